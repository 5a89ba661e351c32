//! Link rules: retries, duplicates and replays, link loss, the last-cup
//! rule, holding, versions, counters.

use leech_protocol::frame::{Counters, Decoder};
use leech_protocol::link::*;
use leech_protocol::message::*;

fn device_hello() -> Hello {
    Hello {
        protocol: PROTOCOL_VERSION,
        firmware: FirmwareVersion { major: 1, minor: 2, patch: 3 },
        kind: DeviceKind::SIMULATOR,
        capabilities: Capabilities(0b11),
    }
}

fn s(seq: u8) -> Seq {
    Seq::new(seq).unwrap()
}

/// A device: a frame decoder, a responder, and the commands it executed.
struct Device {
    decoder: Decoder,
    responder: Responder,
    executed: Vec<Command>,
}

impl Device {
    fn new() -> Device {
        Device { decoder: Decoder::new(), responder: Responder::new(device_hello()), executed: vec![] }
    }

    /// Feeds wire bytes; returns the reports it answers with.
    fn receive(&mut self, bytes: &[u8]) -> Vec<Report> {
        let mut answers = vec![];
        for &b in bytes {
            if let Some(Ok(message)) = self.decoder.push(b) {
                let executed = &mut self.executed;
                answers.extend(self.responder.handle(message, |c| {
                    executed.push(c);
                    match c {
                        Command::Pump { on: false, .. } => AckStatus::Refused(Refusal::LastCup),
                        _ => AckStatus::Ok,
                    }
                }));
            }
        }
        answers
    }

    fn counters(&self) -> LinkCounters {
        LinkCounters::collect(self.decoder.counters(), &self.responder)
    }
}

fn ack(seq: u8, status: AckStatus) -> Report {
    Report::Ack { seq: s(seq), status }
}

#[test]
fn a_replayed_command_is_answered_again_but_executed_once() {
    let mut device = Device::new();
    let jog = crate::command_frame(&Command::Jog { tube: Tube::L1, delta_um: 500 }, 7);
    assert_eq!(device.receive(&jog), [ack(7, AckStatus::Ok)]);
    assert_eq!(device.receive(&jog), [ack(7, AckStatus::Ok)]);
    assert_eq!(device.receive(&jog), [ack(7, AckStatus::Ok)]);
    assert_eq!(device.executed, [Command::Jog { tube: Tube::L1, delta_um: 500 }]);
    assert_eq!(device.responder.duplicates(), 2);
    // The next seq is new.
    assert_eq!(device.receive(&crate::command_frame(&Command::Stop, 8)), [ack(8, AckStatus::Ok)]);
    assert_eq!(device.executed.len(), 2);
    assert_eq!(device.counters(), LinkCounters { rx_frames: 4, bad_crc: 0, bad_frames: 0, duplicates: 2 });
}

#[test]
fn a_retry_gets_the_refusal_it_had() {
    let mut device = Device::new();
    let off = crate::command_frame(&Command::Pump { cup: Cup::Rear, on: false }, 3);
    let refused = ack(3, AckStatus::Refused(Refusal::LastCup));
    assert_eq!(device.receive(&off), [refused]);
    assert_eq!(device.receive(&off), [refused]);
    assert_eq!(device.executed.len(), 1);
}

#[test]
fn only_the_last_seq_is_a_duplicate() {
    let mut device = Device::new();
    let stop = |seq| crate::command_frame(&Command::Stop, seq);
    device.receive(&stop(1));
    device.receive(&stop(2));
    // Seq 1 again after 2 is a new command (the host never retries an old seq).
    device.receive(&stop(1));
    assert_eq!(device.executed.len(), 3);
    assert_eq!(device.responder.duplicates(), 0);
}

#[test]
fn hello_starts_a_session_and_forgets_the_last_seq() {
    let mut device = Device::new();
    assert_eq!(device.responder.boot_hello(), Report::Hello { reply_to: None, hello: device_hello() });
    let stop = crate::command_frame(&Command::Stop, 1);
    device.receive(&stop);
    let hello = crate::command_frame(&Command::Hello, 9);
    let answer = Report::Hello { reply_to: Some(s(9)), hello: device_hello() };
    assert_eq!(device.receive(&hello), [answer]);
    // A retried Hello is simply answered again.
    assert_eq!(device.receive(&hello), [answer]);
    // A new host starting again at seq 1 is executed, not taken for a retry.
    assert_eq!(device.receive(&stop), [ack(1, AckStatus::Ok)]);
    assert_eq!(device.executed, [Command::Stop, Command::Stop]);
    assert_eq!(device.responder.duplicates(), 0);
}

