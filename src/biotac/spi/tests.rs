use super::*;
use crate::biotac::wire::encode_word;

#[test]
fn command_bytes_are_syntouchs() {
    // SynTouch's biotac.h: PAC 0x80, PDC 0x83, TAC 0x85, TDC 0x86, E1 0xA2,
    // E3 0xA7, E19 0xC7; the SP's E20 0xC8, E24 0xD0.
    let cases = [
        (Channel::Pac, 0x80),
        (Channel::Pdc, 0x83),
        (Channel::Tac, 0x85),
        (Channel::Tdc, 0x86),
        (Channel::Electrode(1), 0xA2),
        (Channel::Electrode(3), 0xA7),
        (Channel::Electrode(19), 0xC7),
        (Channel::Electrode(20), 0xC8),
        (Channel::Electrode(24), 0xD0),
    ];
    for (channel, byte) in cases {
        assert_eq!(channel.command(), byte, "{channel:?}");
        assert_eq!(Channel::from_command(byte), Some(channel));
        assert_eq!(byte.count_ones() % 2, 1, "odd parity");
    }
    assert_eq!(Channel::from_command(0x82), None, "even parity");
    assert_eq!(Channel::from_command(0x22), None, "not a sampling command");
}

#[test]
fn default_sequences_interleave_pac() {
    let seq = default_sequence(SensorModel::BioTac);
    assert_eq!(seq.len(), 44);
    assert_eq!(seq[0], Channel::Electrode(1));
    assert_eq!(seq[36], Channel::Electrode(19));
    assert_eq!(
        &seq[38..],
        &[
            Channel::Pdc,
            Channel::Pac,
            Channel::Tac,
            Channel::Pac,
            Channel::Tdc,
            Channel::Pac
        ]
    );
    assert_eq!(seq.iter().filter(|c| **c == Channel::Pac).count(), 22);
    let sp = default_sequence(SensorModel::BioTacSp);
    assert_eq!(sp.len(), 54);
    assert_eq!(sp[46], Channel::Electrode(24));
    assert_eq!(sp.iter().filter(|c| **c == Channel::Pac).count(), 27);
}

#[test]
fn a_sample_period_is_one_4400th_of_a_second() {
    for slots in [&[0u8][..], &[0, 1], &[0, 1, 2]] {
        let plan = BatchPlan::new(SensorModel::BioTac, slots, 1).unwrap();
        let bit_ns = 1e6 / f64::from(BITRATE_KHZ);
        let bits = 8 * plan.bytes_per_sample() as u32 + SS_CHANGE_BITS * plan.ss_changes();
        let total = f64::from(bits) * bit_ns
            + f64::from(AFTER_SAMPLE_NS + INTERWORD_NS + ADAPTER_OVERHEAD_NS)
            + f64::from(plan.fill_delay_ns());
        assert!((total - 1e9 / 4400.0).abs() < 1.0, "{slots:?}: {total} ns");
        // 44 samples: one frame every 10 ms.
        assert!((44.0 * total - 1e7).abs() < 50.0);
    }
    // Three BioTacs: 64 bits + 6 SS changes at 4.4 MHz, 50 + 10 + 3 us.
    let three = BatchPlan::new(SensorModel::BioTac, &[0, 1, 2], 1).unwrap();
    assert_eq!(three.fill_delay_ns(), 138_818);
}

#[test]
fn ops_send_each_command_to_all_then_read_each_sensor() {
    let plan = BatchPlan::new(SensorModel::BioTac, &[2, 0], 2).unwrap();
    assert_eq!(plan.slots(), &[0, 2]);
    let ops = plan.ops();
    assert_eq!(
        &ops[..8],
        &[
            SpiOp::Select(0b101),
            SpiOp::Bytes(vec![0xA2, 0x00]),
            SpiOp::Select(0),
            SpiOp::DelayNs(50_000),
            SpiOp::Select(0b001),
            SpiOp::Bytes(vec![0, 0]),
            SpiOp::Select(0b100),
            SpiOp::Bytes(vec![0, 0]),
        ]
    );
    let shifted: usize = ops
        .iter()
        .map(|op| match op {
            SpiOp::Bytes(b) => b.len(),
            _ => 0,
        })
        .sum();
    assert_eq!(shifted, plan.batch_len());
    assert_eq!(plan.batch_len(), 2 * 44 * 6);
}

#[test]
fn plans_refuse_bad_positions() {
    for bad in [&[][..], &[3], &[0, 0], &[0, 1, 2, 1]] {
        assert!(
            BatchPlan::new(SensorModel::BioTac, bad, 1).is_err(),
            "{bad:?}"
        );
    }
    assert_eq!(
        BatchPlan::new(SensorModel::BioTac, &[0], 0),
        Err(PlanError::Frames)
    );
}

