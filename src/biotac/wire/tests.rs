use super::decoder::seq_lost;
use super::*;

/// A reading whose 44 values all differ, shifted by `offset` (shared with
/// the invalid-sample policy's tests).
pub(in crate::biotac) fn reading(offset: u16) -> BioTacReading {
    let value = |i: usize| (i as u16 * 89 + offset) % (ADC_MAX + 1);
    BioTacReading {
        seq: 0,
        stamp_s: 0.0,
        electrodes: std::array::from_fn::<u16, 19, _>(value).into(),
        pdc: value(19),
        pac: std::array::from_fn::<u16, N_PAC, _>(|i| value(20 + i)).into(),
        tdc: value(42),
        tac: value(43),
    }
}

/// Decodes `bytes` in one push; returns the frames and the decoder.
fn decode_all(bytes: &[u8]) -> (Vec<DecodedFrame>, Decoder) {
    let mut decoder = Decoder::new();
    let mut frames = Vec::new();
    decoder.push(bytes, |f| frames.push(f));
    (frames, decoder)
}

/// Overwrites word `position` of an encoded frame and fixes the CRC.
fn set_word(frame: &mut [u8; FRAME_LEN], position: usize, word: u16) {
    let at = HEADER_LEN + 2 * position;
    frame[at..at + 2].copy_from_slice(&word.to_le_bytes());
    let crc = crc16_ccitt_false(&frame[2..98]);
    frame[98..].copy_from_slice(&crc.to_le_bytes());
}

#[test]
fn every_12_bit_value_round_trips() {
    for value in 0..=ADC_MAX {
        assert_eq!(decode_word(encode_word(value)), Ok(value), "{value}");
    }
}

#[test]
fn word_layout_matches_the_architecture_page() {
    // D = 0b1010_1100_1011: D[11:5] = 0b1010110, D[4:0] = 0b01011.
    let word = encode_word(0b1010_1100_1011);
    assert_eq!(word >> 9, 0b1010110);
    assert_eq!((word >> 3) & 0x1F, 0b01011);
    assert_eq!(word & 0b110, 0);
    let [high, low] = word.to_be_bytes();
    assert_eq!(high.count_ones() % 2, 1);
    assert_eq!(low.count_ones() % 2, 1);
}

#[test]
fn every_single_bit_flip_is_detected() {
    for value in 0..=ADC_MAX {
        for bit in 0..16 {
            let flipped = encode_word(value) ^ (1 << bit);
            let err = decode_word(flipped).expect_err("flip went undetected");
            // A flip can turn the high byte into 0xA5 (even parity too).
            let expected = if flipped >> 8 == u16::from(ERROR_WORD_HIGH) {
                WordError::ErrorWord { word: flipped }
            } else {
                WordError::Parity { word: flipped }
            };
            assert_eq!(err, expected, "value {value} bit {bit}");
        }
    }
}

#[test]
fn words_starting_0xa5_are_error_words() {
    for low in 0..=u8::MAX {
        let word = u16::from_be_bytes([ERROR_WORD_HIGH, low]);
        assert_eq!(decode_word(word), Err(WordError::ErrorWord { word }));
    }
}

#[test]
fn reserved_bits_are_rejected_when_parity_holds() {
    let word = encode_word(1234) | 0b110; // two flips: parity unchanged
    assert_eq!(decode_word(word), Err(WordError::Reserved { word }));
}

#[test]
#[cfg(debug_assertions)]
#[should_panic(expected = "does not fit in 12 bits")]
fn encode_word_refuses_13_bits_in_debug() {
    encode_word(ADC_MAX + 1);
}

#[test]
#[cfg(not(debug_assertions))]
fn encode_word_masks_to_12_bits_in_release() {
    assert_eq!(decode_word(encode_word(0xF123)), Ok(0x123));
}

#[test]
fn crc_matches_the_standard_check_value() {
    assert_eq!(crc16_ccitt_false(b"123456789"), 0x29B1);
    assert_eq!(crc16_ccitt_false(&[]), 0xFFFF);
}

