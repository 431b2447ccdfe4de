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

/// Runs with the default-model cache in `cache`.
fn run_cached(args: &[&str], cache: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_tactile_force"))
        .args(args)
        .env("TACTILE_FORCE_CACHE", cache)
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

/// Asserts that `o` exited 2 (refused input) with `says` in its message.
fn refused_saying(o: &Output, says: &str) {
    let (_, err) = text(o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains(says), "{err}");
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
    let (out, err) = text(&o);
    assert!(out.contains("fz: exact GP on 300 rows"), "{out}{err}");
    assert!(
        out.contains("trained 1 axes (fz) on 40000 samples"),
        "{out}"
    );
    // A BioTac model's GPs keep a zero mean unless told.
    let file = std::fs::read_to_string(&model).unwrap();
    assert!(
        !file.contains("\"linear\""),
        "a BioTac model with a linear mean"
    );

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
fn a_file_that_cannot_be_written_is_a_failure_not_bad_input() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("no-such-dir").join("d.csv");
    let o = run(&["collect", "--trials", "1", "--out", out.to_str().unwrap()]);
    let (_, err) = text(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("cannot write") && err.contains("d.csv"),
        "{err}"
    );
    let o = run(&["--help"]);
    assert!(text(&o)
        .0
        .contains("Exit codes: 0 done; 2 the input was refused"));
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
    assert_eq!(o.status.code(), Some(2));
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
        assert_eq!(o.status.code(), Some(2));
        let (_, err) = text(&o);
        assert!(err.contains(expected), "{err}");
    }
}

