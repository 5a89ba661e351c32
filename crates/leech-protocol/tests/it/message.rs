//! Messages: every one round-trips, lengths match the table, and every kind
//! of bad bytes is a decode error that says what was wrong.

use leech_protocol::frame::{MAX_MESSAGE, MAX_PAYLOAD};
use leech_protocol::link::LinkCounters;
use leech_protocol::message::*;
use leech_protocol::BufferTooSmall;
use proptest::prelude::*;

use crate::{command, report, seq};

fn command_bytes(command: &Command, seq: u8) -> Vec<u8> {
    let mut out = [0u8; MAX_MESSAGE];
    let len = command.encode(Seq::new(seq).unwrap(), &mut out).unwrap();
    out[..len].to_vec()
}

fn report_bytes(report: &Report) -> Vec<u8> {
    let mut out = [0u8; MAX_MESSAGE];
    let len = report.encode(&mut out).unwrap();
    out[..len].to_vec()
}

fn config() -> TubeConfig {
    TubeConfig {
        tube: Tube::L2,
        reverse_motor: false,
        reverse_encoder: true,
        counts_per_mm_x1000: 160_000,
        origin_um: 100_000,
        min_um: 50_000,
        max_um: 400_000,
        max_speed_um_s: 20_000,
        max_duty_permille: 800,
        kp_q16: 65_536,
        ki_q16: 0,
        kd_q16: 6_554,
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    #[test]
    fn every_command_round_trips(command in command(), seq in seq()) {
        let bytes = command_bytes(&command, seq.get());
        prop_assert_eq!(bytes[0], command.type_byte());
        prop_assert_eq!(bytes[1], seq.get());
        prop_assert_eq!(Some(bytes.len() - 2), types::body_len(command.type_byte()));
        prop_assert!(bytes.len() + 2 <= MAX_PAYLOAD);
        prop_assert_eq!(Command::decode(&bytes), Ok((seq, command)));
        // And through a frame.
        let events = crate::decode_all(&crate::command_frame(&command, seq.get()));
        prop_assert_eq!(events, vec![Ok(bytes)]);
    }

    #[test]
    fn every_report_round_trips(report in report()) {
        let bytes = report_bytes(&report);
        prop_assert_eq!(bytes[0], report.type_byte());
        prop_assert_eq!(bytes[1], report.seq_byte());
        prop_assert_eq!(Some(bytes.len() - 2), types::body_len(report.type_byte()));
        prop_assert!(bytes.len() + 2 <= MAX_PAYLOAD);
        prop_assert_eq!(Report::decode(&bytes), Ok(report));
        let events = crate::decode_all(&crate::report_frame(&report));
        prop_assert_eq!(events, vec![Ok(bytes)]);
    }

    #[test]
    fn a_wrong_length_is_bad_length(command in command(), extra in 1usize..8, cut in any::<bool>()) {
        let mut bytes = command_bytes(&command, 9);
        let expected = bytes.len() - 2;
        if cut && expected > 0 {
            bytes.truncate(2 + (expected - 1).min(extra - 1));
        } else {
            bytes.extend(std::iter::repeat_n(0u8, extra));
        }
        let found = bytes.len() - 2;
        prop_assert_eq!(
            Command::decode(&bytes),
            Err(DecodeError::BadLength { type_byte: command.type_byte(), seq: 9, expected: expected as u8, found })
        );
    }
}

#[test]
fn the_layout_of_each_command() {
    let seq = 0x21;
    let cases: Vec<(Command, Vec<u8>)> = vec![
        (Command::Hello, vec![0x01, seq]),
        (Command::Heartbeat, vec![0x02, seq]),
        (Command::Stop, vec![0x03, seq]),
        (
            Command::SetLengths { lengths_um: [1, -2, 0x01020304] },
            vec![0x04, seq, 1, 0, 0, 0, 0xFE, 0xFF, 0xFF, 0xFF, 4, 3, 2, 1],
        ),
        (Command::Jog { tube: Tube::L3, delta_um: -1000 }, vec![0x05, seq, 2, 0x18, 0xFC, 0xFF, 0xFF]),
        (Command::Pump { cup: Cup::Front, on: true }, vec![0x06, seq, 1, 1]),
        (Command::SetTelemetry { period_ms: 10 }, vec![0x07, seq, 10, 0]),
        (Command::ClearFaults { faults: Faults::LINK_LOST.union(Faults::LIMIT_HIT) }, vec![0x08, seq, 0x09, 0]),
        (
            Command::ConfigureCups(CupConfig { attach_kpa_x10: 300, detach_kpa_x10: 200, attach_ms: 1000 }),
            vec![0x0A, seq, 0x2C, 0x01, 0xC8, 0x00, 0xE8, 0x03],
        ),
    ];
    for (command, bytes) in cases {
        assert_eq!(command_bytes(&command, seq), bytes, "{command:?}");
    }
    let tube = command_bytes(&Command::ConfigureTube(config()), seq);
    let body = &tube[2..];
    assert_eq!(tube[0], 0x09);
    assert_eq!(body.len(), 36);
    assert_eq!(body[0], 1, "tube");
    assert_eq!(body[1], 0b10, "flags: reverse encoder");
    assert_eq!(&body[2..6], &160_000u32.to_le_bytes(), "counts_per_mm_x1000");
    assert_eq!(&body[6..10], &100_000i32.to_le_bytes(), "origin_um");
    assert_eq!(&body[10..14], &50_000i32.to_le_bytes(), "min_um");
    assert_eq!(&body[14..18], &400_000i32.to_le_bytes(), "max_um");
    assert_eq!(&body[18..22], &20_000u32.to_le_bytes(), "max_speed_um_s");
    assert_eq!(&body[22..24], &800u16.to_le_bytes(), "max_duty_permille");
    assert_eq!(&body[24..28], &65_536i32.to_le_bytes(), "kp_q16");
    assert_eq!(&body[28..32], &0i32.to_le_bytes(), "ki_q16");
    assert_eq!(&body[32..36], &6_554i32.to_le_bytes(), "kd_q16");
}

#[test]
fn the_layout_of_each_report() {
    let hello = Hello {
        protocol: Version { major: 1, minor: 0 },
        firmware: FirmwareVersion { major: 2, minor: 3, patch: 4 },
        kind: DeviceKind::MEGA,
        capabilities: Capabilities::REAR_VACUUM_SENSOR,
    };
    let s = Seq::new(0x21).unwrap();
    assert_eq!(report_bytes(&Report::Hello { reply_to: None, hello }), [0x81, 0, 1, 0, 2, 3, 4, 1, 1, 0]);
    assert_eq!(report_bytes(&Report::Hello { reply_to: Some(s), hello })[1], 0x21);
    let ack = |status| report_bytes(&Report::Ack { seq: s, status });
    assert_eq!(ack(AckStatus::Ok), [0x80, 0x21, 0, 0]);
    assert_eq!(ack(AckStatus::Refused(Refusal::LastCup)), [0x80, 0x21, 1, 1]);
    assert_eq!(ack(AckStatus::Refused(Refusal::NotConfigured)), [0x80, 0x21, 1, 6]);
    assert_eq!(ack(AckStatus::UnknownType), [0x80, 0x21, 2, 0]);
    assert_eq!(ack(AckStatus::BadLength { expected: 12 }), [0x80, 0x21, 3, 12]);
    assert_eq!(ack(AckStatus::BadValue { offset: 0 }), [0x80, 0x21, 4, 0]);
    assert_eq!(report_bytes(&Report::Fault { time_ms: 0x0102_0304, code: 1, detail: 2 }), [0x83, 0, 4, 3, 2, 1, 1, 2]);
    let t = Telemetry {
        time_ms: 0x0403_0201,
        counts: [0x11, 0x12, 0x13],
        lengths_um: [0x21, 0x22, 0x23],
        duty_permille: [-1000, 0x31, 1000],
        vacuum_kpa_x10: [0x41, NO_SENSOR],
        faults: Faults(0x0051),
        counters: LinkCounters { rx_frames: 0x61, bad_crc: 0x62, bad_frames: 0x63, duplicates: 0x64 },
        pumps: CupSet(0b11),
        holding: CupSet(0b01),
        active: TubeSet(0b101),
        configured: TubeSet::ALL,
    };
    let bytes = report_bytes(&Report::Telemetry(t));
    let body = &bytes[2..];
    assert_eq!(&bytes[..2], [0x82, 0]);
    assert_eq!(body.len(), 52);
    assert_eq!(&body[0..4], [1, 2, 3, 4], "time_ms");
    assert_eq!(&body[4..16], [0x11, 0, 0, 0, 0x12, 0, 0, 0, 0x13, 0, 0, 0], "counts");
    assert_eq!(&body[16..28], [0x21, 0, 0, 0, 0x22, 0, 0, 0, 0x23, 0, 0, 0], "lengths_um");
    assert_eq!(&body[28..34], [0x18, 0xFC, 0x31, 0, 0xE8, 0x03], "duty_permille");
    assert_eq!(&body[34..38], [0x41, 0, 0xFF, 0xFF], "vacuum_kpa_x10");
    assert_eq!(&body[38..40], [0x51, 0], "faults");
    assert_eq!(&body[40..48], [0x61, 0, 0x62, 0, 0x63, 0, 0x64, 0], "counters");
    assert_eq!(&body[48..52], [0b11, 0b01, 0b101, 0b111], "pumps, holding, active, configured");
}

#[test]
fn the_type_table() {
    let commands = [0x01, 0x02, 0x03, 0x04, 0x05, 0x06, 0x07, 0x08, 0x09, 0x0A];
    let reports = [0x80, 0x81, 0x82, 0x83];
    for t in 0..=255u8 {
        let known = commands.contains(&t) || reports.contains(&t);
        assert_eq!(types::body_len(t).is_some(), known, "type {t:#04x}");
        assert_eq!(types::name(t).is_some(), known, "type {t:#04x}");
        assert_eq!(types::from_device(t), t >= 0x80);
    }
    // Every body fits the largest payload.
    assert!((0..=255u8).filter_map(types::body_len).all(|len| len + 4 <= MAX_PAYLOAD));
}

#[test]
fn encode_refuses_a_short_buffer() {
    let mut out = [0u8; 13];
    assert_eq!(
        Command::SetLengths { lengths_um: [0; 3] }.encode(Seq::FIRST, &mut out),
        Err(BufferTooSmall { needed: 14, available: 13 })
    );
    assert_eq!(Report::Telemetry(Telemetry::default()).encode(&mut out).unwrap_err().needed, 54);
}

#[test]
fn closed_sets_are_checked_with_the_field_offset() {
    let cases: [(&[u8], &str, u8, u8); 6] = [
        (&[0x05, 3, 3, 0, 0, 0, 0], "tube", 0, 3),
        (&[0x06, 3, 2, 1], "cup", 0, 2),
        (&[0x06, 3, 0, 2], "on", 1, 2),
        (
            &[
                0x09, 3, 7, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0,
                0, 0, 0, 0, 0,
            ],
            "tube",
            0,
            7,
        ),
        (&[0x05, 3, 0xFF, 0, 0, 0, 0], "tube", 0, 0xFF),
        (&[0x06, 3, 0, 0xFF], "on", 1, 0xFF),
    ];
    for (bytes, field, offset, value) in cases {
        let error = Command::decode(bytes).unwrap_err();
        assert_eq!(error, DecodeError::BadValue { type_byte: bytes[0], seq: 3, field, offset, value });
        assert_eq!(error.ack(), Some((Seq::new(3).unwrap(), AckStatus::BadValue { offset })));
    }
    assert_eq!(
        Command::decode(&[0x05, 3, 3, 0, 0, 0, 0]).unwrap_err().to_string(),
        "Jog (0x05) (seq 3): tube = 3 at body offset 0 is not an allowed value"
    );
    // Reports: the ack's status and reason, the fault's code.
    let bad = |bytes: &[u8]| Report::decode(bytes).unwrap_err();
    assert!(matches!(bad(&[0x80, 1, 5, 0]), DecodeError::BadValue { field: "status", offset: 0, value: 5, .. }));
    assert!(matches!(bad(&[0x80, 1, 1, 0]), DecodeError::BadValue { field: "reason", offset: 1, value: 0, .. }));
    assert!(matches!(bad(&[0x80, 1, 1, 7]), DecodeError::BadValue { field: "reason", offset: 1, value: 7, .. }));
    assert!(matches!(bad(&[0x83, 0, 0, 0, 0, 0, 16, 0]), DecodeError::BadValue { field: "code", offset: 4, .. }));
}

#[test]
fn reserved_bits_are_kept_and_unused_detail_bytes_ignored() {
    // Bit 7 of a flags byte is reserved: ignored, not an error.
    let mut bytes = command_bytes(&Command::ConfigureTube(config()), 1);
    bytes[3] |= 0x80;
    assert_eq!(Command::decode(&bytes), Ok((Seq::FIRST, Command::ConfigureTube(config()))));
    // An Ok ack with a non-zero detail byte is still Ok.
    assert_eq!(Report::decode(&[0x80, 4, 0, 9]), Ok(Report::Ack { seq: Seq::new(4).unwrap(), status: AckStatus::Ok }));
    // Faults bits beyond the named ones travel as they are.
    assert_eq!(Command::decode(&[0x08, 1, 0x00, 0x80]).unwrap().1, Command::ClearFaults { faults: Faults(0x8000) });
}

#[test]
fn sequence_numbers_fit_the_type() {
    // A command must carry 1..=255: seq 0 cannot be answered.
    assert_eq!(Command::decode(&[0x03, 0]), Err(DecodeError::BadSeq { type_byte: 0x03, seq: 0 }));
    assert_eq!(Command::decode(&[0x03, 0]).unwrap_err().ack(), None);
    assert_eq!(Report::decode(&[0x80, 0, 0, 0]), Err(DecodeError::BadSeq { type_byte: 0x80, seq: 0 }));
    let telemetry = report_bytes(&Report::Telemetry(Telemetry::default()));
    let mut numbered = telemetry.clone();
    numbered[1] = 5;
    assert_eq!(Report::decode(&numbered), Err(DecodeError::BadSeq { type_byte: 0x82, seq: 5 }));
    assert_eq!(Report::decode(&[0x83, 1, 0, 0, 0, 0, 0, 0]), Err(DecodeError::BadSeq { type_byte: 0x83, seq: 1 }));
    // A Hello may be either.
    assert!(matches!(Report::decode(&[0x81, 0, 1, 0, 0, 0, 0, 0, 0, 0]), Ok(Report::Hello { reply_to: None, .. })));
    assert!(matches!(
        Report::decode(&[0x81, 7, 1, 0, 0, 0, 0, 0, 0, 0]),
        Ok(Report::Hello { reply_to: Some(s), .. }) if s.get() == 7
    ));
    assert_eq!(
        DecodeError::BadSeq { type_byte: 0x03, seq: 0 }.to_string(),
        "Stop (0x03) with seq 0: commands and acks need 1..=255, telemetry and faults 0"
    );
}

#[test]
fn unknown_and_wrong_direction_types() {
    assert_eq!(Command::decode(&[0x55, 4]), Err(DecodeError::UnknownType { type_byte: 0x55, seq: 4 }));
    assert_eq!(Command::decode(&[0x55, 4]).unwrap_err().ack(), Some((Seq::new(4).unwrap(), AckStatus::UnknownType)));
    // A report sent to the device (an echo) is unknown there, and vice versa.
    assert_eq!(Command::decode(&[0x80, 4, 0, 0]), Err(DecodeError::UnknownType { type_byte: 0x80, seq: 4 }));
    assert_eq!(Report::decode(&[0x03, 4]), Err(DecodeError::UnknownType { type_byte: 0x03, seq: 4 }));
    assert_eq!(Command::decode(&[0x03]), Err(DecodeError::TooShort { len: 1 }));
    assert_eq!(Report::decode(&[]), Err(DecodeError::TooShort { len: 0 }));
    assert_eq!(Command::decode(&[0x55, 4]).unwrap_err().to_string(), "unknown message type 0x55 (seq 4)");
    assert_eq!(
        Command::decode(&[0x04, 4, 0]).unwrap_err().to_string(),
        "SetLengths (0x04) (seq 4): a 1-byte body, the type has 12 bytes"
    );
    assert_eq!(Command::decode(&[0x04, 4, 0]).unwrap_err().ack().unwrap().1, AckStatus::BadLength { expected: 12 });
}

#[test]
fn seq_counts_1_to_255_and_skips_0() {
    let mut s = Seq::FIRST;
    let mut seen = vec![];
    for _ in 0..300 {
        seen.push(s.get());
        s = s.next();
    }
    assert_eq!(seen[..3], [1, 2, 3]);
    assert_eq!(seen[254..258], [255, 1, 2, 3]);
    assert!(!seen.contains(&0));
    assert_eq!(Seq::new(0), None);
}

#[test]
fn tube_lengths_from_counts() {
    let c = config(); // 160 counts/mm, origin 100 mm
    assert_eq!(c.length_um(0), 100_000);
    assert_eq!(c.length_um(160), 101_000);
    assert_eq!(c.length_um(-160), 99_000);
    // 1 count = 6.25 um: truncated toward zero either side.
    assert_eq!(c.length_um(1), 100_006);
    assert_eq!(c.length_um(-1), 99_994);
    let extreme = TubeConfig { counts_per_mm_x1000: 1, origin_um: i32::MAX, ..c };
    assert_eq!(extreme.length_um(i32::MAX), i32::MAX);
    assert_eq!(TubeConfig { origin_um: i32::MIN, ..extreme }.length_um(i32::MIN), i32::MIN);
    assert_eq!(TubeConfig { counts_per_mm_x1000: 0, ..c }.length_um(5000), 100_000);
}

#[test]
fn configurations_are_checked_field_by_field() {
    assert_eq!(config().check(), Ok(()));
    let field = |c: TubeConfig| c.check().unwrap_err().field;
    assert_eq!(field(TubeConfig { counts_per_mm_x1000: 0, ..config() }), "counts_per_mm_x1000");
    assert_eq!(field(TubeConfig { min_um: 500_000, ..config() }), "max_um");
    assert_eq!(field(TubeConfig { max_speed_um_s: 0, ..config() }), "max_speed_um_s");
    assert_eq!(field(TubeConfig { max_duty_permille: 0, ..config() }), "max_duty_permille");
    assert_eq!(field(TubeConfig { max_duty_permille: 1001, ..config() }), "max_duty_permille");
    assert_eq!(field(TubeConfig { ki_q16: -1, ..config() }), "ki_q16");
    assert_eq!(
        TubeConfig { min_um: 500_000, ..config() }.check().unwrap_err().to_string(),
        "max_um must be at least min_um"
    );
    assert_eq!(CupConfig::default().check(), Ok(()));
    assert_eq!(
        CupConfig { attach_kpa_x10: 0, detach_kpa_x10: 0, attach_ms: 0 }.check().unwrap_err().field,
        "attach_kpa_x10"
    );
    assert_eq!(CupConfig { detach_kpa_x10: 301, ..CupConfig::default() }.check().unwrap_err().field, "detach_kpa_x10");
}

#[test]
fn bit_sets_and_names() {
    assert_eq!(Faults::default().to_string(), "none");
    assert_eq!(Faults::LINK_LOST.union(Faults::VACUUM_LOST).to_string(), "link_lost+vacuum_lost");
    assert_eq!(Faults(1 << 9 | 1).to_string(), "link_lost+bit 9");
    assert_eq!(Faults::from_code(3), Some(Faults::LIMIT_HIT));
    assert_eq!(Faults::from_code(16), None);
    assert_eq!(Faults::name(5), Some("brownout_reset"));
    assert_eq!(Faults::name(6), None);
    assert!(Faults(0b111).contains(Faults::MOTOR_STALL));
    assert_eq!(Faults(0b111).without(Faults::MOTOR_STALL), Faults(0b101));
    let cups = CupSet::default().with(Cup::Front, true);
    assert!(cups.contains(Cup::Front) && !cups.contains(Cup::Rear));
    assert_eq!(cups.0, 0b10);
    let tubes = TubeSet::ALL.with(Tube::L2, false);
    assert_eq!(tubes.0, 0b101);
    assert!(!tubes.contains(Tube::L2) && tubes.contains(Tube::L3));
    assert!(Capabilities(0b11).contains(Capabilities::FRONT_VACUUM_SENSOR));
    assert_eq!(DeviceKind(9).to_string(), "device kind 9");
    assert_eq!(Tube::L3.to_string(), "L3");
    assert_eq!(Cup::Rear.other(), Cup::Front);
    assert_eq!(
        AckStatus::Refused(Refusal::LastCup).to_string(),
        "refused: the other cup's pump is off: this cup is the last one holding"
    );
}

#[test]
fn faults_are_named_for_people() {
    assert_eq!(Fault::reported(1, 1).to_string(), "a motor stall on tube L2");
    assert_eq!(Fault::reported(0, 0).to_string(), "link lost");
    assert_eq!(Fault::reported(2, 0).to_string(), "vacuum lost on the rear cup");
    assert_eq!(Fault::reported(2, 1).to_string(), "vacuum lost on the front cup");
    assert_eq!(Fault::reported(3, 2).to_string(), "a tube past its length limits on tube L3");
    assert_eq!(Fault::reported(4, 0).to_string(), "a watchdog reset");
    assert_eq!(Fault::reported(5, 0).to_string(), "a brown-out reset");
    assert_eq!(Fault::reported(1, 7).to_string(), "a motor stall on tube index 7 (no such tube)");
    assert_eq!(Fault::reported(9, 3).to_string(), "fault 9 (detail 3)");
    // Known from the latched bits only: no detail.
    let latched = Fault::latched(Faults::MOTOR_STALL.union(Faults::LIMIT_HIT)).unwrap();
    assert_eq!(latched, Fault { code: 1, detail: None });
    assert_eq!(latched.to_string(), "a motor stall");
    assert_eq!(Fault::latched(Faults::default()), None);
}