#[test]
fn undecodable_commands_are_answered_and_remembered_like_others() {
    let mut device = Device::new();
    let mut out = [0u8; 66];
    let len = leech_protocol::frame::encode(&[0x55, 4, 1, 2], &mut out).unwrap();
    assert_eq!(device.receive(&out[..len]), [ack(4, AckStatus::UnknownType)]);
    assert_eq!(device.receive(&out[..len]), [ack(4, AckStatus::UnknownType)]);
    let len = leech_protocol::frame::encode(&[0x04, 5, 1, 2], &mut out).unwrap();
    assert_eq!(device.receive(&out[..len]), [ack(5, AckStatus::BadLength { expected: 12 })]);
    let len = leech_protocol::frame::encode(&[0x06, 6, 2, 1], &mut out).unwrap();
    assert_eq!(device.receive(&out[..len]), [ack(6, AckStatus::BadValue { offset: 0 })]);
    assert!(device.executed.is_empty());
    assert_eq!(device.responder.duplicates(), 1);
}

#[test]
fn a_command_with_seq_0_is_dropped_and_counted() {
    let mut device = Device::new();
    let mut out = [0u8; 66];
    let len = leech_protocol::frame::encode(&[0x03, 0], &mut out).unwrap();
    assert_eq!(device.receive(&out[..len]), []);
    assert!(device.executed.is_empty());
    assert_eq!(device.responder.dropped(), 1);
    assert_eq!(device.counters(), LinkCounters { rx_frames: 1, bad_crc: 0, bad_frames: 1, duplicates: 0 });
}

#[test]
fn counters_truncate_to_16_bits() {
    let frames = Counters { frames: 0x1_0005, bad_crc: 0xFFFF_FFFF, bad_frames: 0x2_0000 };
    let c = LinkCounters::collect(frames, &Responder::new(device_hello()));
    assert_eq!(c, LinkCounters { rx_frames: 5, bad_crc: 0xFFFF, bad_frames: 0, duplicates: 0 });
}

#[test]
fn the_host_retries_five_times_then_gives_up() {
    let t0 = 1000;
    let mut p = Pending::new(s(12), t0);
    assert_eq!(p.poll(t0), Retry::Wait);
    assert_eq!(p.poll(t0 + ACK_TIMEOUT_MS - 1), Retry::Wait);
    let mut resends = vec![];
    let mut t = t0;
    loop {
        t += 1;
        match p.poll(t) {
            Retry::Wait => {}
            Retry::Resend => resends.push(t - t0),
            Retry::GiveUp => break,
        }
    }
    assert_eq!(resends, [50, 100, 150, 200, 250]);
    assert_eq!(t - t0, 300);
    assert!(t - t0 < LINK_TIMEOUT_MS);
    assert_eq!(p.sends(), 1 + MAX_RETRIES);
    assert_eq!(p.seq(), s(12));
}

#[test]
fn the_retry_clock_may_wrap() {
    let mut p = Pending::new(Seq::FIRST, u32::MAX - 10);
    assert_eq!(p.poll(20), Retry::Wait);
    assert_eq!(p.poll((u32::MAX - 10).wrapping_add(ACK_TIMEOUT_MS)), Retry::Resend);
}

#[test]
fn answers_are_matched_by_seq() {
    let p = Pending::new(s(5), 0);
    assert!(p.is_answered_by(&ack(5, AckStatus::Ok)));
    assert!(!p.is_answered_by(&ack(4, AckStatus::Ok)));
    assert!(p.is_answered_by(&Report::Hello { reply_to: Some(s(5)), hello: device_hello() }));
    assert!(!p.is_answered_by(&Report::Hello { reply_to: None, hello: device_hello() }));
    assert!(!p.is_answered_by(&Report::Telemetry(Telemetry::default())));
}

#[test]
fn the_link_is_lost_once_after_500_ms_of_silence_and_only_after_a_first_frame() {
    let mut watch = LinkWatch::new();
    // Not armed: a device waiting for its host never loses a link.
    assert!(!watch.expired(10_000));
    watch.frame(10_000);
    assert!(!watch.expired(10_499));
    watch.frame(10_400);
    assert!(!watch.expired(10_899));
    assert!(watch.expired(10_900));
    // Once: then disarmed until the next frame.
    assert!(!watch.expired(20_000));
    watch.frame(30_000);
    assert!(watch.expired(30_000 + LINK_TIMEOUT_MS));
    // Across the clock's wrap.
    watch.frame(u32::MAX - 100);
    assert!(!watch.expired(300));
    assert!(watch.expired(399));
}