#[test]
fn tradeoff_measures_every_setting_on_held_out_trials() {
    let dir = tempfile::tempdir().unwrap();
    let data = collect(dir.path(), "6");
    let png = dir.path().join("tradeoff.png");
    let o = run(&[
        "tradeoff",
        "--data",
        data.to_str().unwrap(),
        "--axes",
        "fz",
        "--exact-n",
        "250,100000",
        "--sparse-m",
        "25",
        "--plot",
        png.to_str().unwrap(),
        "--json",
    ]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    // 5 trials per set, the first of 5 trial-wise folds held out.
    assert!(
        out.contains("32000 training rows, 8000 held-out rows"),
        "{out}"
    );
    let rows = last_json(&out)["rows"].as_array().unwrap().clone();
    let kinds: Vec<(&str, Option<&str>, u64)> = rows
        .iter()
        .map(|r| {
            (
                r["model"].as_str().unwrap(),
                r["subset"].as_str(),
                r["n_train"].as_u64().unwrap(),
            )
        })
        .collect();
    // n = 100000 is more than the training rows: skipped.
    assert_eq!(
        kinds,
        [
            ("exact", Some("random"), 250),
            ("exact", Some("farthest"), 250),
            ("sparse", None, 32000),
            ("nn", None, 32000),
        ]
    );
    for r in &rows {
        let rmse = r["rmse"]["fz"].as_f64().unwrap();
        assert!(rmse > 0.0 && rmse < 3.0, "{r}");
        assert!(r["r2"]["fz"].as_f64().unwrap() <= 1.0, "{r}");
        assert!(r["fit_s"].as_f64().unwrap() > 0.0, "{r}");
        assert!(r["latency_mean_us"].as_f64().unwrap() > 0.0, "{r}");
    }
    assert_eq!(rows[2]["m"], 25);
    assert!(rows[0]["m"].is_null() && rows[3]["latency_mean_std_us"].is_null());
    assert!(std::fs::read(&png).unwrap().starts_with(b"\x89PNG"));

    let o = run(&[
        "tradeoff",
        "--data",
        data.to_str().unwrap(),
        "--subsets",
        "best",
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        text(&o).1.contains("expected random or farthest"),
        "{:?}",
        text(&o)
    );
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
        assert_eq!(o.status.code(), Some(2));
        assert!(text(&o).1.contains(expected), "{:?}", text(&o));
    }
}

/// `collect --unit U --seed S --trials 1` (80 s) into `dir`.
fn collect_short(dir: &Path, unit: &str, seed: &str) -> String {
    let data = dir.join(format!("u{unit}s{seed}.csv"));
    let d = data.to_str().unwrap();
    let o = run(&[
        "collect", "--unit", unit, "--seed", seed, "--trials", "1", "--out", d,
    ]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    assert!(
        out.contains(&format!(
            "wrote 8000 rows (80 s) to {d} (unit {unit}, session {seed})"
        )),
        "{out}"
    );
    d.to_string()
}

#[test]
fn training_data_that_cannot_be_true_is_refused_and_a_model_that_explains_nothing_is_not_written() {
    let dir = tempfile::tempdir().unwrap();
    let clean = collect_short(dir.path(), "1", "1");
    let text_of = std::fs::read_to_string(&clean).unwrap();
    // One cell of row 4001 (line 4002) changed: (column, value).
    let glitch = |column: &str, value: &str| {
        let mut lines: Vec<String> = text_of.lines().map(String::from).collect();
        let k = lines[0].split(',').position(|h| h == column).unwrap();
        let mut cells: Vec<&str> = lines[4001].split(',').collect();
        cells[k] = value;
        lines[4001] = cells.join(",");
        let path = dir.path().join(format!("{column}_{value}.csv"));
        std::fs::write(&path, lines.join("\n") + "\n").unwrap();
        path.to_str().unwrap().to_string()
    };
    let model = dir.path().join("model.json");
    let m = model.to_str().unwrap();
    let o = run(&["train", "--data", &clean, "--out", m]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    assert!(
        out.contains("fit on its own training data: fx RMSE"),
        "{out}"
    );
    let before = std::fs::read(&model).unwrap();
    for (column, value) in [("e5", "1e300"), ("pdc", "65535"), ("fz", "-2e6")] {
        let bad = glitch(column, value);
        let o = run(&["train", "--data", &bad, "--out", m]);
        let (_, err) = text(&o);
        assert_eq!(o.status.code(), Some(2), "{err}");
        let at = format!("{bad}: line 4002, column \"{column}\"");
        assert!(err.contains(&at) && err.contains("cannot be true"), "{err}");
    }
    // A force a sensor could give but this data cannot explain: the fit
    // on the training data says so, and the model in place is kept.
    let bad = glitch("fz", "90000");
    let o = run(&["train", "--data", &bad, "--out", m]);
    let (_, err) = text(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("of fz's variance on its own training data"),
        "{err}"
    );
    assert_eq!(
        std::fs::read(&model).unwrap(),
        before,
        "the model in place kept"
    );
}

/// `train --select` on fz of `data` into `model` within 4 s, with `extra`
/// options.
fn select_fz_in_4_s(data: &str, model: &str, extra: &[&str]) -> std::process::Output {
    let mut args = vec!["train", "--select", "--budget-s", "4", "--axes", "fz"];
    args.extend_from_slice(extra);
    args.extend_from_slice(&["--data", data, "--out", model]);
    run(&args)
}

/// Two threads spinning until `stop`: both cores of the CI machine busy.
fn cpu_hog(
    stop: &std::sync::Arc<std::sync::atomic::AtomicBool>,
) -> Vec<std::thread::JoinHandle<u64>> {
    (0..2)
        .map(|_| {
            let stop = stop.clone();
            std::thread::spawn(move || {
                let mut x = 0u64;
                while !stop.load(std::sync::atomic::Ordering::Relaxed) {
                    x = std::hint::black_box(x.wrapping_mul(6364136223846793005).wrapping_add(1));
                }
                x
            })
        })
        .collect()
}

#[test]
fn train_select_writes_the_same_model_file_on_a_loaded_machine() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("two.csv");
    let d = data.to_str().unwrap();
    let o = run(&["collect", "--trials", "2", "--seed", "3", "--out", d]);
    assert!(o.status.success(), "{:?}", text(&o));
    let select = |name: &str| {
        let model = dir.path().join(name);
        let m = model.to_str().unwrap();
        let args = [
            "train",
            "--select",
            "--budget-s",
            "1.5",
            "--axes",
            "fz",
            "--data",
            d,
            "--out",
            m,
        ];
        let o = run(&args);
        let (out, err) = text(&o);
        assert!(o.status.success(), "{err}");
        let chosen = out
            .lines()
            .find(|l| l.starts_with("chosen: "))
            .unwrap_or("")
            .to_string();
        (std::fs::read(&model).unwrap(), chosen)
    };
    let (quiet, chosen) = select("quiet.json");
    let stop = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let hog = cpu_hog(&stop);
    let (loaded, chosen_loaded) = select("loaded.json");
    stop.store(true, std::sync::atomic::Ordering::Relaxed);
    hog.into_iter().for_each(|h| {
        h.join().unwrap();
    });
    assert!(!chosen.is_empty());
    assert_eq!(chosen, chosen_loaded);
    assert!(
        quiet == loaded,
        "the model files differ:\n{}",
        String::from_utf8_lossy(&loaded)
    );
}

#[test]
fn train_select_chooses_within_its_budget_and_the_model_file_records_the_table() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("two.csv");
    let d = data.to_str().unwrap();
    let o = run(&["collect", "--trials", "2", "--out", d]);
    assert!(o.status.success(), "{:?}", text(&o));
    let model = dir.path().join("sel.json");
    let m = model.to_str().unwrap();
    let o = select_fz_in_4_s(d, m, &[]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    assert!(
        out.contains("--select: 2-fold trial-wise cross-validation of"),
        "{out}"
    );
    assert!(out.contains("* ") && out.contains("chosen: "), "{out}");
    // Four seconds leave some candidates untried, and it says so.
    assert!(
        out.contains("not tried: ") && out.contains("s the time budget leaves"),
        "{out}"
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&model).unwrap()).unwrap();
    let table = json["selection"]["table"].as_array().unwrap();
    assert!(
        !table.is_empty() && json["selection"]["budget_s"] == 4.0,
        "{json}"
    );
    assert_eq!(json["version"], 10);
    // The data it was trained on, by reference.
    let files = &json["trained_on"]["files"];
    assert_eq!(files[0]["path"], d, "{files}");
    assert_eq!(files[0]["rows"], 16000, "{files}");
    assert_eq!(files[0]["hash"].as_str().unwrap().len(), 16, "{files}");
    // `eval --model` prints the table it was chosen by.
    let o = run(&["eval", "--model", m, "--test", d, "--axes", "fz"]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    assert!(
        out.contains("chosen by `train --select`") && out.contains("--select: 2-fold"),
        "{out}"
    );
    // The family fixed: the ensemble is scored, chosen and written with
    // its table.
    let o = select_fz_in_4_s(
        d,
        m,
        &["--family", "ensemble", "--channels", "electrodes,pdc"],
    );
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    assert!(
        out.contains("* ") && out.contains("electrodes+pdc, ensemble\n"),
        "{out}"
    );
    assert!(
        out.contains("not varied: family: fixed by --family"),
        "{out}"
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&model).unwrap()).unwrap();
    assert_eq!(json["format"], "tactile_force/wrench_ensemble", "{json}");
    let chosen = &json["selection"]["table"][0];
    assert_eq!(chosen["choice"]["family"], "ensemble", "{json}");
    let scale = chosen["std_scale"]["fz"].as_f64().unwrap();
    assert_eq!(json["std_scale"][0].as_f64(), Some(scale), "{json}");
    let o = run(&["eval", "--model", m, "--test", d, "--axes", "fz"]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    assert!(
        out.contains("ensemble of 5 networks") && out.contains("chosen by `train --select`"),
        "{out}"
    );
    // A budget must be a time; one trial per set is cross-validated on
    // contiguous blocks of it.
    let o = run(&[
        "train",
        "--select",
        "--data",
        d,
        "--out",
        m,
        "--budget-s",
        "0",
    ]);
    refused_saying(&o, "--budget-s 0");
    let one = collect_short(dir.path(), "1", "3");
    let o = run(&[
        "train",
        "--select",
        "--data",
        &one,
        "--budget-s",
        "1",
        "--out",
        m,
    ]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    for set in 1..=4 {
        let cut = format!("set {set} is one trial: cross-validated on 5 contiguous blocks of it");
        assert!(out.contains(&cut), "{out}");
    }
}

#[test]
fn train_select_on_electrode_only_data_varies_the_rest_and_keeps_what_is_given() {
    let dir = tempfile::tempdir().unwrap();
    let full = dir.path().join("two.csv");
    let o = run(&["collect", "--trials", "2", "--out", full.to_str().unwrap()]);
    assert!(o.status.success(), "{:?}", text(&o));
    // The electrodes and the forces only, as public BioTac data sets hold.
    let text_in = std::fs::read_to_string(&full).unwrap();
    let header: Vec<&str> = text_in.lines().next().unwrap().split(',').collect();
    let keep: Vec<usize> = header
        .iter()
        .enumerate()
        .filter(|(_, h)| !matches!(**h, "pdc" | "pac_mean" | "tdc" | "tac"))
        .map(|(i, _)| i)
        .collect();
    let cut: String = text_in
        .lines()
        .map(|l| {
            let cells: Vec<&str> = l.split(',').collect();
            let kept: Vec<&str> = keep.iter().map(|&i| cells[i]).collect();
            kept.join(",") + "\n"
        })
        .collect();
    let data = dir.path().join("electrodes.csv");
    std::fs::write(&data, cut).unwrap();
    let d = data.to_str().unwrap();
    let model = dir.path().join("e.json");
    let m = model.to_str().unwrap();
    let o = select_fz_in_4_s(d, m, &["--input", "pattern"]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    assert!(
        out.contains("not varied: channels: the data hold electrodes only")
            && out.contains("not varied: input: fixed by --input"),
        "{out}"
    );
    let rows: Vec<&str> = out.lines().filter(|l| l.ends_with(" mean")).collect();
    assert!(!rows.is_empty(), "{out}");
    for row in rows {
        assert!(
            row.contains("electrodes, pattern,") && !row.contains("pdc"),
            "{row}"
        );
    }
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&model).unwrap()).unwrap();
    assert_eq!(json["features"].as_array().unwrap().len(), 19, "{json}");
}

#[test]
fn demo_calibrate_writes_the_session_and_a_model_and_refuses_what_it_cannot_do() {
    let dir = tempfile::tempdir().unwrap();
    let model = dir.path().join("u2.json");
    let m = model.to_str().unwrap();
    let o = run_cached(
        &["demo", "calibrate", "--unit", "2", "--out", m, "--json"],
        dir.path(),
    );
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    let j = last_json(&out);
    assert_eq!(
        (j["task"].as_str(), j["unit"].as_u64()),
        (Some("calibrate"), Some(2))
    );
    assert!(j["motion_s"].as_f64().unwrap() <= 90.0, "{j}");
    assert!(
        j["peak_force_n"].as_f64() <= j["force_limit_n"].as_f64(),
        "{j}"
    );
    assert!(
        [
            "adapted",
            "from scratch",
            "from scratch, network mean",
            "from scratch, ensemble"
        ]
        .contains(&j["chosen"].as_str().unwrap()),
        "{j}"
    );
    // The session is a rosbag2 MCAP file that eval reads; the model records
    // its calibration.
    let session = dir.path().join("u2.mcap");
    assert_eq!(j["session"].as_str(), session.to_str());
    let o = run(&["eval", "--model", m, "--test", session.to_str().unwrap()]);
    assert!(o.status.success(), "{:?}", text(&o));
    let file: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&model).unwrap()).unwrap();
    assert_eq!(file["calibration"]["chosen"], j["chosen"]);
    // Then the guarded move on unit 2 holds with it.
    let o = run(&["demo", "guarded", "--unit", "2", "--model", m, "--json"]);
    let g = last_json(&text(&o).0);
    assert_eq!(g["final_phase"].as_str(), Some("hold"), "{g}");
    for (args, says) in [
        (vec!["demo", "calibrate"], "needs --out"),
        (
            vec!["demo", "guarded", "--out", m],
            "go with `demo calibrate`",
        ),
    ] {
        refused_saying(&run_cached(&args, dir.path()), says);
    }
    // Nothing to touch: the arm stops, no model is written (exit 1).
    let far = dir.path().join("far.yaml");
    let scene = include_str!("../config/calibrate.yaml")
        .replace("    object_gap_mm: 10.0", "    object_gap_mm: 50.0");
    std::fs::write(&far, scene).unwrap();
    let other = dir.path().join("other.json");
    let o = run_cached(
        &[
            "demo",
            "calibrate",
            "--scene",
            far.to_str().unwrap(),
            "--out",
            other.to_str().unwrap(),
        ],
        dir.path(),
    );
    let (_, err) = text(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("no contact found") && err.contains("no model written"),
        "{err}"
    );
    assert!(!other.exists());
}

