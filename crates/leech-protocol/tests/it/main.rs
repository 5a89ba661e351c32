//! Integration tests of `leech-protocol`: one binary, one module per topic.

mod cobs;
mod crc;
mod frame;
mod golden;
mod link;
mod message;
mod streams;

use leech_protocol::frame::{Decoder, FrameError, MAX_FRAME};
use leech_protocol::link::LinkCounters;
use leech_protocol::message::*;
use proptest::prelude::*;

/// The wire bytes of `command` sent with `seq`.
pub fn command_frame(command: &Command, seq: u8) -> Vec<u8> {
    let mut out = [0u8; MAX_FRAME];
    let len = command.encode_frame(Seq::new(seq).unwrap(), &mut out).unwrap();
    out[..len].to_vec()
}

/// The wire bytes of `report`.
pub fn report_frame(report: &Report) -> Vec<u8> {
    let mut out = [0u8; MAX_FRAME];
    let len = report.encode_frame(&mut out).unwrap();
    out[..len].to_vec()
}

/// Everything a fresh decoder makes of `bytes`, pushed one at a time.
pub fn decode_all(bytes: &[u8]) -> Vec<Result<Vec<u8>, FrameError>> {
    let mut decoder = Decoder::new();
    bytes.iter().filter_map(|&b| decoder.push(b).map(|event| event.map(<[u8]>::to_vec))).collect()
}

pub fn seq() -> impl Strategy<Value = Seq> {
    (1u8..=255).prop_map(|s| Seq::new(s).unwrap())
}

pub fn tube() -> impl Strategy<Value = Tube> {
    prop_oneof![Just(Tube::L1), Just(Tube::L2), Just(Tube::L3)]
}

pub fn cup() -> impl Strategy<Value = Cup> {
    prop_oneof![Just(Cup::Rear), Just(Cup::Front)]
}

pub fn tube_config() -> impl Strategy<Value = TubeConfig> {
    (
        (tube(), any::<bool>(), any::<bool>(), any::<u32>(), any::<i32>(), any::<i32>(), any::<i32>()),
        (any::<u32>(), any::<u16>(), any::<i32>(), any::<i32>(), any::<i32>()),
    )
        .prop_map(|((tube, reverse_motor, reverse_encoder, cpm, origin, min, max), (speed, duty, kp, ki, kd))| {
            TubeConfig {
                tube,
                reverse_motor,
                reverse_encoder,
                counts_per_mm_x1000: cpm,
                origin_um: origin,
                min_um: min,
                max_um: max,
                max_speed_um_s: speed,
                max_duty_permille: duty,
                kp_q16: kp,
                ki_q16: ki,
                kd_q16: kd,
            }
        })
}

pub fn command() -> impl Strategy<Value = Command> {
    prop_oneof![
        Just(Command::Hello),
        Just(Command::Heartbeat),
        Just(Command::Stop),
        any::<[i32; 3]>().prop_map(|lengths_um| Command::SetLengths { lengths_um }),
        (tube(), any::<i32>()).prop_map(|(tube, delta_um)| Command::Jog { tube, delta_um }),
        (cup(), any::<bool>()).prop_map(|(cup, on)| Command::Pump { cup, on }),
        any::<u16>().prop_map(|period_ms| Command::SetTelemetry { period_ms }),
        any::<u16>().prop_map(|f| Command::ClearFaults { faults: Faults(f) }),
        tube_config().prop_map(Command::ConfigureTube),
        any::<[u16; 3]>().prop_map(|[a, d, ms]| Command::ConfigureCups(CupConfig {
            attach_kpa_x10: a,
            detach_kpa_x10: d,
            attach_ms: ms
        })),
    ]
}

pub fn hello() -> impl Strategy<Value = Hello> {
    any::<([u8; 2], [u8; 3], u8, u16)>().prop_map(|([major, minor], [fa, fb, fc], kind, caps)| Hello {
        protocol: Version { major, minor },
        firmware: FirmwareVersion { major: fa, minor: fb, patch: fc },
        kind: DeviceKind(kind),
        capabilities: Capabilities(caps),
    })
}

pub fn refusal() -> impl Strategy<Value = Refusal> {
    (1u8..=6).prop_map(|code| Refusal::from_code(code).unwrap())
}

pub fn ack_status() -> impl Strategy<Value = AckStatus> {
    prop_oneof![
        Just(AckStatus::Ok),
        refusal().prop_map(AckStatus::Refused),
        Just(AckStatus::UnknownType),
        any::<u8>().prop_map(|expected| AckStatus::BadLength { expected }),
        any::<u8>().prop_map(|offset| AckStatus::BadValue { offset }),
    ]
}

pub fn telemetry() -> impl Strategy<Value = Telemetry> {
    (
        (any::<u32>(), any::<[i32; 3]>(), any::<[i32; 3]>(), any::<[i16; 3]>(), any::<[u16; 2]>(), any::<u16>()),
        (any::<[u16; 4]>(), any::<[u8; 4]>()),
    )
        .prop_map(
            |((time_ms, counts, lengths_um, duty, vacuum, faults), (c, [pumps, holding, active, configured]))| {
                Telemetry {
                    time_ms,
                    counts,
                    lengths_um,
                    duty_permille: duty,
                    vacuum_kpa_x10: vacuum,
                    faults: Faults(faults),
                    counters: LinkCounters { rx_frames: c[0], bad_crc: c[1], bad_frames: c[2], duplicates: c[3] },
                    pumps: CupSet(pumps),
                    holding: CupSet(holding),
                    active: TubeSet(active),
                    configured: TubeSet(configured),
                }
            },
        )
}

pub fn report() -> impl Strategy<Value = Report> {
    prop_oneof![
        (proptest::option::of(seq()), hello()).prop_map(|(reply_to, hello)| Report::Hello { reply_to, hello }),
        (seq(), ack_status()).prop_map(|(seq, status)| Report::Ack { seq, status }),
        telemetry().prop_map(Report::Telemetry),
        (any::<u32>(), 0u8..16, any::<u8>()).prop_map(|(time_ms, code, detail)| Report::Fault {
            time_ms,
            code,
            detail
        }),
    ]
}
