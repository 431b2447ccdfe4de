//! Data sets: reading, plausibility, records, folds and tares.

use super::*;
use std::io::Write;

fn write(text: &str) -> tempfile::NamedTempFile {
    let mut f = tempfile::NamedTempFile::new().unwrap();
    f.write_all(text.as_bytes()).unwrap();
    f
}

#[test]
fn reads_only_the_needed_columns_and_names_a_missing_one() {
    let f = write("t,set,trial,e1,junk,fz,fx\n0,1,1,10,x,0.5,0.1\n0.01,1,2,12,y,0.7,0.2\n");
    let axes: AxisSet = "fx,fz".parse().unwrap();
    let ds = Dataset::read_csv(f.path(), &["e1".into()], &axes, Counts::Raw).unwrap();
    assert_eq!(ds.x.column(0).to_vec(), vec![10.0, 12.0]);
    assert_eq!(ds.y.row(1).to_vec(), vec![0.2, 0.7]);
    assert_eq!(ds.trial, vec![1, 2]);
    let err = Dataset::read_csv(f.path(), &["e2".into()], &axes, Counts::Raw).unwrap_err();
    assert!(err.to_string().contains("missing column \"e2\""), "{err}");
    let err = Dataset::read_csv(f.path(), &["junk".into()], &axes, Counts::Raw).unwrap_err();
    assert!(err.to_string().contains("line 2, column \"junk\""), "{err}");
}

#[test]
fn values_that_cannot_be_true_are_refused_with_their_line_even_in_crlf_files() {
    let axes: AxisSet = "fz,tx".parse().unwrap();
    let e1 = ["e1".to_string()];
    for (row, says, counts) in [
        ("1,1,1e300,0.5,0", "1e300 cannot be true", Counts::Raw),
        ("1,1,4096,0.5,0", "0 to 4095", Counts::Raw),
        ("1,1,-1,0.5,0", "a raw 12-bit", Counts::Raw),
        ("1,1,-4096,0.5,0", "a tared 12-bit", Counts::Tared),
        ("1,1,10,2e6,0", "column \"fz\"", Counts::Raw),
        ("1,1,10,0.5,-2e5", "column \"tx\"", Counts::Raw),
    ] {
        for end in ["\n", "\r\n"] {
            let text = format!("set,trial,e1,fz,tx{end}1,1,10,0.5,0{end}{row}{end}");
            let f = write(&text);
            let err = Dataset::read_csv(f.path(), &e1, &axes, counts).unwrap_err();
            let msg = err.to_string();
            assert!(
                msg.contains("line 3,") && msg.contains(says),
                "{end:?}: {msg}"
            );
        }
    }
    // Tared counts may go below zero; raw ones up to 4095.
    let f = write("set,trial,e1,fz,tx\n1,1,-40,0.5,0\n1,1,4095,-0.5,1\n");
    Dataset::read_csv(f.path(), &e1, &axes, Counts::Tared).unwrap();
    let f = write("set,trial,e1,fz,tx\n1,1,40,0.5,0\n1,1,4095,-0.5,1\n");
    Dataset::read_csv(f.path(), &e1, &axes, Counts::Raw).unwrap();
}

#[test]
fn a_bag_reading_or_wrench_that_cannot_be_true_is_refused_with_its_place() {
    use crate::biotac::{BioTacReading, N_ELECTRODES, N_PAC};
    use crate::wrench::Wrench;
    let record = |e1: u16, fz: f64| {
        let mut electrodes = [2000; N_ELECTRODES];
        electrodes[0] = e1;
        Record {
            t: 0.0,
            set: 1,
            trial: 1,
            reading: BioTacReading {
                seq: 0,
                stamp_s: 0.0,
                electrodes: electrodes.into(),
                pdc: 2000,
                pac: [2000; N_PAC].into(),
                tdc: 2000,
                tac: 2000,
            },
            wrench: Wrench::new(nalgebra::Vector3::new(0.0, 0.0, fz), Default::default()),
        }
    };
    let (e1, fz): (Vec<String>, AxisSet) = (vec!["e1".into()], "fz".parse().unwrap());
    let from = |records: &[Record]| Dataset::from_records(records, &e1, &fz, "bag.mcap");
    from(&[record(2000, 1.0), record(4095, -2.0)]).unwrap();
    let e = from(&[record(2000, 1.0), record(4096, 1.0)])
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("bag.mcap: reading 2, column \"e1\"") && e.contains("4095"),
        "{e}"
    );
    let e = from(&[record(2000, f64::NAN)]).unwrap_err().to_string();
    assert!(
        e.contains("reading 1, column \"fz\"") && e.contains("finite"),
        "{e}"
    );
    let e = from(&[record(2000, 3e6)]).unwrap_err().to_string();
    assert!(
        e.contains("reading 1, column \"fz\"") && e.contains("1e6 N"),
        "{e}"
    );
}