/// The GP's pooled fx and fz RMSE from `eval ... --json`.
fn gp_rmse(args: &[&str]) -> ([f64; 2], serde_json::Value, String) {
    let o = run(args);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    let j = last_json(&out);
    let rmse = ["fx", "fz"].map(|a| j["gp"]["rmse"][a].as_f64().unwrap_or(f64::NAN));
    (rmse, j, out)
}

#[test]
fn a_new_unit_is_adapted_to_and_sessions_are_left_out_in_turn() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (
        collect_short(dir.path(), "1", "1"),
        collect_short(dir.path(), "1", "2"),
    );
    let (new, test) = (
        collect_short(dir.path(), "2", "2"),
        collect_short(dir.path(), "2", "3"),
    );
    let base = dir.path().join("base.json");
    let base = base.to_str().unwrap();
    let o = run(&[
        "train",
        "--data",
        &format!("{a},{b}"),
        "--axes",
        "fx,fz",
        "--max-train",
        "600",
        "--out",
        base,
    ]);
    assert!(o.status.success(), "{:?}", text(&o));
    assert!(text(&o).0.contains("on 16000 samples"), "{:?}", text(&o));

    let adapted = dir.path().join("adapted.json");
    let adapted = adapted.to_str().unwrap();
    let o = run(&[
        "adapt",
        "--model",
        base,
        "--data",
        &new,
        "--max-train",
        "600",
        "--no-pool",
        "--out",
        adapted,
    ]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    assert!(out.contains("with 80 s of data (8000 rows)"), "{out}");
    assert!(
        out.contains("pooled retraining: not considered: pooling switched off"),
        "{out}"
    );
    let file: serde_json::Value = serde_json::from_slice(&std::fs::read(adapted).unwrap()).unwrap();
    assert_eq!(file["prior"]["from"]["model"], base);
    assert_eq!(file["prior"]["from"]["data"][0], new.as_str());

    // Another unit: the base model is off along x (the electrodes' gains
    // differ; PDC does not tell x); adapted on 80 s of the unit, much less so.
    let (before, _, _) = gp_rmse(&["eval", "--model", base, "--test", &test, "--json"]);
    let (after, _, _) = gp_rmse(&["eval", "--model", adapted, "--test", &test, "--json"]);
    assert!(
        after[0] < 0.6 * before[0],
        "fx RMSE {before:?} -> {after:?}"
    );
    assert!(
        after[1] < 1.1 * before[1],
        "fz RMSE {before:?} -> {after:?}"
    );

    pooling_wins_where_adapting_cannot_and_is_skipped_without_the_base_s_data(
        dir.path(),
        base,
        [&a, &b],
        &new,
        &test,
        before,
    );

    // Each session tested on a model of the others, one row per file.
    let sessions = format!("{a},{b},{new}");
    let args = [
        "eval",
        "--sessions",
        &sessions,
        "--axes",
        "fx",
        "--max-train",
        "300",
        "--no-nn",
        "--json",
    ];
    let (_, j, out) = gp_rmse(&args);
    assert_eq!(j["folds"].as_array().unwrap().len(), 3);
    for label in ["u1s1 ", "u1s2 ", "u2s2 "] {
        assert!(out.contains(label), "{out}");
    }
    for f in j["folds"].as_array().unwrap() {
        let rmse = f["gp"]["rmse"]["fx"].as_f64().unwrap();
        assert!(f["n_test"] == 8000 && rmse > 0.0 && rmse < 1.0, "{j}");
    }

    // A missing recording is named.
    let o = run(&[
        "adapt",
        "--model",
        base,
        "--data",
        "/no/such.csv",
        "--out",
        adapted,
    ]);
    assert!(!o.status.success());
    assert!(text(&o).1.contains("/no/such.csv"), "{:?}", text(&o));
}

