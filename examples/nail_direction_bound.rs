//! The direction error no model can beat on the simulated nail camera:
//! the Cramér-Rao bound of one frame (`tactile_force::nail::bound`) at the
//! 48 peaks of Watanabe's 360° test (`collect --protocol radial`: 12
//! directions, tangential peaks 1.25, 2.5, 3.75 and 5 N at 10 N normal),
//! the pad pressed as the shipped protocol draws it, person 1 in sessions
//! 3 to 6. Then the largest error of 48 peaks an estimator that reaches
//! the bound would make, by drawing its errors.
//!
//! Usage: cargo run --release --example nail_direction_bound [recordings]

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;
use tactile_force::nail::bound::direction_bound_deg;
use tactile_force::nail::collect::radial_peaks;
use tactile_force::nail::sim::{NailSimConfig, Person, Pressing, Session};

/// Draws of the 48 errors per recording.
const DRAWS: usize = 1000;
/// Watanabe's target (deg).
const TARGET_DEG: f64 = 2.5;

fn main() {
    let recordings: usize = match std::env::args().nth(1).map(|a| a.parse()) {
        None => 40,
        Some(Ok(n)) if n > 0 => n,
        Some(_) => {
            eprintln!("usage: nail_direction_bound [recordings, a positive whole number]");
            std::process::exit(2);
        }
    };
    let config = NailSimConfig::default();
    let person = Person::new(&config, 1);
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let (mut smallest, mut n_peaks) = (f64::INFINITY, 0);
    for pad_known in [false, true] {
        let mut at_smallest = Vec::new();
        let mut largest = Vec::new();
        for r in 0..recordings {
            let session = Session::new(&config, 3 + (r % 4) as u64);
            let peaks = radial_peaks(&config, &mut rng);
            let shear = |p: &Pressing| p.force[0].hypot(p.force[1]);
            smallest = peaks.iter().map(shear).fold(f64::INFINITY, f64::min);
            n_peaks = peaks.len();
            let mut bounds = Vec::new();
            for p in &peaks {
                let b = direction_bound_deg(&config, &person, &session, p, pad_known)
                    .expect("a peak presses with a tangential force");
                if shear(p) < smallest + 1e-9 {
                    at_smallest.push(b);
                }
                bounds.push(b);
            }
            for _ in 0..DRAWS {
                let worst = bounds
                    .iter()
                    .map(|b| (b * rng.sample::<f64, _>(StandardNormal)).abs())
                    .fold(0.0, f64::max);
                largest.push(worst);
            }
        }
        at_smallest.sort_by(f64::total_cmp);
        largest.sort_by(f64::total_cmp);
        let q = |v: &[f64], p: f64| v[((v.len() - 1) as f64 * p).round() as usize];
        let within = largest.iter().filter(|&&e| e <= TARGET_DEG).count() as f64;
        println!(
            "pad {}: bound at the {smallest:.2} N peaks (one frame, std): median {:.2} deg, \
             largest {:.2} deg; largest error of {n_peaks} peaks at the bound: median {:.2} deg, \
             90 % within {:.2} deg; {:.0} % of recordings within {TARGET_DEG} deg",
            if pad_known { "given" } else { "unknown" },
            q(&at_smallest, 0.5),
            q(&at_smallest, 1.0),
            q(&largest, 0.5),
            q(&largest, 0.9),
            100.0 * within / largest.len() as f64,
        );
    }
}