#[test]
fn the_last_cup_rule() {
    let cup = |pump_on, holding| CupState { pump_on, holding };
    let off = cup(false, false);
    let attaching = cup(true, false);
    let holds = cup(true, true);
    // Switching on is always allowed.
    for a in [off, attaching, holds] {
        for b in [off, attaching, holds] {
            assert_eq!(last_cup_allows(Cup::Rear, true, [a, b]), Ok(()));
            assert_eq!(last_cup_allows(Cup::Front, true, [a, b]), Ok(()));
        }
    }
    // Releasing a holding cup needs the other to hold.
    assert_eq!(last_cup_allows(Cup::Rear, false, [holds, holds]), Ok(()));
    assert_eq!(last_cup_allows(Cup::Rear, false, [holds, off]), Err(Refusal::LastCup));
    assert_eq!(last_cup_allows(Cup::Rear, false, [holds, attaching]), Err(Refusal::NotHolding));
    assert_eq!(last_cup_allows(Cup::Front, false, [off, holds]), Err(Refusal::LastCup));
    assert_eq!(last_cup_allows(Cup::Front, false, [attaching, holds]), Err(Refusal::NotHolding));
    assert_eq!(last_cup_allows(Cup::Front, false, [holds, holds]), Ok(()));
    // A cup that does not hold may always be switched off.
    assert_eq!(last_cup_allows(Cup::Rear, false, [attaching, off]), Ok(()));
    assert_eq!(last_cup_allows(Cup::Front, false, [off, attaching]), Ok(()));
    assert_eq!(last_cup_allows(Cup::Front, false, [off, off]), Ok(()));
}

#[test]
fn holding_with_and_without_a_sensor() {
    let c = CupConfig::default(); // 30 kPa on, 20 kPa off, 1 s without a sensor
    assert!(!holds(false, true, 299, 5000, &c));
    assert!(holds(false, true, 300, 0, &c));
    // Hysteresis: a holding cup keeps holding down to 20 kPa.
    assert!(holds(true, true, 200, 0, &c));
    assert!(!holds(true, true, 199, 0, &c));
    // A pump that is off never holds.
    assert!(!holds(true, false, 900, 5000, &c));
    // Without a sensor: by the time the pump has run.
    assert!(!holds(false, true, NO_SENSOR, 999, &c));
    assert!(holds(false, true, NO_SENSOR, 1000, &c));
    assert!(!holds(true, false, NO_SENSOR, 5000, &c));
}

#[test]
fn a_different_major_version_is_an_error_naming_both() {
    assert_eq!(check_version(PROTOCOL_VERSION), Ok(()));
    assert_eq!(check_version(Version { major: PROTOCOL_VERSION.major, minor: 9 }), Ok(()));
    let device = Version { major: 2, minor: 1 };
    let error = check_version(device).unwrap_err();
    assert_eq!(error, VersionMismatch { host: PROTOCOL_VERSION, device });
    assert_eq!(
        error.to_string(),
        "protocol version mismatch: the host speaks 1.0, the device speaks 2.1 (the major versions must match)"
    );
}

#[test]
fn timing_constants() {
    // The spec's numbers; their relations are checked where they are defined.
    assert_eq!((ACK_TIMEOUT_MS, MAX_RETRIES, LINK_TIMEOUT_MS, HEARTBEAT_MS), (50, 5, 500, 100));
    assert_eq!((MIN_TELEMETRY_PERIOD_MS, BOOT_TIMEOUT_MS, BAUD_RATE, LIMIT_MARGIN_UM), (10, 3000, 115_200, 2000));
}

#[test]
fn a_report_type_sent_to_the_device_is_never_answered() {
    let mut device = Device::new();
    let mut out = [0u8; 66];
    // An echo of the device's own Ack for seq 5: answering it would be
    // echoed again, for ever.
    let len = leech_protocol::frame::encode(&[0x80, 5, 0, 0], &mut out).unwrap();
    assert_eq!(device.receive(&out[..len]), []);
    assert_eq!(device.receive(&out[..len]), []);
    assert!(device.executed.is_empty());
    assert_eq!(device.responder.dropped(), 2);
    assert_eq!(device.responder.duplicates(), 0);
}