/// The new unit's z and combined pushes only (sets 3 and 4, as two trials):
/// the base adapted to z pushes estimates the combined ones poorly, the
/// base's data pooled with them well. Without the base's data (moved), the
/// adapted model is kept and the output says why; `--base-data` finds it.
fn pooling_wins_where_adapting_cannot_and_is_skipped_without_the_base_s_data(
    dir: &Path,
    base: &str,
    base_data: [&str; 2],
    new: &str,
    test: &str,
    base_rmse: [f64; 2],
) {
    let text_of = std::fs::read_to_string(new).unwrap();
    let mut rows = text_of.lines();
    let header = rows.next().unwrap();
    let column = |name| header.split(',').position(|h| h == name).unwrap();
    let (set, trial) = (column("set"), column("trial"));
    // Written as two trials of one set, so that each of adapt's two folds
    // holds out one kind of push and trains on the other.
    let kept: Vec<String> = rows
        .filter_map(|l| {
            let mut cells: Vec<&str> = l.split(',').collect();
            let kind = ["3", "4"].iter().position(|s| *s == cells[set])?;
            cells[set] = "3";
            cells[trial] = ["1", "2"][kind];
            Some(cells.join(","))
        })
        .collect();
    let z = dir.join("u2_z_and_combined.csv");
    std::fs::write(&z, format!("{header}\n{}\n", kept.join("\n"))).unwrap();
    let out = dir.join("pooled.json");
    let adapt = |extra: &[&str]| {
        let mut args = vec!["adapt", "--model", base, "--data", z.to_str().unwrap()];
        args.extend(["--max-train", "600", "--out", out.to_str().unwrap()]);
        args.extend(extra);
        let o = run(&args);
        let (stdout, err) = text(&o);
        assert!(o.status.success(), "{err}");
        stdout
    };
    let said = adapt(&[]);
    assert!(said.contains("pooled retraining: 16000 base rows of 2 file(s)\n2 folds of the new data, each of its 4000 rows held out once: RMSE (score)"), "{said}");
    assert!(said.contains("\npooled from "), "{said}");
    let file: serde_json::Value = serde_json::from_slice(&std::fs::read(&out).unwrap()).unwrap();
    let choice = &file["adapt_choice"];
    assert_eq!(choice["chosen"], "pooled", "{choice}");
    let score = |i: usize| choice["validation"][i]["score"].as_f64().unwrap();
    assert_eq!(choice["validation"][0]["model"], "adapted");
    assert!(score(1) < 0.6 * score(0), "{choice}");
    let files: Vec<&str> = file["trained_on"]["files"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| f["path"].as_str().unwrap())
        .collect();
    assert_eq!(files, [base_data[0], base_data[1], z.to_str().unwrap()]);
    assert!(file["prior"].is_null());
    // On another session of the unit, all four kinds of push.
    let (pooled, _, _) = gp_rmse(&[
        "eval",
        "--model",
        out.to_str().unwrap(),
        "--test",
        test,
        "--json",
    ]);
    assert!(
        pooled[0] < 0.6 * base_rmse[0],
        "fx RMSE {base_rmse:?} -> {pooled:?}"
    );
    assert!(
        pooled[1] < 1.1 * base_rmse[1],
        "fz RMSE {base_rmse:?} -> {pooled:?}"
    );

    // The base's data moved: adapted, saying why once; found again when given.
    let moved = dir.join("moved.csv");
    std::fs::rename(base_data[1], &moved).unwrap();
    let said = adapt(&[]);
    let why = format!(
        "pooled retraining: not considered: its training data file {} is missing",
        base_data[1]
    );
    assert_eq!(said.matches(&why).count(), 1, "{said}");
    assert!(said.contains("\nadapted "), "{said}");
    let file: serde_json::Value = serde_json::from_slice(&std::fs::read(&out).unwrap()).unwrap();
    assert_eq!(file["adapt_choice"]["chosen"], "adapted");
    assert!(!file["prior"].is_null());
    let given = format!("{},{}", base_data[0], moved.display());
    let said = adapt(&["--base-data", &given]);
    assert!(
        said.contains("pooled retraining: 16000 base rows of 2 file(s)"),
        "{said}"
    );
    std::fs::rename(&moved, base_data[1]).unwrap();
}

#[test]
fn every_subcommand_has_help() {
    for sub in [
        "collect",
        "train",
        "eval",
        "adapt",
        "demo",
        "biotac-emulator",
        "biotac-monitor",
        "tradeoff",
        "robot",
    ] {
        let o = run(&[sub, "--help"]);
        assert!(o.status.success());
        assert!(text(&o).0.contains("Usage: tactile_force"), "{sub}");
    }
}

