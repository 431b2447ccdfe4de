//! Properties of the serial wire codec (`biotac::wire`): the streaming
//! decoder against a plain reference scan, frames found bit-exact at any
//! offset and under any chunking, encode -> decode round trips, and no
//! allocation per push.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

use proptest::array::{uniform19, uniform22};
use proptest::collection::vec;
use proptest::prelude::*;
use tactile_force::biotac::wire::{
    crc16_ccitt_false, decode_frame, encode_frame, ChannelMask, DecodedFrame, Decoder, FRAME_LEN,
    N_SENSORS,
};
use tactile_force::biotac::{BioTacReading, ADC_MAX};

/// Counts this thread's allocations (tests run on parallel threads).
struct Counting;

thread_local! {
    static ALLOCATIONS: Cell<usize> = const { Cell::new(0) };
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.with(|n| n.set(n.get() + 1));
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

/// Readings with 12-bit values; `seq` and `stamp_s` are not on the wire.
fn reading() -> impl Strategy<Value = BioTacReading> {
    (
        uniform19(0..=ADC_MAX),
        uniform22(0..=ADC_MAX),
        [0..=ADC_MAX, 0..=ADC_MAX, 0..=ADC_MAX],
        any::<u16>(),
        -1e6..1e6,
    )
        .prop_map(
            |(electrodes, pac, [pdc, tdc, tac], seq, stamp_s)| BioTacReading {
                seq,
                stamp_s,
                electrodes: electrodes.into(),
                pdc,
                pac: pac.into(),
                tdc,
                tac,
            },
        )
}

/// Sensor index, sequence number, bridge time and reading of a frame.
fn frame_fields() -> impl Strategy<Value = (u8, u16, u32, BioTacReading)> {
    (0..N_SENSORS as u8, any::<u16>(), any::<u32>(), reading())
}

/// A valid frame of arbitrary fields.
fn frame() -> impl Strategy<Value = [u8; FRAME_LEN]> {
    frame_fields().prop_map(|(sensor, seq, us, r)| encode_frame(sensor, seq, us, &r))
}

/// A frame with a correct CRC around arbitrary words (invalid ones likely).
fn frame_with_any_words() -> impl Strategy<Value = [u8; FRAME_LEN]> {
    (frame(), vec(any::<u8>(), 88)).prop_map(|(mut f, words)| {
        f[10..98].copy_from_slice(&words);
        let crc = crc16_ccitt_false(&f[2..98]);
        f[98..].copy_from_slice(&crc.to_le_bytes());
        f
    })
}

/// Pieces a serial stream is made of: garbage, frames, torn and corrupted
/// frames, and false sync patterns.
fn segment() -> impl Strategy<Value = Vec<u8>> {
    prop_oneof![
        vec(any::<u8>(), 0..300),
        frame().prop_map(|f| f.to_vec()),
        frame_with_any_words().prop_map(|f| f.to_vec()),
        (frame(), 0..FRAME_LEN).prop_map(|(f, n)| f[..n].to_vec()),
        (frame(), 0..FRAME_LEN, 1..=u8::MAX).prop_map(|(mut f, at, x)| {
            f[at] ^= x;
            f.to_vec()
        }),
        Just(vec![0xAA, 0x55, 0x01, 0x00]),
        Just(vec![0xAA]),
    ]
}

/// A stream of up to 16 segments.
fn stream() -> impl Strategy<Value = Vec<u8>> {
    vec(segment(), 0..16).prop_map(|s| s.concat())
}

/// Chunk sizes the stream is pushed in, cycled.
fn chunk_sizes() -> impl Strategy<Value = Vec<usize>> {
    vec(1..300usize, 1..20)
}

/// Pushes `bytes` in chunks of the given sizes (cycled).
fn decode_chunked(bytes: &[u8], sizes: &[usize]) -> (Vec<DecodedFrame>, Decoder) {
    let mut decoder = Decoder::new();
    let mut frames = Vec::new();
    let mut rest = bytes;
    for &size in sizes.iter().cycle() {
        if rest.is_empty() {
            break;
        }
        let (chunk, tail) = rest.split_at(size.min(rest.len()));
        decoder.push(chunk, |f| frames.push(f));
        rest = tail;
    }
    (frames, decoder)
}

/// The decoder's contract spelt out: at each offset, a frame if the next
/// 100 bytes decode (then jump over it), else the next offset.
fn reference_scan(bytes: &[u8]) -> Vec<(usize, DecodedFrame)> {
    let mut found = Vec::new();
    let mut at = 0;
    while let Some(window) = bytes.get(at..).and_then(|b| b.first_chunk::<FRAME_LEN>()) {
        match decode_frame(window) {
            Ok(frame) => {
                found.push((at, frame));
                at += FRAME_LEN;
            }
            Err(_) => at += 1,
        }
    }
    found
}

/// The decoder agrees with the reference scan, every frame it yields has a
/// correct CRC in the input, and every byte is accounted for.
fn check_against_reference(bytes: &[u8], sizes: &[usize]) -> Result<(), TestCaseError> {
    let (frames, decoder) = decode_chunked(bytes, sizes);
    let expected = reference_scan(bytes);
    for &(at, _) in &expected {
        let window = &bytes[at..at + FRAME_LEN];
        let crc = u16::from_le_bytes([window[98], window[99]]);
        prop_assert_eq!(crc16_ccitt_false(&window[2..98]), crc);
    }
    let expected: Vec<DecodedFrame> = expected.into_iter().map(|(_, f)| f).collect();
    prop_assert_eq!(&frames, &expected);
    let stats = decoder.stats();
    prop_assert_eq!(stats.frames, frames.len() as u64);
    let invalid: usize = frames.iter().map(|f| f.invalid.len()).sum();
    prop_assert_eq!(stats.parity_errors, invalid as u64);
    prop_assert!(decoder.pending() < FRAME_LEN);
    prop_assert_eq!(
        stats.frames * FRAME_LEN as u64 + stats.bytes_skipped + decoder.pending() as u64,
        bytes.len() as u64
    );
    Ok(())
}

/// The frame the decoder must return for a valid encoding of these fields:
/// the header's sequence number, no stamp, no invalid channel.
fn valid_frame(sensor: u8, seq: u16, bridge_us: u32, r: &BioTacReading) -> DecodedFrame {
    DecodedFrame {
        sensor,
        seq,
        bridge_us,
        reading: BioTacReading {
            seq,
            stamp_s: 0.0,
            ..*r
        },
        invalid: ChannelMask::default(),
    }
}

proptest! {
    #[test]
    fn arbitrary_bytes_decode_like_the_reference_scan(
        bytes in vec(any::<u8>(), 0..4000),
        sizes in chunk_sizes(),
    ) {
        check_against_reference(&bytes, &sizes)?;
    }

    #[test]
    fn mixed_streams_decode_like_the_reference_scan(
        bytes in stream(),
        sizes in chunk_sizes(),
    ) {
        check_against_reference(&bytes, &sizes)?;
    }

    /// The prefix holds no 0xAA, so no sync starts before the frame (a sync
    /// in arbitrary garbage could by chance start a valid frame overlapping
    /// ours); the suffix is arbitrary.
    #[test]
    fn embedded_frame_is_found_bit_exact(
        prefix in vec(any::<u8>().prop_map(|b| if b == 0xAA { 0xAB } else { b }), 0..500),
        (sensor, seq, us, r) in frame_fields(),
        suffix in vec(any::<u8>(), 0..500),
        sizes in chunk_sizes(),
    ) {
        let bytes = [&prefix[..], &encode_frame(sensor, seq, us, &r), &suffix].concat();
        let (frames, decoder) = decode_chunked(&bytes, &sizes);
        let expected = valid_frame(sensor, seq, us, &r);
        prop_assert_eq!(frames.first(), Some(&expected));
        prop_assert!(decoder.stats().bytes_skipped >= prefix.len() as u64);
    }

    #[test]
    fn encode_decode_round_trips((sensor, seq, us, r) in frame_fields()) {
        let decoded = decode_frame(&encode_frame(sensor, seq, us, &r));
        prop_assert_eq!(decoded, Ok(valid_frame(sensor, seq, us, &r)));
    }
}

#[test]
fn push_allocates_nothing() {
    let r = BioTacReading {
        seq: 0,
        stamp_s: 0.0,
        electrodes: [2000; 19].into(),
        pdc: 1500,
        pac: [2048; 22].into(),
        tdc: 2600,
        tac: 2040,
    };
    let mut bytes: Vec<u8> = (0..300u16)
        .flat_map(|seq| encode_frame((seq % 3) as u8, seq / 3, 0, &r))
        .collect();
    bytes[5_050] ^= 0x40; // one corrupted frame
    bytes.extend_from_slice(&[0xAA, 0x55, 0x01, 0x00, 0x13]);
    let mut decoder = Decoder::new();
    let mut frames = 0;
    let before = ALLOCATIONS.with(Cell::get);
    for chunk in bytes.chunks(37) {
        decoder.push(chunk, |_| frames += 1);
    }
    assert_eq!(ALLOCATIONS.with(Cell::get), before);
    assert_eq!(frames, 299);
    assert_eq!(decoder.stats().crc_errors, 1);
}
