//! The sessions reader: taring, the F/T frame, sensors that do not match.

use super::*;

use std::io::Write;
use std::path::Path;

use crate::biotac::ElectrodeLayout;

fn csv(dir: &Path, name: &str, text: &str) -> PathBuf {
    let path = dir.join(name);
    std::fs::File::create(&path)
        .and_then(|mut f| f.write_all(text.as_bytes()))
        .unwrap();
    path
}

fn quiet() -> impl FnMut(String) {
    |_| {}
}

#[test]
fn each_file_is_tared_per_trial_and_the_baselines_averaged() {
    let dir = tempfile::tempdir().unwrap();
    let a = csv(
        dir.path(),
        "a.csv",
        "set,trial,e1,fz\n1,1,10,0\n1,1,12,0.5\n1,2,30,0\n1,2,31,0.2\n",
    );
    let b = csv(
        dir.path(),
        "b.csv",
        "set,trial,e1,fz\n1,1,20,0\n1,1,26,0.4\n",
    );
    let features = ["e1".to_string()];
    let axes: AxisSet = "fz".parse().unwrap();
    let request = Request {
        paths: &[a, b],
        features: Features::Model(&features),
        axes: &axes,
        tare_samples: Some(1),
        source: &Source::default(),
        sensor: None,
    };
    let s = load_sessions(&request, &mut quiet()).unwrap();
    assert_eq!(s.sets[0].x.column(0).to_vec(), vec![0.0, 2.0, 0.0, 1.0]);
    assert_eq!(s.sets[1].x.column(0).to_vec(), vec![0.0, 6.0]);
    // a: trials at 10 and 30 (mean 20); b: 20.
    assert_eq!(s.tare.mean_baseline, vec![20.0]);
    assert_eq!(s.tare.samples, 1);
    assert_eq!(s.sensor, SensorSpec::biotac(ElectrodeLayout::Biotac));
    assert_eq!(s.pooled().unwrap().len(), 6);
}

#[test]
fn an_ft_sensor_turned_half_about_x_gives_the_wrench_in_the_biotac_frame() {
    let dir = tempfile::tempdir().unwrap();
    let f = csv(
        dir.path(),
        "f.csv",
        "set,trial,e1,fx,fy,fz\n1,1,10,0.1,0.2,0.5\n",
    );
    let features = ["e1".to_string()];
    let source = Source {
        ft_to_biotac: Some("180,0,0,0,0,0".parse().unwrap()),
        ..Source::default()
    };
    let axes: AxisSet = "fy,fz".parse().unwrap();
    let read = |source: &Source| {
        let features = |_, _: &dyn Fn(&str) -> bool| Ok(features.to_vec());
        formats::read(&f, &features, &axes, Counts::Raw, source, &mut quiet())
            .unwrap()
            .rows
    };
    let ds = read(&source);
    let y = ds.y.row(0).to_vec();
    assert!(
        (y[0] + 0.2).abs() < 1e-12 && (y[1] + 0.5).abs() < 1e-12,
        "{y:?}"
    );
    assert_eq!(ds.axes, axes);
    // Without the frame change the file's own values.
    let ds = read(&Source::default());
    assert_eq!(ds.y.row(0).to_vec(), vec![0.2, 0.5]);
}

#[test]
fn files_of_two_sensors_or_not_the_models_sensor_are_refused_by_name() {
    let dir = tempfile::tempdir().unwrap();
    let e20 = (1..=24)
        .map(|i| format!("e{i}"))
        .collect::<Vec<_>>()
        .join(",");
    let zeros = vec!["0"; 24].join(",");
    let sp = csv(
        dir.path(),
        "sp.csv",
        &format!("set,trial,{e20},fz\n1,1,{zeros},0\n"),
    );
    let bt = csv(dir.path(), "bt.csv", "set,trial,e1,fz\n1,1,10,0\n");
    let axes: AxisSet = "fz".parse().unwrap();
    let channels = [Channel::Electrodes];
    let load = |paths: &[PathBuf], sensor: Option<&SensorSpec>| {
        let request = Request {
            paths,
            features: Features::Channels(&channels),
            axes: &axes,
            tare_samples: Some(0),
            source: &Source::default(),
            sensor,
        };
        load_sessions(&request, &mut quiet())
    };
    let err = load(&[sp.clone(), bt.clone()], None).unwrap_err();
    assert!(
        err.to_string().contains("the data files mix sensors"),
        "{err}"
    );
    assert_eq!(err.class(), ExitClass::Refused);
    let s = load(std::slice::from_ref(&sp), None).unwrap();
    assert_eq!(s.sensor, SensorSpec::biotac(ElectrodeLayout::BiotacSp));
    assert_eq!(s.sets[0].features.len(), 24);
    let model = SensorSpec::biotac(ElectrodeLayout::Biotac);
    let err = load(std::slice::from_ref(&sp), Some(&model)).unwrap_err();
    assert!(err.to_string().contains("readings have"), "{err}");
    // A nail-camera directory beside a CSV.
    let nail = dir.path().join("nail");
    std::fs::create_dir_all(nail.join(crate::nail::collect::FRAMES_DIR)).unwrap();
    csv(&nail, crate::nail::collect::LABELS_FILE, "");
    let err = load(&[nail, bt], None).unwrap_err();
    assert!(
        err.to_string().contains("mix nail-camera directories"),
        "{err}"
    );
}

#[test]
fn held_channels_are_those_every_file_holds_each_file_read_once() {
    let dir = tempfile::tempdir().unwrap();
    let e: Vec<String> = (1..=19).map(|i| format!("e{i}")).collect();
    let tens = vec!["10"; 19].join(",");
    let a = csv(
        dir.path(),
        "a.csv",
        &format!("{},pdc,tac,fz\n{tens},2000,30,0.5\n", e.join(",")),
    );
    let b = csv(
        dir.path(),
        "b.csv",
        &format!("{},pdc,fz\n{tens},2100,0.4\n", e.join(",")),
    );
    let all = [
        Channel::Electrodes,
        Channel::Pdc,
        Channel::Tdc,
        Channel::Tac,
    ];
    let axes: AxisSet = "fz".parse().unwrap();
    let request = Request {
        paths: &[a, b],
        features: Features::Held(&all),
        axes: &axes,
        tare_samples: Some(0),
        source: &Source::default(),
        sensor: None,
    };
    let s = load_sessions(&request, &mut quiet()).unwrap();
    assert_eq!(s.channels_of(&all), [Channel::Electrodes, Channel::Pdc]);
    let mut names = e.clone();
    names.push("pdc".into());
    for set in &s.sets {
        assert_eq!(set.features, names);
    }
    assert_eq!(s.pooled().unwrap().x.column(19).to_vec(), [2000.0, 2100.0]);
    // Asked for by name, a channel a file lacks is refused with its column.
    let request = Request {
        features: Features::Channels(&all),
        ..request
    };
    let err = load_sessions(&request, &mut quiet()).unwrap_err();
    assert!(err.to_string().contains("\"tdc\""), "{err}");
}