#[test]
fn demo_trains_the_default_model_once_then_reuses_it() {
    let dir = tempfile::tempdir().unwrap();
    let (csv, png) = (dir.path().join("run.csv"), dir.path().join("run.png"));
    let args = [
        "demo",
        "guarded",
        "--json",
        "--csv",
        csv.to_str().unwrap(),
        "--plot",
        png.to_str().unwrap(),
    ];
    let first = run_cached(&args, dir.path());
    let (out, err) = text(&first);
    assert!(first.status.success(), "{err}");
    assert!(
        err.contains("training the default model of the scene ("),
        "{err}"
    );
    assert!(err.contains("cached at"), "{err}");
    let j = last_json(&out);
    for key in [
        "task",
        "object",
        "approach_speed_mps",
        "contact_time_s",
        "peak_force_n",
        "overshoot_n",
        "steady_state_error_n",
        "settle_time_s",
        "rms_force_error_n",
        "max_off_axis_speed_mps",
        "aborted",
        "reason",
    ] {
        assert!(j.get(key).is_some(), "missing {key} in {j}");
    }
    assert_eq!(
        (j["task"].as_str(), j["object"].as_str()),
        (Some("guarded"), Some("wooden_box"))
    );
    assert!(j["overshoot_n"].as_f64().unwrap() <= 0.1, "{j}");
    let header = std::fs::read_to_string(&csv).unwrap();
    assert!(header.starts_with(tactile_force::report::trace::CSV_HEADER));
    assert!(header.lines().count() > 700);
    assert!(std::fs::read(&png).unwrap().starts_with(b"\x89PNG"));

    let second = run_cached(&args, dir.path());
    let (out2, err2) = text(&second);
    assert!(!err2.contains("training"), "{err2}");
    assert!(err2.contains("default model: "), "{err2}");
    assert_eq!(last_json(&out2), j, "same seed, same run");
}

#[test]
fn demo_refuses_bad_requests_before_any_training() {
    let dir = tempfile::tempdir().unwrap();
    let o = run_cached(&["demo", "guarded", "--object", "teapot"], dir.path());
    let (_, err) = text(&o);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        err.contains("teapot") && err.contains("stuffed_animal"),
        "{err}"
    );
    let o = run_cached(&["demo", "guided", "--speed", "0.02"], dir.path());
    assert!(text(&o).1.contains("guarded move"), "{:?}", text(&o));
    let o = run_cached(
        &["demo", "guarded", "--scene", "/nonexistent.yaml"],
        dir.path(),
    );
    assert!(text(&o).1.contains("/nonexistent.yaml"), "{:?}", text(&o));
    // Approach speeds beyond the safety envelope (24 mm/s: anything up to
    // rigid, over the bounds of the loop's delays): 0.2 m/s, and a user who
    // meant 5 mm/s.
    for speed in ["0.2", "5"] {
        let o = run_cached(&["demo", "guarded", "--speed", speed], dir.path());
        let (_, err) = text(&o);
        assert_eq!(o.status.code(), Some(2), "{speed}: {err}");
        assert!(
            err.contains("guarded.approach_speed_mps") && err.contains("at most 0.0238 m/s"),
            "{speed}: {err}"
        );
        assert!(
            err.contains("unknown") && err.contains("3.00 N force limit"),
            "{err}"
        );
    }
    // Speeds that are no speeds.
    for speed in ["NaN", "-0.01", "0"] {
        let o = run_cached(
            &["demo", "guarded", &format!("--speed={speed}")],
            dir.path(),
        );
        let (_, err) = text(&o);
        assert_eq!(o.status.code(), Some(2), "{speed}: {err}");
        assert!(err.contains("guarded.approach_speed_mps"), "{speed}: {err}");
    }
    let o = run_cached(&["demo", "guarded", "--speed", "5"], dir.path());
    assert!(
        text(&o).1.contains("5 mm/s would be 0.005 m/s"),
        "{:?}",
        text(&o)
    );
    assert_eq!(
        std::fs::read_dir(dir.path()).unwrap().count(),
        0,
        "nothing trained"
    );
}

#[test]
fn robot_prints_the_chain_pose_and_jacobian_and_refuses_bad_input() {
    let urdf = concat!(env!("CARGO_MANIFEST_DIR"), "/config/ur5.urdf");
    let on = |file, base, tip| vec!["robot", "--urdf", file, "--base", base, "--tip", tip];
    let chain = |base, tip| on(urdf, base, tip);
    let base = chain("base_link", "tool0");
    // At zero the UR5 lies stretched along its base's x (base_link is UR's
    // base turned by pi): tool0 at (a2 + a3, d4 + d6, d1 - d5).
    let o = run(&[&base[..], &["--q=0,0,0,0,0,0", "--json"]].concat());
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    assert!(
        out.contains("shoulder_pan_joint") && out.contains("revolute"),
        "{out}"
    );
    let j = last_json(&out);
    let p: Vec<f64> = serde_json::from_value(j["position_m"].clone()).unwrap();
    let expected = [0.425 + 0.39225, 0.10915 + 0.0823, 0.089159 - 0.09465];
    for (a, b) in p.iter().zip(expected) {
        assert!((a - b).abs() < 1e-12, "{p:?}");
    }
    let jac: Vec<Vec<f64>> = serde_json::from_value(j["jacobian"].clone()).unwrap();
    assert_eq!((jac.len(), jac[0].len()), (6, 6));
    assert_eq!(j["joints"].as_array().unwrap().len(), 6);
    assert!(j["quaternion_xyzw"].as_array().unwrap().len() == 4);
    // Stretched: the elbow is singular.
    assert!(j["sigma_min"].as_f64().unwrap() < 1e-9, "{j}");
    // Default q: the middle of each range (0 for the UR5), the same pose.
    let o = run(&[&base[..], &["--json"]].concat());
    assert_eq!(last_json(&text(&o).0)["position_m"], j["position_m"]);

    let refused = |args: &[&str], says: &str| refused_saying(&run(args), says);
    refused(&[&base[..], &["--q", "1,2,3"]].concat(), "6 values");
    refused(
        &[&base[..], &["--q=0,0,0,0,0,7"]].concat(),
        "wrist_3_joint = 7",
    );
    refused(
        &[&base[..], &["--q=0,0,0,0,0,nan"]].concat(),
        "wrist_3_joint = NaN",
    );
    refused(
        &chain("base_link", "tool9"),
        "no link `tool9` (its links: base_link, base,",
    );
    refused(
        &chain("tool0", "base_link"),
        "no chain from `tool0` down to `base_link`",
    );
    refused(&on("/nonexistent.urdf", "a", "b"), "/nonexistent.urdf");
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.urdf");
    std::fs::write(&bad, "<robot name=\"x\"><link name=\"a\"></robot>").unwrap();
    refused(&on(bad.to_str().unwrap(), "a", "a"), "not a valid URDF");
}

