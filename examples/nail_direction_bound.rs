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
    let q = &config.protocol;
    let radial = &q.radial;
    let person = Person::new(&config, 1);
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    for pad_known in [false, true] {
        let mut at_smallest = Vec::new();
        let mut largest = Vec::new();
        for r in 0..recordings {
            let session = Session::new(&config, 3 + (r % 4) as u64);
            let mut bounds = Vec::new();
            for d in 0..radial.directions {
                let (s, c) = radial.direction_rad(d).sin_cos();
                for cycle in 1..radial.cycles {
                    let ft = q.max_traction_ratio * radial.normal_peak_n * f64::from(cycle)
                        / f64::from(radial.cycles - 1);
                    let roll = rng.random::<f64>() * std::f64::consts::TAU;
                    let centre = |rng: &mut ChaCha8Rng, a: f64| {
                        rng.random_range(q.pressure_centre_mm[0]..q.pressure_centre_mm[1])
                            + q.pressure_roll_mm * a
                    };
                    let pressing = Pressing {
                        force: [ft * c, ft * s, radial.normal_peak_n],
                        centre_mm: [centre(&mut rng, roll.cos()), centre(&mut rng, roll.sin())],
                        twist_nmm: rng.random_range(q.twist_nmm[0]..q.twist_nmm[1]),
                    };
                    let b = direction_bound_deg(&config, &person, &session, &pressing, pad_known)
                        .expect("a peak presses with a tangential force");
                    if cycle == 1 {
                        at_smallest.push(b);
                    }
                    bounds.push(b);
                }
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
            "pad {}: bound at the 1.25 N peaks (one frame, std): median {:.2} deg, largest {:.2} \
             deg; largest error of 48 peaks at the bound: median {:.2} deg, 90 % within {:.2} \
             deg; {:.0} % of recordings within {TARGET_DEG} deg",
            if pad_known { "given" } else { "unknown" },
            q(&at_smallest, 0.5),
            q(&at_smallest, 1.0),
            q(&largest, 0.5),
            q(&largest, 0.9),
            100.0 * within / largest.len() as f64,
        );
    }
}
