//! Throughput of the serial frame decoder (`biotac::wire::Decoder`) in
//! frames per second, against the 100 frames/s one sensor produces:
//!
//! - `valid`: 10 000 valid frames (1 MB, three sensors interleaved);
//! - `corrupted_1pct`: the same bytes with 1% of them changed at random
//!   (about 63% of the frames fail their CRC and the decoder resynchronises).
//!
//! Both push the buffer in 4096-byte chunks (a large serial read); the
//! throughput counts the 10 000 frames sent, decoded or not. After the
//! criterion group, a plain loop prints each case's median frames/s and its
//! ratio to 100 frames/s, which criterion does not report.
//!
//! Run with `cargo bench --bench wire` (about 10 s).

use std::hint::black_box;
use std::time::{Duration, Instant};

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use tactile_force::biotac::wire::{encode_frame, Decoder, FRAME_LEN, N_SENSORS};
use tactile_force::biotac::{BioTacReading, ADC_MAX};

/// Frames in the buffer.
const FRAMES: usize = 10_000;
/// Bytes per push.
const CHUNK: usize = 4096;
/// Share of bytes corrupted in the second case.
const CORRUPTED: f64 = 0.01;
/// Frames one sensor sends per second.
const SENSOR_FRAMES_PER_S: f64 = 100.0;
/// Timed decodes per case in the plain loop.
const REPEATS: usize = 21;
/// Seed of the readings and the corruption.
const SEED: u64 = 7;

/// `FRAMES` frames of random 12-bit readings, sensors interleaved.
fn valid_stream(rng: &mut ChaCha8Rng) -> Vec<u8> {
    let mut value = || rng.random_range(0..=ADC_MAX);
    (0..FRAMES)
        .flat_map(|i| {
            let reading = BioTacReading {
                seq: 0,
                stamp_s: 0.0,
                electrodes: std::array::from_fn::<u16, 19, _>(|_| value()).into(),
                pdc: value(),
                pac: std::array::from_fn::<u16, 22, _>(|_| value()).into(),
                tdc: value(),
                tac: value(),
            };
            let sensor = i % N_SENSORS;
            let seq = (i / N_SENSORS) as u16;
            encode_frame(sensor as u8, seq, 10_000 * u32::from(seq), &reading)
        })
        .collect()
}

/// `bytes` with a share `CORRUPTED` of them changed.
fn corrupt(bytes: &[u8], rng: &mut ChaCha8Rng) -> Vec<u8> {
    let mut out = bytes.to_vec();
    for _ in 0..(bytes.len() as f64 * CORRUPTED) as usize {
        let at = rng.random_range(0..out.len());
        out[at] ^= rng.random_range(1..=u8::MAX);
    }
    out
}

/// Decodes `bytes` in `CHUNK`-byte pushes; returns the frames decoded.
fn decode(bytes: &[u8]) -> usize {
    let mut decoder = Decoder::new();
    let mut frames = 0;
    for chunk in bytes.chunks(CHUNK) {
        decoder.push(chunk, |frame| {
            black_box(&frame);
            frames += 1;
        });
    }
    frames
}

/// Median wall time of `REPEATS` decodes of `bytes` (s).
fn median_s(bytes: &[u8]) -> f64 {
    let mut times: Vec<f64> = (0..REPEATS)
        .map(|_| {
            let t0 = Instant::now();
            black_box(decode(black_box(bytes)));
            t0.elapsed().as_secs_f64()
        })
        .collect();
    times.sort_by(f64::total_cmp);
    times[REPEATS / 2]
}

fn benches(c: &mut Criterion) {
    let mut rng = ChaCha8Rng::seed_from_u64(SEED);
    let valid = valid_stream(&mut rng);
    let corrupted = corrupt(&valid, &mut rng);
    assert_eq!(valid.len(), FRAMES * FRAME_LEN);
    let cases = [("valid", &valid), ("corrupted_1pct", &corrupted)];

    let mut group = c.benchmark_group("decoder");
    group.throughput(Throughput::Elements(FRAMES as u64));
    for (name, bytes) in cases {
        group.bench_function(name, |b| b.iter(|| decode(black_box(bytes))));
    }
    group.finish();

    for (name, bytes) in cases {
        let per_s = FRAMES as f64 / median_s(bytes);
        println!(
            "decoder/{name:<15} median {per_s:10.3e} frames/s = {:8.0} x one sensor's {SENSOR_FRAMES_PER_S} frames/s ({} of {FRAMES} frames decoded)",
            per_s / SENSOR_FRAMES_PER_S,
            decode(bytes),
        );
    }
}

criterion_group! {
    name = wire;
    config = Criterion::default()
        .sample_size(20)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(2));
    targets = benches
}
criterion_main!(wire);