#[test]
fn demo_runs_any_arm_and_refuses_an_axis_the_arm_cannot_make() {
    let dir = tempfile::tempdir().unwrap();
    let o = run_cached(
        &[
            "demo",
            "guarded",
            "--robot",
            "ur5",
            "--object",
            "carton_box",
            "--json",
        ],
        dir.path(),
    );
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    let j = last_json(&out);
    assert_eq!(j["robot"].as_str(), Some("ur5"));
    assert!(j["overshoot_n"].as_f64().unwrap() <= 0.1, "{j}");
    assert!(
        j["damped_periods"].as_u64().unwrap() > 0,
        "near the wrist singularity: {j}"
    );
    // A URDF file: the chain from its root to its one leaf, the BioTac at
    // the flange, the middle of every range (the forearm level, the pad
    // facing down). The guarded move presses down, which the planar joints
    // make; the guided move also needs y, which only the pan could give.
    let arm = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/data/five_joint_arm.urdf"
    );
    let o = run_cached(&["demo", "guarded", "--robot", arm, "--json"], dir.path());
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    let j = last_json(&out);
    assert_eq!(j["robot"].as_str(), Some("five_joint_arm"));
    assert_eq!(j["final_phase"].as_str(), Some("hold"), "{j}");
    assert!(j["overshoot_n"].as_f64().unwrap() <= 0.1, "{j}");
    let o = run_cached(&["demo", "guided", "--robot", arm], dir.path());
    let (_, err) = text(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("5 joints") && err.contains("y of the BioTac frame"),
        "{err}"
    );
    for (args, says) in [
        (vec!["--robot", "ur10"], "pa10, ur5, panda"),
        (vec!["--robot", "/nonexistent.urdf"], "/nonexistent.urdf"),
        (
            vec!["--robot", "ur5", "--tip", "flange"],
            "no link `flange`",
        ),
    ] {
        let o = run_cached(&[&["demo", "guarded"][..], &args].concat(), dir.path());
        refused_saying(&o, says);
    }
}

#[test]
fn demo_speed_sweep_measures_the_peak_within_the_envelope_and_refuses_beyond() {
    let dir = tempfile::tempdir().unwrap();
    let plot = dir.path().join("sweep.png");
    let o = run_cached(
        &[
            "demo",
            "guarded",
            "--sweep-speed",
            "--objects",
            "wooden_box",
            "--speeds-mm-s",
            "10,20,40",
            "--plot",
            plot.to_str().unwrap(),
            "--json",
        ],
        dir.path(),
    );
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    assert!(
        out.contains("wooden_box: fastest approach within 0.1 N overshoot: 20.0 mm/s"),
        "{out}"
    );
    assert!(
        out.contains("wooden_box: the envelope accepts up to 24.1 mm/s"),
        "{out}"
    );
    assert!(std::fs::read(&plot).unwrap().starts_with(b"\x89PNG"));
    let j = last_json(&out);
    let limit = j["objects"][0]["max_speed_mps"].as_f64().unwrap();
    assert!((limit - 0.0241).abs() < 5e-4, "{j}");
    let sweep = j["sweep"].as_array().unwrap();
    assert_eq!(sweep.len(), 3);
    let run = |i: usize| &sweep[i]["run"];
    // The derivative term brakes the approach: within the bound at both.
    assert!(run(0)["overshoot_n"].as_f64().unwrap() <= 0.1);
    assert!(run(1)["overshoot_n"].as_f64().unwrap() <= 0.1);
    // Where the envelope predicts more than the target, it is an upper bound.
    let (peak, predicted) = (
        run(1)["peak_force_n"].as_f64().unwrap(),
        sweep[1]["predicted_peak_n"].as_f64().unwrap(),
    );
    assert!(predicted > 1.0 && peak <= predicted && peak < 3.0, "{j}");
    assert!(run(2).is_null(), "40 mm/s is refused: {j}");
    assert!(sweep[2]["predicted_peak_n"].as_f64().unwrap() > 3.0);
    assert_eq!(
        j["fastest_within_bound_mps"]["wooden_box"].as_f64(),
        Some(0.02)
    );
}

#[test]
fn monitor_prints_what_the_emulator_sends_as_json_lines() {
    use std::io::BufRead;
    let mut emulator = Command::new(env!("CARGO_BIN_EXE_tactile_force"))
        .args(["biotac-emulator", "--pty", "--frames", "1000"])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::null())
        .spawn()
        .expect("the emulator starts");
    let mut line = String::new();
    std::io::BufReader::new(emulator.stdout.take().unwrap())
        .read_line(&mut line)
        .unwrap();
    let port = line
        .split_whitespace()
        .last()
        .expect("a port path")
        .to_string();
    let o = run(&[
        "biotac-monitor",
        "--port",
        &port,
        "--frames",
        "20",
        "--jsonl",
    ]);
    let _ = emulator.kill();
    let _ = emulator.wait();
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    let lines: Vec<serde_json::Value> = out
        .lines()
        .map(|l| serde_json::from_str(l).expect("a JSON line"))
        .collect();
    assert_eq!(lines.len(), 21);
    for f in &lines[..20] {
        assert_eq!(f["sensor"], 0);
        assert_eq!(f["electrodes"].as_array().unwrap().len(), 19);
        assert_eq!(f["pac"].as_array().unwrap().len(), 22);
        assert!(f["pdc"].is_u64() && f["tdc"].is_u64() && f["tac"].is_u64() && f["seq"].is_u64());
        assert_eq!(f["invalid"], serde_json::json!([]));
    }
    let stats = &lines[20]["stats"];
    assert!(stats["frames"].as_u64().unwrap() >= 20);
    assert_eq!(
        (stats["crc_errors"].as_u64(), stats["lost"].as_u64()),
        (Some(0), Some(0))
    );
}

#[test]
fn monitor_without_a_bridge_gives_up_with_the_reason() {
    let o = run(&[
        "biotac-monitor",
        "--port",
        "/dev/no-such-bridge",
        "--timeout-s",
        "0.3",
    ]);
    let (_, err) = text(&o);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        err.contains("no frame from /dev/no-such-bridge") && err.contains("No such file"),
        "{err}"
    );
    let o = run(&["biotac-emulator", "--pty", "--fault-rate", "2"]);
    assert!(text(&o).1.contains("--fault-rate 2"), "{:?}", text(&o));
    assert_eq!(o.status.code(), Some(2), "a refused argument");
}

