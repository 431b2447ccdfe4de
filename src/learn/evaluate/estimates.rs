//! `eval --model M --test FILES --estimates OUT.csv`: the model's estimate
//! of every row of the test files (a bag's: the readings with a wrench),
//! one CSV line each, as `eval` scores
//! them: to set beside what the nodes publish for the same readings (a
//! recording played back into `wrench_estimator`).

use super::{check_fits, EvalError};
use crate::learn::data::Dataset;
use crate::learn::models::wrench_model::WrenchModel;

/// The CSV of `model`'s estimates for `files` (each its name as given and
/// its rows, tared as `eval` tares them): a header, then one line per row
/// of each file in its order (a bag's: its readings with an F/T wrench
/// within 5 ms, in stamp order): `file,row,set,trial` (`row` from 0 within the file), then for
/// each of the model's axes its estimate (`fz_estimate`: the mean, N or
/// N m) and the file's label (`fz_label`: the reference, tared).
pub fn estimates_csv(
    model: &dyn WrenchModel,
    files: &[(&str, &Dataset)],
) -> Result<String, EvalError> {
    let axes = model.axes().axes();
    let mut out = String::from("file,row,set,trial");
    for a in axes {
        out += &format!(",{0}_estimate,{0}_label", a.name());
    }
    out.push('\n');
    for (name, data) in files {
        check_fits(model, data)?;
        let pred = model.predict_observed(data.x.view(), false)?;
        let name = quoted(name);
        for i in 0..data.len() {
            out += &format!("{name},{i},{},{}", data.set[i], data.trial[i]);
            for j in 0..axes.len() {
                // `{}` writes the shortest text that reads back to the same f64.
                out += &format!(",{},{}", pred.mean[[i, j]], data.y[[i, j]]);
            }
            out.push('\n');
        }
    }
    Ok(out)
}

/// `field` as a CSV field: in double quotes (doubled inside) when it holds
/// a comma, a quote or a line break.
fn quoted(field: &str) -> String {
    if field.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", field.replace('"', "\"\""))
    } else {
        field.to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::learn::models::wrench_gp::{quick_fit, TareSpec};
    use ndarray::Array2;

    /// `n` rows of 3 electrodes, fx and fz linear in them; trial 1 then 2.
    fn data(n: usize, offset: f64) -> Dataset {
        let x = Array2::from_shape_fn((n, 3), |(i, j)| ((i * 7 + j * 3) % 11) as f64 - offset);
        let y = Array2::from_shape_fn((n, 2), |(i, j)| x[[i, 0]] * (j as f64 + 1.0) + x[[i, 1]]);
        Dataset {
            features: vec!["e1".into(), "e2".into(), "e3".into()],
            x,
            axes: "fx,fz".parse().unwrap(),
            y,
            set: vec![1; n],
            trial: (0..n).map(|i| 1 + (2 * i / n) as u32).collect(),
            images: None,
        }
    }

    #[test]
    fn one_line_per_row_with_the_estimate_eval_scores_and_the_label() {
        let tare = TareSpec {
            samples: 5,
            mean_baseline: vec![0.0; 3],
        };
        let model = quick_fit(&data(40, 5.0), tare);
        let (a, b) = (data(6, 4.0), data(4, 6.0));
        let text = estimates_csv(&model, &[("a, first.mcap", &a), ("b.csv", &b)]).unwrap();
        let mut r = csv::Reader::from_reader(text.as_bytes());
        let header: Vec<String> = r.headers().unwrap().iter().map(String::from).collect();
        assert_eq!(
            header,
            [
                "file",
                "row",
                "set",
                "trial",
                "fx_estimate",
                "fx_label",
                "fz_estimate",
                "fz_label"
            ]
        );
        let lines: Vec<csv::StringRecord> = r.records().map(Result::unwrap).collect();
        assert_eq!(lines.len(), 10);
        let want_a = model.predict_observed(a.x.view(), false).unwrap().mean;
        let want_b = model.predict_observed(b.x.view(), false).unwrap().mean;
        for (k, line) in lines.iter().enumerate() {
            let (name, data, want, i) = match k {
                0..=5 => ("a, first.mcap", &a, &want_a, k),
                _ => ("b.csv", &b, &want_b, k - 6),
            };
            assert_eq!(
                &line[0], name,
                "a name with a comma is quoted, read back whole"
            );
            assert_eq!(line[1].parse::<usize>().unwrap(), i);
            assert_eq!(line[2].parse::<u32>().unwrap(), data.set[i]);
            assert_eq!(line[3].parse::<u32>().unwrap(), data.trial[i]);
            for j in 0..2 {
                // Bit for bit: the text reads back to the same number.
                let estimate: f64 = line[4 + 2 * j].parse().unwrap();
                assert_eq!(estimate.to_bits(), want[[i, j]].to_bits());
                assert_eq!(line[5 + 2 * j].parse::<f64>().unwrap(), data.y[[i, j]]);
            }
        }
        assert_eq!(
            (&lines[5][3], &lines[6][3]),
            ("2", "1"),
            "each file's trials"
        );
    }

    #[test]
    fn data_of_other_features_are_refused() {
        let tare = TareSpec {
            samples: 5,
            mean_baseline: vec![0.0; 3],
        };
        let model = quick_fit(&data(40, 5.0), tare);
        let mut other = data(4, 5.0);
        other.features[2] = "pdc".into();
        let e = estimates_csv(&model, &[("c.csv", &other)]).unwrap_err();
        assert!(matches!(e, EvalError::Mismatch(_)), "{e}");
    }
}
