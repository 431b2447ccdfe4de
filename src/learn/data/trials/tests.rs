//! Trials cut at rests, at given times, or not at all.

use super::*;
use crate::biotac::BioTacReading;
use crate::wrench::Wrench;
use nalgebra::Vector3;

/// Records at 100 Hz with |F| = `force(t)` along z on a 0.2 N offset.
fn records(n: usize, force: impl Fn(f64) -> f64) -> Vec<Record> {
    (0..n)
        .map(|i| {
            let t = i as f64 * 0.01;
            Record {
                t,
                set: 1,
                trial: 1,
                reading: BioTacReading {
                    seq: 0,
                    stamp_s: t,
                    electrodes: [3000; 19].into(),
                    pdc: 2000,
                    pac: [2000; 22].into(),
                    tdc: 2300,
                    tac: 2000,
                },
                wrench: Wrench::new(Vector3::new(0.0, 0.0, 0.2 + force(t)), Vector3::zeros()),
            }
        })
        .collect()
}

fn firsts(records: &[Record]) -> Vec<usize> {
    (1..records.len())
        .filter(|&i| records[i].trial != records[i - 1].trial)
        .collect()
}

#[test]
fn presses_are_cut_in_the_middle_of_the_rests_between_them() {
    // Presses at 1..2 s, 3..4 s (a 1 s rest), 4.3..5 s (a 0.3 s rest: one press).
    let press = |t: f64| {
        let on = (1.0..2.0).contains(&t) || (3.0..4.0).contains(&t) || (4.3..5.0).contains(&t);
        if on {
            1.0
        } else {
            0.01 * (t * 50.0).sin()
        }
    };
    let mut r = records(600, press);
    let rests = TrialSplit::Rests {
        force_n: 0.1,
        min_rest_s: 0.5,
        rest_samples: 50,
    };
    assert_eq!(split_trials(&mut r, &rests), 2);
    // Rest from 2.00 s to the next contact at 3.00 s: cut at 2.50 s.
    assert_eq!(firsts(&r), [250]);
    assert_eq!(r[0].trial, 1);
    assert_eq!(r[599].trial, 2);

    let shorter = TrialSplit::Rests {
        force_n: 0.1,
        min_rest_s: 0.2,
        rest_samples: 50,
    };
    assert_eq!(split_trials(&mut r, &shorter), 3);
    assert_eq!(firsts(&r), [250, 415]);

    let mut still = records(300, |_| 0.0);
    assert_eq!(split_trials(&mut still, &rests), 1);
}

#[test]
fn given_starts_and_whole_number_the_trials() {
    let mut r = records(500, |_| 0.0);
    assert_eq!(
        split_trials(&mut r, &TrialSplit::Starts(vec![1.0, 3.005])),
        3
    );
    assert_eq!(firsts(&r), [100, 301]);
    assert_eq!(split_trials(&mut r, &TrialSplit::Whole), 1);
    assert!(r.iter().all(|x| x.trial == 1));
    assert_eq!(split_trials(&mut [], &TrialSplit::Whole), 0);
}

#[test]
fn the_trials_option_parses_its_forms_and_refuses_the_rest() {
    assert_eq!("auto".parse::<TrialsArg>(), Ok(TrialsArg::Auto));
    assert_eq!("rests".parse::<TrialsArg>(), Ok(TrialsArg::Rests));
    assert_eq!("whole".parse::<TrialsArg>(), Ok(TrialsArg::Whole));
    assert_eq!(
        "9.6, 15.4".parse::<TrialsArg>(),
        Ok(TrialsArg::Starts(vec![9.6, 15.4]))
    );
    for bad in ["", "x", "5,3", "0,1", "-1", "1,inf"] {
        assert!(bad.parse::<TrialsArg>().is_err(), "{bad}");
    }
}
