//! The base's own data: files named by hash, read again, or why not.

use super::*;
use crate::biotac::sim::BioTacSimConfig;
use crate::biotac::ElectrodeLayout;
use crate::learn::data::{electrode_columns, write_csv, Counts};
use crate::learn::models::wrench_gp::quick_params;
use crate::sim::collect::{collect, CollectConfig};
use std::path::{Path, PathBuf};

#[test]
fn the_hash_is_fnv_1a_of_the_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let f = dir.path().join("f");
    for (bytes, hash) in [(&b""[..], "cbf29ce484222325"), (b"a", "af63dc4c8601ec8c")] {
        std::fs::write(&f, bytes).unwrap();
        assert_eq!(file_hash(&f).unwrap(), hash);
    }
    let r = data_file(&f, 7).unwrap();
    assert_eq!((r.path.as_str(), r.rows), (f.to_str().unwrap(), 7));
}

#[test]
fn an_adapted_model_records_its_base_s_files_and_its_own() {
    let file = |p: &str| DataFile {
        path: p.into(),
        hash: "0".into(),
        rows: 1,
    };
    let base = TrainedOn {
        files: vec![file("a.csv")],
        params: GpParams {
            max_train: 77,
            ..GpParams::default()
        },
    };
    let on = lineage(Some(&base), vec![file("b.csv")]).unwrap();
    assert_eq!(on.files, vec![file("a.csv"), file("b.csv")]);
    assert_eq!(on.params.max_train, 77);
    assert_eq!(lineage(None, vec![file("b.csv")]), None);
}

/// Unit `unit`'s set 1 (two trials), every 4th row, written to `dir`
/// (shared with adapt's tests).
pub(in crate::learn) fn session(dir: &Path, unit: u64) -> (PathBuf, Dataset) {
    let cfg = CollectConfig::default().with_trials(2).unwrap();
    let records: Vec<_> = collect(&cfg, &BioTacSimConfig::default(), unit, 1)
        .into_iter()
        .filter(|r| r.set == 1)
        .step_by(4)
        .collect();
    let path = dir.join(format!("u{unit}.csv"));
    write_csv(&path, &records).unwrap();
    let features = electrode_columns(ElectrodeLayout::Biotac);
    let axes = "fx,fz".parse().unwrap();
    let data = Dataset::read_csv(&path, &features, &axes, Counts::Raw).unwrap();
    (path, data)
}

/// A model of `data` (tared on 10 rows) that records `path` as its data
/// (shared with adapt's tests).
pub(in crate::learn) fn model_of(path: &Path, data: &Dataset) -> (WrenchGp, Dataset, TareSpec) {
    let mut tared = data.clone();
    let tare = TareSpec {
        samples: 10,
        mean_baseline: tared.tare_per_trial(10).unwrap(),
    };
    let params = quick_params();
    let on = TrainedOn {
        files: vec![data_file(path, data.len()).unwrap()],
        params: GpParams::clone(&params),
    };
    let model = WrenchGp::train(&tared, tare.clone(), &params, &mut |_, _| {})
        .unwrap()
        .with_trained_on(Some(on));
    (model, tared, tare)
}

#[test]
fn the_base_s_data_is_read_again_or_said_why_not() {
    let dir = tempfile::tempdir().unwrap();
    let (path, data) = session(dir.path(), 1);
    let (model, tared, _) = model_of(&path, &data);
    let base = base_data(&model, None).unwrap();
    assert_eq!(base.data.x, tared.x);
    assert_eq!((base.rows, base.files.len()), (data.len(), 1));
    let thin = base.clone().thin(100);
    assert_eq!(thin.data.len(), 100);
    assert_eq!(
        thin.describe(),
        format!("base rows subsampled {} -> 100 of 1 file(s)", data.len())
    );

    // Moved: missing where recorded, found by content where given.
    let moved = dir.path().join("moved.csv");
    std::fs::rename(&path, &moved).unwrap();
    let p = path.display().to_string();
    assert!(matches!(base_data(&model, None), Err(Unavailable::Missing { path, .. }) if path == p));
    let given = base_data(&model, Some(std::slice::from_ref(&moved))).unwrap();
    assert_eq!(given.data.x, tared.x);

    // Changed: named, with both hashes.
    let text = std::fs::read_to_string(&moved).unwrap();
    std::fs::write(&path, text.replacen(",1,", ",2,", 1)).unwrap();
    let err = base_data(&model, None).unwrap_err();
    assert!(
        matches!(&err, Unavailable::Changed { path, .. } if *path == p),
        "{err}"
    );
    let said = err.to_string();
    assert!(
        said.contains(&model.trained_on().unwrap().files[0].hash),
        "{said}"
    );

    let bare = model.with_trained_on(None);
    assert_eq!(
        base_data(&bare, None).unwrap_err(),
        Unavailable::NoReference
    );
}