#[test]
fn crc_table_matches_bitwise_crc() {
    let bitwise = |bytes: &[u8]| {
        bytes.iter().fold(CRC_INIT, |mut crc, &b| {
            crc ^= u16::from(b) << 8;
            for _ in 0..8 {
                crc = if crc & 0x8000 != 0 {
                    (crc << 1) ^ CRC_POLY
                } else {
                    crc << 1
                };
            }
            crc
        })
    };
    let bytes: Vec<u8> = (0..=u8::MAX).chain((0..=u8::MAX).rev()).collect();
    for end in 0..bytes.len() {
        assert_eq!(crc16_ccitt_false(&bytes[..end]), bitwise(&bytes[..end]));
    }
}

#[test]
fn channel_names_follow_the_frame_order() {
    use ElectrodeLayout::{Biotac, BiotacSp};
    for (layout, words) in [(Biotac, N_WORDS), (BiotacSp, MAX_WORDS)] {
        assert_eq!(frame_words(layout), words);
        let n = layout.count();
        for k in 0..n {
            assert_eq!(channel_name(2 * k, layout), Some(format!("e{}", k + 1)));
        }
        for k in 0..layout.pac_per_frame() {
            assert_eq!(
                channel_name(2 * k + 1, layout),
                Some(format!("pac{}", k + 1))
            );
        }
        let name = |p| channel_name(p, layout);
        assert_eq!(name(2 * n).as_deref(), Some("pdc"));
        assert_eq!(name(2 * n + 2).as_deref(), Some("tac"));
        assert_eq!(name(2 * n + 4).as_deref(), Some("tdc"));
        assert_eq!(name(words), None);
    }
}

#[test]
fn slots_follow_the_frame_order() {
    let r = reading(1);
    let values = to_frame_order(&r);
    assert_eq!(values[12], r.electrodes[6]); // e7
    assert_eq!(values[5], r.pac[2]); // pac3
    assert_eq!(values[38], r.pdc);
    assert_eq!(values[40], r.tac);
    assert_eq!(values[42], r.tdc);
    assert_eq!(values[43], r.pac[21]);
    let mut sorted = values.to_vec();
    sorted.sort_unstable();
    sorted.dedup();
    assert_eq!(
        sorted.len(),
        N_WORDS + 1,
        "every field appears once, then 0"
    );
    assert_eq!(values[N_WORDS..], [0; MAX_WORDS - N_WORDS]);
    // A BioTac SP's frame: E20 where a BioTac's PDC is, PDC at 48.
    let mut sp = BioTacReading::zeroed(ElectrodeLayout::BiotacSp);
    for p in 0..MAX_WORDS {
        *slot(&mut sp, p).unwrap() = p as u16;
    }
    assert_eq!((sp.electrodes[19], sp.electrodes[23]), (38, 46));
    assert_eq!((sp.pdc, sp.tac, sp.tdc), (48, 50, 52));
    assert_eq!((sp.pac[0], sp.pac[26]), (1, 53));
    assert_eq!(to_frame_order(&sp), std::array::from_fn(|p| p as u16));
}

#[test]
fn the_bridge_frame_carries_a_biotacs_44_words_of_an_sp_reading() {
    let mut sp = BioTacReading::zeroed(ElectrodeLayout::BiotacSp);
    for p in 0..MAX_WORDS {
        *slot(&mut sp, p).unwrap() = p as u16 + 1;
    }
    let back = decode_frame(&encode_frame(0, 1, 0, &sp)).unwrap().reading;
    assert_eq!(&back.electrodes[..], &sp.electrodes[..N_ELECTRODES]);
    assert_eq!(&back.pac[..], &sp.pac[..N_PAC]);
    assert_eq!((back.pdc, back.tac, back.tdc), (sp.pdc, sp.tac, sp.tdc));
}

#[test]
fn channel_mask_lists_names_in_frame_order() {
    let mut mask = ChannelMask::default();
    for position in [42, 12, 5, 38, 40, 53, 54, 100] {
        mask.insert(position);
    }
    assert_eq!(mask.len(), 6);
    assert!(mask.contains(12) && !mask.contains(13) && mask.contains(53) && !mask.contains(54));
    assert_eq!(
        mask.names(ElectrodeLayout::Biotac).collect::<Vec<_>>(),
        ["pac3", "e7", "pdc", "tac", "tdc"]
    );
    assert_eq!(
        mask.names(ElectrodeLayout::BiotacSp).collect::<Vec<_>>(),
        ["pac3", "e7", "e20", "e21", "e22", "pac27"]
    );
}