#[test]
fn records_in_memory_equal_records_read_back_from_csv_for_both_layouts() {
    use crate::biotac::sim::BioTacSimConfig;
    use crate::biotac::ElectrodeLayout;
    use crate::sim::collect::{collect, CollectConfig};
    let all = [
        Channel::Electrodes,
        Channel::Pdc,
        Channel::Tdc,
        Channel::Tac,
    ];
    let axes = AxisSet::forces();
    let mut both = Vec::new();
    for (layout, n_features) in [
        (ElectrodeLayout::Biotac, 22),
        (ElectrodeLayout::BiotacSp, 27),
    ] {
        let sensor = BioTacSimConfig::default().with_layout(layout);
        let records = collect(&CollectConfig::default(), &sensor, 3, 3)[..300].to_vec();
        let f = tempfile::NamedTempFile::new().unwrap();
        write_csv(f.path(), &records).unwrap();
        let features = channel_columns(&all, layout);
        assert_eq!(features.len(), n_features);
        assert_eq!(layout_of(&features), layout);
        let read = Dataset::read_csv(f.path(), &features, &axes, Counts::Raw).unwrap();
        let mem = Dataset::from_records(&records, &features, &axes, "memory").unwrap();
        assert_eq!(
            (&mem.x, &mem.set, &mem.trial),
            (&read.x, &read.set, &read.trial)
        );
        let err = Dataset::from_records(&records, &["pressure".into()], &axes, "memory");
        assert!(err
            .unwrap_err()
            .to_string()
            .contains("missing column \"pressure\""));
        // The file keeps targets to the precision it writes them with.
        let worst = (&mem.y - &read.y)
            .mapv(f64::abs)
            .fold(0.0f64, |a, &b| a.max(b));
        assert!(worst < 1e-6, "{worst}");
        both.push(records);
    }
    // A BioTac has no E20; one session cannot hold both sensors.
    let err = Dataset::from_records(&both[0], &["e20".into()], &axes, "memory").unwrap_err();
    assert!(err.to_string().contains("missing column \"e20\""), "{err}");
    let mixed = [both[0][0].clone(), both[1][0].clone()];
    let err = write_csv(std::path::Path::new("/dev/null"), &mixed)
        .unwrap_err()
        .to_string();
    assert_eq!(
        err,
        "/dev/null: readings of 19 electrodes and of 24 electrodes in one session"
    );
}

#[test]
fn folds_never_mix_a_trial_and_cover_every_row_once() {
    let mut text = String::from("set,trial,e1,fz\n");
    for set in 1..=4 {
        for trial in 1..=10 {
            for s in 0..3 {
                text += &format!("{set},{trial},{s},0\n");
            }
        }
    }
    let f = write(&text);
    let ds = Dataset::read_csv(
        f.path(),
        &["e1".into()],
        &"fz".parse().unwrap(),
        Counts::Raw,
    )
    .unwrap();
    let folds = trialwise_folds(&ds, 5);
    let mut tested = vec![0; ds.len()];
    for (train, test) in &folds {
        let key = |i: &usize| (ds.set[*i], ds.trial[*i]);
        let train_trials: std::collections::BTreeSet<_> = train.iter().map(key).collect();
        let test_trials: std::collections::BTreeSet<_> = test.iter().map(key).collect();
        assert!(train_trials.is_disjoint(&test_trials));
        assert_eq!((train_trials.len(), test_trials.len()), (32, 8));
        test.iter().for_each(|&i| tested[i] += 1);
    }
    assert!(tested.iter().all(|&c| c == 1));
}

#[test]
fn tare_subtracts_each_trials_own_baseline() {
    let f =
        write("set,trial,e1,fz\n1,1,100,0\n1,1,102,0\n1,1,90,1\n1,2,50,0\n1,2,50,0\n1,2,40,1\n");
    let mut ds = Dataset::read_csv(
        f.path(),
        &["e1".into()],
        &"fz".parse().unwrap(),
        Counts::Raw,
    )
    .unwrap();
    ds.tare_per_trial(2).unwrap();
    assert_eq!(
        ds.x.column(0).to_vec(),
        vec![-1.0, 1.0, -11.0, 0.0, 0.0, -10.0]
    );
    assert!(matches!(
        ds.tare_per_trial(4),
        Err(DatasetError::TareTooShort { needed: 4, .. })
    ));
}
