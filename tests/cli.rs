//! The `tactile_force` binary end to end: collect -> train -> eval on a small
//! simulated data set, and the errors a user sees for bad files.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn run(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_tactile_force"))
        .args(args)
        .output()
        .expect("the binary runs")
}

fn text(o: &Output) -> (String, String) {
    (
        String::from_utf8_lossy(&o.stdout).into_owned(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

/// The shipped simulator config with 5 trials per set instead of 10.
fn small_config(dir: &Path) -> PathBuf {
    let shipped = include_str!("../config/biotac_sim.yaml");
    assert!(shipped.contains("trials_per_set: 10"));
    let path = dir.join("small.yaml");
    std::fs::write(
        &path,
        shipped.replace("trials_per_set: 10", "trials_per_set: 5"),
    )
    .unwrap();
    path
}

fn collect(dir: &Path, seed: &str) -> PathBuf {
    let data = dir.join(format!("d{seed}.csv"));
    let cfg = small_config(dir);
    let o = run(&[
        "collect",
        "--seed",
        seed,
        "--config",
        cfg.to_str().unwrap(),
        "--out",
        data.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{:?}", text(&o));
    assert!(text(&o).0.contains("wrote 40000 rows"), "{:?}", text(&o));
    data
}

fn last_json(stdout: &str) -> serde_json::Value {
    serde_json::from_str(stdout.lines().last().expect("output")).expect("last line is JSON")
}

#[test]
fn collect_train_eval_round_trip() {
    let dir = tempfile::tempdir().unwrap();
    let data = collect(dir.path(), "3");
    let header = std::fs::read_to_string(&data).unwrap();
    assert!(header.starts_with(
        "t,set,trial,e1,e2,e3,e4,e5,e6,e7,e8,e9,e10,e11,e12,e13,e14,e15,e16,e17,e18,e19,\
         pdc,pac_mean,tdc,tac,fx,fy,fz,tx,ty,tz\n"
    ));

    let model = dir.path().join("m.json");
    let (d, m) = (data.to_str().unwrap(), model.to_str().unwrap());
    let o = run(&[
        "train",
        "--data",
        d,
        "--axes",
        "fz",
        "--max-train",
        "300",
        "--out",
        m,
    ]);
    assert!(o.status.success(), "{:?}", text(&o));
    assert!(text(&o).0.contains("trained 1 axes (fz) on 300 samples"));

    // Cross-validation: GP and NN on the same folds, JSON on the last line.
    let o = run(&[
        "eval",
        "--data",
        d,
        "--axes",
        "fx,fz",
        "--max-train",
        "300",
        "--json",
    ]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    let j = last_json(&out);
    for model in ["gp", "nn"] {
        for axis in ["fx", "fz"] {
            let rmse = j[model]["rmse"][axis].as_f64().unwrap();
            assert!(rmse > 0.0 && rmse < 1.0, "{model} {axis} RMSE {rmse}");
        }
        assert_eq!(j[model]["n_train"], 300);
    }
    assert_eq!(j["folds"].as_array().unwrap().len(), 5);
    assert!(out.contains("overall  GP"));

    // The saved model scored on another seed's data.
    let other = collect(dir.path(), "4");
    let o = run(&[
        "eval",
        "--model",
        m,
        "--test",
        other.to_str().unwrap(),
        "--json",
    ]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    let rmse = last_json(&out)["gp"]["rmse"]["fz"].as_f64().unwrap();
    assert!(rmse < 0.5, "fz RMSE on new data {rmse}");
}

#[test]
fn a_missing_column_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("bad.csv");
    let mut text_csv = String::from("set,trial");
    for i in (1..=19).filter(|&i| i != 7) {
        text_csv += &format!(",e{i}");
    }
    text_csv += ",fz\n1,1";
    text_csv += &",1".repeat(19);
    text_csv += "\n";
    std::fs::write(&csv, text_csv).unwrap();
    let out = dir.path().join("m.json");
    let o = run(&[
        "train",
        "--data",
        csv.to_str().unwrap(),
        "--axes",
        "fz",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(1));
    let (_, err) = text(&o);
    assert!(err.contains("missing column \"e7\""), "{err}");
    assert!(!out.exists());
}

#[test]
fn a_corrupt_or_foreign_model_file_is_refused_clearly() {
    let dir = tempfile::tempdir().unwrap();
    let test = dir.path().join("t.csv");
    std::fs::write(&test, "e1,fz\n1,0\n").unwrap();
    let model = dir.path().join("m.json");
    for (content, expected) in [
        (
            "{\"format\": \"tactile_force/wrench_gp\", \"vers",
            "truncated or corrupt",
        ),
        ("{\"format\": \"other\"}", "format is \"other\""),
        ("\u{0}\u{1}binary", "truncated or corrupt"),
    ] {
        std::fs::write(&model, content).unwrap();
        let o = run(&[
            "eval",
            "--model",
            model.to_str().unwrap(),
            "--test",
            test.to_str().unwrap(),
        ]);
        assert_eq!(o.status.code(), Some(1));
        let (_, err) = text(&o);
        assert!(err.contains(expected), "{err}");
    }
}

#[test]
fn too_few_folds_or_trials_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let data = collect(dir.path(), "5");
    let d = data.to_str().unwrap();
    for (folds, expected) in [
        ("1", "at least 2 folds, got 1"),
        ("6", "6 folds need at least 6 trials per set; set 1 has 5"),
    ] {
        let o = run(&["eval", "--data", d, "--folds", folds, "--no-nn"]);
        assert_eq!(o.status.code(), Some(1));
        assert!(text(&o).1.contains(expected), "{:?}", text(&o));
    }
}

#[test]
fn every_subcommand_has_help() {
    for sub in ["collect", "train", "eval"] {
        let o = run(&[sub, "--help"]);
        assert!(o.status.success());
        assert!(text(&o).0.contains("Usage: tactile_force"), "{sub}");
    }
}