#[test]
fn frame_layout_matches_the_spec() {
    let r = reading(3);
    let frame = encode_frame(2, 0x1234, 0xDEAD_BEEF, &r);
    assert_eq!(frame[..4], [0xAA, 0x55, 1, 2]);
    assert_eq!(frame[4..6], [0x34, 0x12]);
    assert_eq!(frame[6..10], [0xEF, 0xBE, 0xAD, 0xDE]);
    let word =
        |position: usize| u16::from_le_bytes([frame[10 + 2 * position], frame[11 + 2 * position]]);
    assert_eq!(word(0), encode_word(r.electrodes[0]));
    assert_eq!(word(1), encode_word(r.pac[0]));
    assert_eq!(word(36), encode_word(r.electrodes[18]));
    assert_eq!(word(38), encode_word(r.pdc));
    assert_eq!(word(40), encode_word(r.tac));
    assert_eq!(word(42), encode_word(r.tdc));
    assert_eq!(word(43), encode_word(r.pac[21]));
    let crc = crc16_ccitt_false(&frame[2..98]);
    assert_eq!(frame[98..], crc.to_le_bytes());
}

#[test]
fn frame_round_trips_and_takes_seq_from_the_header() {
    let r = BioTacReading {
        seq: 999,
        stamp_s: 4.5,
        ..reading(7)
    };
    let decoded = decode_frame(&encode_frame(1, 65535, 42, &r)).unwrap();
    assert_eq!(
        decoded,
        DecodedFrame {
            sensor: 1,
            seq: 65535,
            bridge_us: 42,
            reading: BioTacReading {
                seq: 65535,
                stamp_s: 0.0,
                ..r
            },
            invalid: ChannelMask::default(),
        }
    );
}

#[test]
fn decode_frame_reports_each_header_fault() {
    let good = encode_frame(0, 1, 2, &reading(0));
    let with = |at: usize, byte: u8| {
        let mut f = good;
        f[at] = byte;
        decode_frame(&f)
    };
    assert_eq!(
        with(1, 0x56),
        Err(FrameError::Sync {
            found: [0xAA, 0x56]
        })
    );
    assert_eq!(with(2, 2), Err(FrameError::Version { found: 2 }));
    assert_eq!(with(3, 3), Err(FrameError::Sensor { found: 3 }));
    let computed = crc16_ccitt_false(
        &{
            let mut f = good;
            f[50] ^= 0x10;
            f
        }[2..98],
    );
    let received = u16::from_le_bytes([good[98], good[99]]);
    assert_eq!(
        with(50, good[50] ^ 0x10),
        Err(FrameError::Crc { received, computed })
    );
}

#[test]
fn invalid_words_are_zeroed_and_listed() {
    let mut frame = encode_frame(0, 5, 0, &reading(9));
    set_word(&mut frame, 12, encode_word(100) ^ 1); // e7: parity
    set_word(&mut frame, 38, 0xA5A5); // pdc: error word
    let decoded = decode_frame(&frame).unwrap();
    assert_eq!(decoded.invalid_names().collect::<Vec<_>>(), ["e7", "pdc"]);
    assert_eq!(decoded.reading.electrodes[6], 0);
    assert_eq!(decoded.reading.pdc, 0);
    assert_eq!(decoded.reading.electrodes[5], reading(9).electrodes[5]);
    let (_, decoder) = decode_all(&frame);
    assert_eq!(decoder.stats().parity_errors, 2);
}

#[test]
fn decoder_finds_frames_fed_byte_by_byte() {
    let bytes: Vec<u8> = (0..5)
        .flat_map(|i| encode_frame(i % 3, i.into(), 0, &reading(i.into())))
        .collect();
    let mut decoder = Decoder::new();
    let mut seqs = Vec::new();
    for byte in &bytes {
        decoder.push(std::slice::from_ref(byte), |f| seqs.push(f.seq));
    }
    assert_eq!(seqs, [0, 1, 2, 3, 4]);
    assert_eq!(decoder.pending(), 0);
    assert_eq!(decoder.stats().bytes_skipped, 0);
}