#[test]
fn nail_camera_data_are_collected_trained_on_and_scored_with_the_cnn() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("p1");
    let d = data.to_str().unwrap();
    let o = run(&[
        "collect", "--sensor", "nail", "--unit", "1", "--seed", "1", "--trials", "2", "--out", d,
    ]);
    assert!(o.status.success(), "{:?}", text(&o));
    assert!(
        text(&o).0.contains("wrote 4800 frames (160 s)"),
        "{:?}",
        text(&o)
    );
    assert!(data.join("frames/004799.png").is_file() && data.join("labels.csv").is_file());
    let model = dir.path().join("m.json");
    let m = model.to_str().unwrap();
    let o = run(&["train", "--data", d, "--axes", "fz", "--out", m]);
    assert!(o.status.success(), "{:?}", text(&o));
    assert!(
        text(&o).1.contains("principal components"),
        "{:?}",
        text(&o)
    );
    // A nail model's GPs take a cubic mean by default (one line for fz).
    let file = std::fs::read_to_string(&model).unwrap();
    assert!(file.contains("\"linear\":{\"weights\":["), "no linear mean");
    assert!(file.contains("\"bend\":{\"along\":[["), "no bend");
    // Its trials were tared on their first second.
    assert!(
        file.contains("\"tare\":{\"samples\":30,"),
        "not tared on 30 frames"
    );
    let o = run(&["train", "--data", d, "--mean", "affine", "--out", m]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        text(&o)
            .1
            .contains("expected zero, linear, cubic or network"),
        "{:?}",
        text(&o)
    );
    let o = run(&["eval", "--model", m, "--test", d, "--json"]);
    assert!(o.status.success(), "{:?}", text(&o));
    let r2 = last_json(&text(&o).0)["gp"]["r2"]["fz"].as_f64().unwrap();
    assert!(r2 > 0.9, "fz R2 of a nail model on its own data: {r2}");
    // Cross-validation on 150 training frames (on 300 the CNN's
    // fits took 40 of this test's 50 s): GP, and the CNN beside it.
    let o = run(&[
        "eval",
        "--data",
        d,
        "--folds",
        "2",
        "--axes",
        "fx,fy,fz",
        "--max-train",
        "150",
        "--no-nn",
        "--json",
    ]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    let json = last_json(&out);
    let gp = json["gp"]["r2"]["fz"].as_f64().unwrap();
    let cnn = json["cnn"]["r2"]["fz"].as_f64().unwrap();
    assert!(gp > 0.8 && cnn > 0.3, "fz R2: GP {gp}, CNN {cnn}");
    let pooled = json["gp"]["direction_deg"]["peaks"].as_u64().unwrap();
    assert!(pooled > 0);
    assert!(out.contains("tangential force direction at"), "{out}");
    // Each fold's peaks on a line of its own; together, the pooled ones.
    let mut per_fold = 0;
    for f in json["folds"].as_array().unwrap() {
        if let Some(peaks) = f["gp"]["direction_deg"]["peaks"].as_u64() {
            let line = format!(
                "GP, {}: tangential force direction at {peaks} peaks",
                f["fold"]
            );
            assert!(out.contains(&line), "no '{line}' in {out}");
            per_fold += peaks;
        }
    }
    assert_eq!(per_fold, pooled);
    // BioTac files and nail directories do not mix; nail inputs are raw.
    let csv = dir.path().join("d.csv");
    std::fs::write(&csv, "t,set,trial,e1\n0,1,1,1\n").unwrap();
    let mixed = format!("{d},{}", csv.display());
    let o = run(&["train", "--data", &mixed, "--out", m]);
    assert_eq!(o.status.code(), Some(2));
    assert!(text(&o)
        .1
        .contains("mix nail-camera directories and BioTac files"));
    let o = run(&["train", "--data", d, "--input", "standard", "--out", m]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        text(&o).1.contains("take their projected pixels raw"),
        "{:?}",
        text(&o)
    );
}

#[test]
fn the_radial_test_scores_one_direction_per_push_from_the_given_force() {
    let dir = tempfile::tempdir().unwrap();
    let ok = |args: &[&str]| {
        let o = run(args);
        assert!(o.status.success(), "{args:?}: {:?}", text(&o));
        text(&o).0
    };
    let path = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    // Three directions of two 6 s cycles: the second cycle's tangential
    // force peaks at mu Fz_max = 5 N.
    let shipped =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/config/nail_sim.yaml"))
            .unwrap();
    let short = shipped
        .replace("directions: 12", "directions: 3")
        .replace("cycles: 5", "cycles: 2")
        .replace("cycle_s: 40.0", "cycle_s: 6.0");
    assert_ne!(short, shipped);
    std::fs::write(path("short.yaml"), short).unwrap();
    let (cfg, radial) = (path("short.yaml"), path("radial"));
    let out = ok(&[
        "collect",
        "--sensor",
        "nail",
        "--protocol",
        "radial",
        "--config",
        &cfg,
        "--out",
        &radial,
    ]);
    assert!(out.contains("wrote 1170 frames (39 s)"), "{out}");
    let (sets, m) = (path("sets"), path("m.json"));
    ok(&[
        "collect", "--sensor", "nail", "--trials", "1", "--out", &sets,
    ]);
    ok(&[
        "train",
        "--data",
        &sets,
        "--axes",
        "fx,fy",
        "--max-train",
        "300",
        "--out",
        &m,
    ]);
    let score = |n| vec!["eval", "--model", &m, "--test", &radial, "--peak-min-n", n];
    let out = ok(&[score("2"), vec!["--json"]].concat());
    let d = &last_json(&out)["gp"]["direction_deg"];
    assert_eq!(
        (d["peaks"].as_u64(), d["min_peak_n"].as_f64()),
        (Some(3), Some(2.0))
    );
    assert!(d["max_deg"].as_f64().unwrap() < 30.0, "{d}");
    assert!(out.contains("at 3 peaks (|Ft| >= 2 N)"), "{out}");
    // Refused: the BioTac has no radial test, the radial test no --trials,
    // a peak force that the noise at rest would reach.
    for (args, says) in [
        (
            vec!["collect", "--protocol", "radial", "--out", &radial],
            "add --sensor nail",
        ),
        (
            vec![
                "collect",
                "--sensor",
                "nail",
                "--protocol",
                "radial",
                "--trials",
                "2",
                "--out",
                &radial,
            ],
            "one trial per direction",
        ),
        (score("0"), "at least 0.1 N"),
    ] {
        let o = run(&args);
        assert_eq!(o.status.code(), Some(2), "{args:?}");
        assert!(text(&o).1.contains(says), "{args:?}: {:?}", text(&o));
    }
}