/// The bytes a batch returns when the BioTac at position j answers word
/// `value(j, frame, position)`.
fn returned(plan: &BatchPlan, value: impl Fn(usize, usize, usize) -> u16) -> Vec<u8> {
    let mut bytes = Vec::new();
    for f in 0..plan.frames() {
        for p in 0..plan.model().frame_words() {
            bytes.extend([0xFF, 0xFF]);
            for j in 0..plan.slots().len() {
                bytes.extend(encode_word(value(j, f, p)).to_be_bytes());
            }
        }
    }
    bytes
}

#[test]
fn decode_is_bit_exact_and_flags_invalid_words() {
    let plan = BatchPlan::new(SensorModel::BioTac, &[0, 1, 2], 2).unwrap();
    let value = |j: usize, f: usize, p: usize| ((j * 1000 + f * 100 + p * 7) % 4096) as u16;
    let mut bytes = returned(&plan, value);
    // Sensor 1, frame 0, position 38 (PDC): flip a data bit.
    let at = 38 * plan.bytes_per_sample() + 2 + 2 + 1;
    bytes[at] ^= 0x08;
    let mut seq = [7, 65535, 0];
    let frames = plan.decode(&bytes, &mut seq);
    assert_eq!(frames.len(), 6);
    assert_eq!(seq, [9, 1, 2]);
    let f = &frames[1];
    assert_eq!((f.sensor, f.seq), (1, 65535));
    assert_eq!(f.invalid.positions().collect::<Vec<_>>(), vec![38]);
    assert_eq!(f.reading.pdc, 0);
    let g = &frames[5];
    assert_eq!((g.sensor, g.seq), (2, 1));
    assert!(g.invalid.is_empty());
    for k in 0..19 {
        assert_eq!(g.reading.electrodes[k], value(2, 1, 2 * k));
    }
    assert_eq!(g.reading.pdc, value(2, 1, 38));
    assert_eq!(g.reading.tac, value(2, 1, 40));
    assert_eq!(g.reading.tdc, value(2, 1, 42));
    for n in 0..22 {
        assert_eq!(g.reading.pac[n], value(2, 1, 2 * n + 1));
    }
}

#[test]
fn a_short_batch_gives_the_frames_it_completes() {
    let plan = BatchPlan::new(SensorModel::BioTac, &[0], 3).unwrap();
    let bytes = returned(&plan, |_, _, p| p as u16);
    let mut seq = [0; 3];
    assert_eq!(plan.decode(&bytes[..bytes.len() - 1], &mut seq).len(), 2);
    assert!(plan.decode(&[], &mut seq).is_empty());
}

#[test]
fn a_missing_sensor_answers_only_invalid_words() {
    let plan = BatchPlan::new(SensorModel::BioTac, &[0], 1).unwrap();
    let bytes = vec![0xFF; plan.batch_len()];
    let mut seq = [0; 3];
    let frame = plan.decode(&bytes, &mut seq).remove(0);
    assert_eq!(frame.invalid.len(), 44);
}

#[test]
fn an_sp_frame_fills_24_electrodes_and_27_pac_samples() {
    let plan = BatchPlan::new(SensorModel::BioTacSp, &[0, 2], 1).unwrap();
    assert_eq!(plan.batch_len(), 54 * 6);
    assert!((SensorModel::BioTacSp.frame_period_s() - 54.0 / 4400.0).abs() < 1e-12);
    let value = |j: usize, _: usize, p: usize| (j * 1000 + p) as u16;
    let mut bytes = returned(&plan, value);
    // Position 2, its last PAC sample (position 53): a parity error.
    bytes[53 * plan.bytes_per_sample() + 4 + 1] ^= 0x08;
    let mut seq = [0; 3];
    let frames = plan.decode(&bytes, &mut seq);
    let (a, b) = (&frames[0].reading, &frames[1].reading);
    assert_eq!((a.electrodes.len(), a.pac.len()), (24, 27));
    let want: Vec<u16> = (0..24).map(|k| value(0, 0, 2 * k)).collect();
    assert_eq!(&a.electrodes[..], &want[..]);
    let want: Vec<u16> = (0..27).map(|n| value(0, 0, 2 * n + 1)).collect();
    assert_eq!(&a.pac[..], &want[..]);
    assert_eq!((a.pdc, a.tac, a.tdc), (48, 50, 52));
    assert!(frames[0].invalid.is_empty());
    assert_eq!(frames[1].invalid_names().collect::<Vec<_>>(), ["pac27"]);
    assert_eq!((b.pac[25], b.pac[26]), (1051, 0));
}

#[test]
fn serial_numbers_are_read_from_a_biotac_only() {
    let ops = BatchPlan::serial_number_ops(2);
    assert_eq!(ops[0], SpiOp::Select(4));
    assert_eq!(ops[1], SpiOp::Bytes(vec![0x61, 0x15]));
    let mut answer = vec![0, 0];
    answer.extend(b"BTSIM00000000002");
    assert_eq!(serial_number(&answer).as_deref(), Some("BTSIM00000000002"));
    assert_eq!(serial_number(&[0xFF; 18]), None);
    assert_eq!(serial_number(&[0x00; 18]), None);
    assert_eq!(serial_number(&[0]), None);
}
