//! Another lab's real BioTac recordings of contact direction
//! (`../shared/data/robotic_finger_direction_{1,2}.csv`, see the README
//! there): `train --select` on the first with the data's own flags, `eval
//! --model` on the second, as a user runs them. The targets are the unit
//! contact normal, not forces; that lab's own network reached R2 about 0.8
//! on x and z.

use std::path::PathBuf;
use std::process::Command;

fn recording(n: u32) -> PathBuf {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join(format!("../shared/data/robotic_finger_direction_{n}.csv"));
    assert!(
        path.exists(),
        "{}: the recording is missing",
        path.display()
    );
    path
}

fn run(args: &[&str]) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_tactile_force"))
        .args(args)
        .output()
        .expect("the binary runs");
    let (stdout, stderr) = (
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr),
    );
    assert!(out.status.success(), "{args:?}: {stdout}\n{stderr}");
    stdout.into_owned()
}

#[test]
fn selected_on_one_recording_the_model_finds_the_direction_on_the_other_and_knows_its_error() {
    let dir = tempfile::tempdir().unwrap();
    let model = dir.path().join("direction.json");
    let (first, second) = (recording(1), recording(2));
    // A budget every candidate fits in on a loaded CI machine: the choice
    // then does not depend on the machine's speed.
    let table = run(&[
        "train",
        "--select",
        "--data",
        first.to_str().unwrap(),
        "--axes",
        "fx,fz",
        "--channels",
        "electrodes",
        "--tare-samples",
        "0",
        "--budget-s",
        "600",
        "--out",
        model.to_str().unwrap(),
    ]);
    println!("{table}");
    assert!(
        table.contains("set 1 is one trial: cross-validated on 5 contiguous blocks of it"),
        "{table}"
    );
    assert!(!table.contains("not tried"), "{table}");
    let eval = run(&[
        "eval",
        "--model",
        model.to_str().unwrap(),
        "--test",
        second.to_str().unwrap(),
        "--json",
    ]);
    println!("{eval}");
    let json: serde_json::Value = serde_json::from_str(eval.lines().last().unwrap()).unwrap();
    let gp = &json["gp"];
    let r2 = |a: &str| gp["r2"][a].as_f64().unwrap();
    let mean_r2 = (r2("fx") + r2("fz")) / 2.0;
    assert!(mean_r2 >= 0.80, "mean R2 of x and z {mean_r2}");
    for axis in ["fx", "fz"] {
        let two = gp["coverage_2s"][axis].as_f64().unwrap();
        let one = gp["coverage_1s"][axis].as_f64().unwrap();
        assert!(
            (0.85..=0.99).contains(&two),
            "{axis}: 2-sigma coverage {two}"
        );
        assert!(one < two, "{axis}: {one} vs {two}");
    }
}
