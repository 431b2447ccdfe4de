//! A BioTac SP's 24 electrodes end to end: a simulated session collected,
//! trained on, run closed-loop, and refused by name where a model of the
//! other layout meets it.

use std::path::Path;
use std::process::{Command, Output};

fn run(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_tactile_force"))
        .args(args)
        .output()
        .expect("the binary runs")
}

fn ok(o: Output) -> String {
    let (out, err) = (
        String::from_utf8_lossy(&o.stdout).into_owned(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    );
    assert!(o.status.success(), "{out}\n{err}");
    out
}

fn collect(dir: &Path, sensor: &str, seed: &str) -> String {
    let out = dir.join(format!("{sensor}-{seed}.csv"));
    let out = out.to_str().unwrap().to_string();
    let args = [
        "collect", "--sensor", sensor, "--trials", "2", "--seed", seed,
    ];
    ok(run(&[&args[..], &["--out", &out]].concat()));
    out
}

#[test]
fn a_biotac_sp_session_is_trained_on_and_holds_1_n_and_other_layouts_are_refused_by_name() {
    let dir = tempfile::tempdir().unwrap();
    let sp = collect(dir.path(), "biotac-sp", "1");
    let header = std::fs::read_to_string(&sp).unwrap();
    let header = header.lines().next().unwrap();
    assert!(header.contains(",e19,e20,e21,e22,e23,e24,pdc,"), "{header}");

    let model = dir.path().join("sp.json");
    let model = model.to_str().unwrap();
    ok(run(&["train", "--data", &sp, "--out", model]));
    let file: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(model).unwrap()).unwrap();
    assert_eq!(file["sensor"]["kind"], "biotac");
    assert_eq!(file["sensor"]["electrodes"], 24);
    assert_eq!(
        file["features"].as_array().unwrap().len(),
        25,
        "e1..e24, pdc"
    );

    // The closed loop on a simulated BioTac SP: the guarded move's bounds.
    let out = ok(run(&["demo", "guarded", "--model", model, "--json"]));
    let s: serde_json::Value = serde_json::from_str(out.lines().last().unwrap()).unwrap();
    assert_eq!(s["final_phase"], "hold", "{s}");
    let peak = s["peak_force_n"].as_f64().unwrap();
    let sd = s["final_sd_n"].as_f64().unwrap();
    let error = s["steady_state_error_n"].as_f64().unwrap();
    assert!(peak <= 1.1 && sd <= 0.02 && error.abs() <= 0.05, "{s}");

    // A BioTac's 19-electrode readings given to the SP's model.
    let bt = collect(dir.path(), "biotac", "2");
    for args in [
        vec!["eval", "--model", model, "--test", &bt],
        vec![
            "adapt",
            "--model",
            model,
            "--data",
            &bt,
            "--out",
            "/dev/null",
        ],
    ] {
        let o = run(&args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert!(
            err.contains("model trained on 24 electrodes, readings have 19 electrodes"),
            "{args:?}: {err}"
        );
    }
    // Files of both layouts in one training set.
    let o = run(&["train", "--data", &sp, "--data", &bt, "--out", model]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("mix sensors") && err.contains("24 electrodes"),
        "{err}"
    );
}
