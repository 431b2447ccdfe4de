use super::*;
use crate::biotac::wire::tests::reading;

/// A decoded frame of `reading(offset)` with the given invalid channels
/// (zeroed, as the decoder leaves them).
fn frame_with_invalid(sensor: u8, seq: u16, offset: u16, invalid: &[usize]) -> DecodedFrame {
    let mut frame = DecodedFrame {
        sensor,
        seq,
        bridge_us: 0,
        reading: BioTacReading {
            seq,
            ..reading(offset)
        },
        invalid: ChannelMask::default(),
    };
    for &position in invalid {
        frame.invalid.insert(position);
        if let Some(v) = slot(&mut frame.reading, position) {
            *v = 0;
        }
    }
    frame
}

#[test]
fn hold_passes_valid_readings_through() {
    let mut hold = HoldLastGood::new();
    let frame = frame_with_invalid(0, 1, 0, &[]);
    assert_eq!(hold.apply(&frame), Some(frame.reading));
}

#[test]
fn hold_fills_one_invalid_frame_from_the_previous_one() {
    let mut hold = HoldLastGood::new();
    hold.apply(&frame_with_invalid(0, 1, 0, &[]));
    let held = hold.apply(&frame_with_invalid(0, 2, 5, &[12, 38])).unwrap();
    assert_eq!(held.electrodes[6], reading(0).electrodes[6]);
    assert_eq!(held.pdc, reading(0).pdc);
    assert_eq!(held.electrodes[5], reading(5).electrodes[5]);
    assert_eq!(held.seq, 2);
}

#[test]
fn hold_drops_a_channel_invalid_twice_in_a_row() {
    let mut hold = HoldLastGood::new();
    hold.apply(&frame_with_invalid(0, 1, 0, &[]));
    assert!(hold.apply(&frame_with_invalid(0, 2, 0, &[12])).is_some());
    assert_eq!(hold.apply(&frame_with_invalid(0, 3, 0, &[12, 5])), None);
    assert_eq!(hold.apply(&frame_with_invalid(0, 4, 0, &[5])), None);
    assert!(hold.apply(&frame_with_invalid(0, 5, 0, &[12])).is_some());
}

#[test]
fn hold_drops_without_a_previous_frame() {
    let mut hold = HoldLastGood::new();
    assert_eq!(hold.apply(&frame_with_invalid(0, 1, 0, &[3])), None);
    hold.apply(&frame_with_invalid(0, 2, 0, &[]));
    assert_eq!(hold.apply(&frame_with_invalid(0, 4, 0, &[3])), None, "gap");
    hold.apply(&frame_with_invalid(0, 5, 0, &[]));
    assert_eq!(
        hold.apply(&frame_with_invalid(1, 6, 0, &[3])),
        None,
        "other sensor"
    );
    assert_eq!(
        hold.apply(&frame_with_invalid(3, 6, 0, &[])),
        None,
        "no sensor 3"
    );
}

#[test]
fn hold_allows_different_channels_in_consecutive_frames() {
    let mut hold = HoldLastGood::new();
    hold.apply(&frame_with_invalid(2, 65535, 0, &[]));
    let a = hold.apply(&frame_with_invalid(2, 0, 1, &[7])).unwrap();
    let b = hold.apply(&frame_with_invalid(2, 1, 2, &[8])).unwrap();
    assert_eq!(a.pac[3], reading(0).pac[3]);
    assert_eq!(b.electrodes[4], reading(1).electrodes[4]);
}