#[test]
fn a_demo_whose_task_does_not_hold_exits_3_with_the_reason_and_its_figures() {
    let dir = tempfile::tempdir().unwrap();
    // The object is 10 mm away; the approach gives up after 5 mm.
    let scene = dir.path().join("short.yaml");
    let text_yaml = include_str!("../config/guarded_move.yaml")
        .replace("max_distance_m: 0.05", "max_distance_m: 0.005");
    std::fs::write(&scene, text_yaml).unwrap();
    let o = run_cached(
        &[
            "demo",
            "guarded",
            "--scene",
            scene.to_str().unwrap(),
            "--json",
        ],
        dir.path(),
    );
    let (out, err) = text(&o);
    assert_eq!(o.status.code(), Some(3), "{err}");
    assert!(
        err.contains("did not hold: it stopped on travel_limit"),
        "{err}"
    );
    assert_eq!(last_json(&out)["reason"].as_str(), Some("travel_limit"));
}

#[test]
fn errors_say_their_cause_once_and_name_the_file_s_role() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("m.json");
    let out = out.to_str().unwrap();
    for (args, says) in [
        (
            vec!["eval", "--data", "/nope.csv"],
            "data file /nope.csv: No such file or directory (os error 2)",
        ),
        (
            vec!["demo", "guarded", "--model", "/nope.json"],
            "model file /nope.json: No such file or directory (os error 2)",
        ),
        (
            vec!["train", "--data", "/nope.csv", "--out", out],
            "data file /nope.csv: No such file or directory (os error 2)",
        ),
        (
            vec![
                "adapt",
                "--model",
                "/nope.json",
                "--data",
                "/nope.csv",
                "--out",
                out,
            ],
            "model file /nope.json: No such file or directory (os error 2)",
        ),
        (
            vec!["demo", "guarded", "--scene", "/nope.yaml"],
            "scene file /nope.yaml: No such file or directory (os error 2)",
        ),
        (
            vec!["eval", "--data", "/nope.mcap"],
            "bag /nope.mcap: cannot read: No such file or directory (os error 2)",
        ),
    ] {
        let o = run_cached(&args, dir.path());
        let (_, err) = text(&o);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert_eq!(err, format!("error: {says}\n"), "{args:?}");
    }
}

#[test]
fn every_output_is_checked_before_the_work_and_refused_naming_its_role() {
    let dir = tempfile::tempdir().unwrap();
    let d = |name: &str| dir.path().join(name).display().to_string();
    let (model, png) = (d("u2.json"), d("c.png"));
    for (args, says) in [
        (
            vec![
                "demo",
                "calibrate",
                "--unit",
                "2",
                "--out",
                "/nonexistent-dir/u2.json",
            ],
            "model file /nonexistent-dir/u2.json: its folder /nonexistent-dir does not exist"
                .to_string(),
        ),
        (
            vec![
                "demo",
                "calibrate",
                "--unit",
                "2",
                "--out",
                &model,
                "--plot",
                "calib.svg",
            ],
            "plot calib.svg: the format .svg is not written (supported: .png)".to_string(),
        ),
        (
            vec![
                "demo",
                "calibrate",
                "--out",
                &model,
                "--session",
                "/nonexistent-dir/s.mcap",
            ],
            "session /nonexistent-dir/s.mcap: its folder /nonexistent-dir does not exist"
                .to_string(),
        ),
        (
            vec!["demo", "calibrate", "--out", &model, "--session", &model],
            format!("session {model}: is the model file too"),
        ),
        (
            vec![
                "demo",
                "guarded",
                "--plot",
                &png,
                "--csv",
                "/nonexistent-dir/t.csv",
            ],
            "trace CSV /nonexistent-dir/t.csv: its folder /nonexistent-dir does not exist"
                .to_string(),
        ),
        (
            vec![
                "train",
                "--data",
                "/nope.csv",
                "--out",
                "/nonexistent-dir/m.json",
            ],
            "model file /nonexistent-dir/m.json: its folder /nonexistent-dir does not exist"
                .to_string(),
        ),
    ] {
        let t0 = std::time::Instant::now();
        let o = run_cached(&args, dir.path());
        let took = t0.elapsed().as_secs_f64();
        let (out, err) = text(&o);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(&says), "{args:?}: {err}");
        // Refused before the default model's training and with the arm still.
        assert!(took < 5.0, "{args:?}: refused after {took:.2} s");
        assert!(!out.contains("calibration, BioTac unit"), "{out}");
        assert!(!err.contains("default model"), "{err}");
    }
    let left: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
    assert!(left.is_empty(), "nothing written: {left:?}");
}

#[test]
fn the_exit_code_table_has_every_command_and_holds() {
    let doc = include_str!("../docs/development.md");
    let table = &doc[doc.find("## Exit codes").unwrap()..];
    let o = run(&["--help"]);
    let help = text(&o).0;
    let commands = help
        .split("Commands:")
        .nth(1)
        .unwrap()
        .lines()
        .filter_map(|l| l.split_whitespace().next())
        .take_while(|w| *w != "Options:")
        .filter(|w| *w != "help")
        .collect::<Vec<_>>();
    assert!(commands.len() >= 9, "{commands:?}");
    for c in &commands {
        assert!(table.contains(&format!("| `{c}")), "no row for {c}");
    }
    // Rows checked: refused (2) for an output before the work, and for a
    // missing file; the task that did not hold (3) is
    // a_demo_whose_task_does_not_hold_exits_3_with_the_reason_and_its_figures.
    assert!(table.contains("the model file, the session (its folder"));
    let o = run(&[
        "train",
        "--data",
        "/nope.csv",
        "--out",
        "/nonexistent-dir/m.json",
    ]);
    assert_eq!(o.status.code(), Some(2));
    let o = run(&["robot", "--urdf", "/nope.urdf", "--base", "b", "--tip", "t"]);
    assert_eq!(o.status.code(), Some(2), "{:?}", text(&o));
    assert!(
        text(&o).1.contains("URDF file /nope.urdf"),
        "{:?}",
        text(&o)
    );
}