#[test]
fn decoder_resyncs_after_garbage() {
    let mut bytes = vec![0x00, 0xAA, 0xAA, 0x55, 0x01, 0x07, 0x55, 0xAA];
    bytes.extend_from_slice(&encode_frame(0, 1, 0, &reading(0)));
    let (frames, decoder) = decode_all(&bytes);
    assert_eq!(frames.len(), 1);
    assert_eq!(decoder.stats().bytes_skipped, 8);
    assert_eq!(
        decoder.stats().crc_errors,
        0,
        "bad sensor byte rejected early"
    );
}

#[test]
fn torn_frame_does_not_hide_the_next_one() {
    let torn = encode_frame(0, 1, 0, &reading(1));
    let mut bytes = torn[..60].to_vec();
    bytes.extend_from_slice(&encode_frame(0, 2, 0, &reading(2)));
    let (frames, decoder) = decode_all(&bytes);
    assert_eq!(frames.iter().map(|f| f.seq).collect::<Vec<_>>(), [2]);
    assert_eq!(decoder.stats().crc_errors, 1);
    assert_eq!(decoder.stats().bytes_skipped, 60);
}

#[test]
fn false_sync_resumes_at_the_next_byte() {
    // A sync with a good prefix 10 bytes before a real frame: its CRC
    // fails, and the real frame starts inside its 100 bytes.
    let mut bytes = vec![0xAA, 0x55, 0x01, 0x00, 0, 0, 0, 0, 0, 0];
    bytes.extend_from_slice(&encode_frame(1, 7, 0, &reading(5)));
    let (frames, decoder) = decode_all(&bytes);
    assert_eq!(frames.len(), 1);
    assert_eq!(frames[0].reading.electrodes, reading(5).electrodes);
    assert_eq!(decoder.stats().crc_errors, 1);
    assert_eq!(decoder.stats().bytes_skipped, 10);
}

#[test]
fn garbage_never_grows_the_buffer() {
    let mut decoder = Decoder::new();
    let patterns: [&[u8]; 3] = [&[0xAA], &[0xAA, 0x55, 0x01, 0x00], &[0x00, 0x55, 0xAA]];
    for pattern in patterns {
        for _ in 0..10_000 {
            decoder.push(pattern, |_| panic!("no frame in garbage"));
            assert!(decoder.pending() < FRAME_LEN);
        }
    }
    let s = decoder.stats();
    assert_eq!(s.bytes_skipped + decoder.pending() as u64, 80_000);
}

#[test]
fn sequence_gaps_are_counted_per_sensor() {
    let seqs: [(u8, u16); 8] = [
        (0, 10),    // first frame of sensor 0: not a gap
        (1, 65534), // first frame of sensor 1
        (0, 11),
        (1, 65535),
        (0, 14), // 2 lost
        (1, 0),  // wrap: not a gap
        (1, 3),  // 2 lost
        (0, 15),
    ];
    let bytes: Vec<u8> = seqs
        .iter()
        .flat_map(|&(sensor, seq)| encode_frame(sensor, seq, 0, &reading(0)))
        .collect();
    let (frames, decoder) = decode_all(&bytes);
    assert_eq!(frames.len(), 8);
    assert_eq!(decoder.stats().lost, [2, 2, 0]);
    assert_eq!(decoder.stats().restarts, 0);
}

#[test]
fn backward_sequence_jump_is_a_restart_not_a_gap() {
    let bytes: Vec<u8> = [500u16, 501, 0, 1, 3, 3]
        .iter()
        .flat_map(|&seq| encode_frame(2, seq, 0, &reading(0)))
        .collect();
    let (_, decoder) = decode_all(&bytes);
    assert_eq!(decoder.stats().lost, [0, 0, 1]);
    assert_eq!(decoder.stats().restarts, 2, "501 -> 0 and 3 -> 3");
    assert_eq!(seq_lost(0, 32_768), Some(32_767));
    assert_eq!(seq_lost(0, 32_769), None);
}
