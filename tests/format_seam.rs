//! The data-format seam is open: a format defined here, outside the crate,
//! in this one file, is read once registered by everything that reads data
//! files: the sessions reader of `train`, `eval`, `adapt` and `tradeoff`,
//! pooled retraining, and the calibration's pooled candidate.

mod seam_data;

use std::path::{Path, PathBuf};

use nalgebra::Vector3;

use seam_data::{quick, unit};
use tactile_force::biotac::{BioTacReading, ElectrodeLayout, Electrodes};
use tactile_force::learn::calibration::{fit, Recorded};
use tactile_force::learn::data::format::{has_extension, FileError, FileRows, Format, Say, Want};
use tactile_force::learn::data::formats::{format_of, register};
use tactile_force::learn::data::sessions::{
    load_sessions, Features, Request, SessionError, Sessions,
};
use tactile_force::learn::data::source::Source;
use tactile_force::learn::data::{write_csv, Channel, DatasetError};
use tactile_force::learn::models::provenance::TrainedOn;
use tactile_force::learn::models::wrench_gp::WrenchGp;
use tactile_force::learn::pooled::{base_data, data_file};
use tactile_force::record::Record;
use tactile_force::wrench::{AxisSet, Wrench};

/// A toy format: `.toy` files of one reading per line, white-space
/// separated: trial, fx, fy, fz (N), then the 19 electrodes, pdc, tdc, tac.
struct Toy;

impl Format for Toy {
    fn name(&self) -> &'static str {
        "toy"
    }

    fn reads(&self, path: &Path) -> bool {
        has_extension(path, "toy")
    }

    fn read(&self, path: &Path, want: &Want, _: Say) -> Result<FileRows, FileError> {
        let name = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|source| DatasetError::Io {
            path: name.clone(),
            source,
        })?;
        let mut records = Vec::new();
        for (i, line) in text.lines().enumerate() {
            let bad = |value: &str| DatasetError::BadValue {
                path: name.clone(),
                line: i as u64 + 1,
                column: "any".into(),
                value: value.into(),
            };
            let v: Vec<f64> = (line.split_whitespace())
                .map(|f| f.parse().map_err(|_| bad(f)))
                .collect::<Result<_, _>>()?;
            if v.len() != 26 {
                return Err(bad(line).into());
            }
            let counts: Vec<u16> = v[4..].iter().map(|&c| c as u16).collect();
            let mut reading = BioTacReading::zeroed(ElectrodeLayout::Biotac);
            reading.electrodes = Electrodes::from_slice(&counts[..19]).map_err(|_| bad(line))?;
            (reading.pdc, reading.tdc, reading.tac) = (counts[19], counts[20], counts[21]);
            records.push(Record {
                t: 0.0,
                set: 1,
                trial: v[0] as u32,
                reading,
                wrench: Wrench::new(Vector3::new(v[1], v[2], v[3]), Vector3::zeros()),
            });
        }
        want.records(&records, &name)
    }
}

/// `records` as a toy file.
fn write_toy(path: &Path, records: &[Record]) {
    let lines: Vec<String> = records
        .iter()
        .map(|r| {
            let f = r.wrench.force;
            let mut fields = vec![r.trial.to_string(), f.x.to_string(), f.y.to_string()];
            fields.push(f.z.to_string());
            fields.extend(r.reading.electrodes.iter().map(|e| e.to_string()));
            let rd = &r.reading;
            fields.extend([rd.pdc, rd.tdc, rd.tac].map(|c| c.to_string()));
            fields.join(" ")
        })
        .collect();
    std::fs::write(path, lines.join("\n")).unwrap();
}

/// The files' electrodes, pdc and tdc, and fx, fz, each trial tared on 10 rows.
fn sessions(paths: &[PathBuf]) -> Result<Sessions, SessionError> {
    let channels = [Channel::Electrodes, Channel::Pdc, Channel::Tdc];
    let request = Request {
        paths,
        features: Features::Channels(&channels),
        axes: &"fx,fz".parse::<AxisSet>().unwrap(),
        tare_samples: Some(10),
        source: &Source::default(),
        sensor: None,
    };
    load_sessions(&request, &mut |_| {})
}

#[test]
fn a_format_defined_outside_is_read_by_every_reader_once_registered() {
    let dir = tempfile::tempdir().unwrap();
    let records = unit(2, 2);
    let (toy, csv) = (dir.path().join("u2.toy"), dir.path().join("u2.csv"));
    write_toy(&toy, &records);
    write_csv(&csv, &records).unwrap();
    assert_eq!(format_of(&toy).name(), "CSV");
    register(&Toy);
    assert_eq!(format_of(&toy).name(), "toy");
    assert_eq!(format_of(&csv).name(), "CSV");

    // The sessions reader: the same rows as the CSV of the same records
    // (its wrenches printed to 6 decimals).
    let (from_toy, from_csv) = (
        sessions(std::slice::from_ref(&toy)).unwrap(),
        sessions(&[csv]).unwrap(),
    );
    let (a, b) = (from_toy.pooled().unwrap(), from_csv.pooled().unwrap());
    assert_eq!((a.features.len(), a.len()), (21, records.len()));
    assert_eq!((&a.features, &a.x, &a.trial), (&b.features, &b.x, &b.trial));
    let dy = (&a.y - &b.y).iter().fold(0.0_f64, |m, d| m.max(d.abs()));
    assert!(dy < 1e-6, "{dy}");
    assert_eq!(from_toy.tare, from_csv.tare);

    // Pooled retraining reads the toy file a model records as its data.
    let params = quick().validate().unwrap();
    let on = TrainedOn {
        files: vec![data_file(&toy, a.len()).unwrap()],
        params: quick(),
    };
    let model = WrenchGp::train(&a, from_toy.tare.clone(), &params, &mut |_, _| {})
        .unwrap()
        .with_trained_on(Some(on));
    let base = base_data(&model, None).unwrap();
    assert_eq!(base.data.x, a.x);

    // So does the calibration of another unit with that model as current:
    // its model pooled with the toy file's rows is among the candidates.
    let recorded = Recorded {
        motion_s: 40.0,
        peak_force_n: 5.0,
        session: None,
    };
    let (_, record) = fit(&unit(1, 4), &model, recorded, &quick()).unwrap();
    let pooling = record.pooling.unwrap_or_default();
    assert!(
        record.validation.iter().any(|v| v.model == "pooled"),
        "{pooling}"
    );
    assert!(pooling.contains("of 1 file"), "{pooling}");

    // A line the format cannot read is refused with its place.
    let bad = dir.path().join("bad.toy");
    std::fs::write(&bad, "1 0 0 nan?\n").unwrap();
    let err = sessions(&[bad]).map(|_| ()).unwrap_err().to_string();
    assert!(err.contains("bad.toy") && err.contains("line 1"), "{err}");
}
