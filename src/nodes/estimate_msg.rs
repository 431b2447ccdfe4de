//! `tactile_force_msgs/msg/WrenchEstimate` <-> [`WrenchEstimate`]: the CDR
//! bytes a raw publisher sends and a raw subscription delivers
//! (`msg/msg/WrenchEstimate.msg`). Under r2r's `doc-only` build there are
//! no Rust types for our own interface package, so the topic is untyped,
//! as the BioTac's is ([`crate::biotac::msg`]): this module is the one place
//! that knows its fields. It needs no ROS installation.

use serde::{Deserialize, Serialize};

use crate::biotac::msg::{join_stamp, split_stamp};
use crate::learn::models::model_file::ModelId;
use crate::wrench::{Axis, Wrench, WrenchEstimate};

/// The ROS type name of the estimate topic.
pub const ESTIMATE_MSG_TYPE: &str = "tactile_force_msgs/msg/WrenchEstimate";

/// Why an estimate message was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum EstimateMsgError {
    /// Not a WrenchEstimate in CDR.
    #[error("WrenchEstimate message: not decodable as CDR ({0})")]
    Cdr(String),
    /// A NaN or an infinity where the model estimates.
    #[error("WrenchEstimate message: {0} is not finite on an estimated axis")]
    NonFinite(&'static str),
}

/// The message's fields in their CDR order (a Wrench is six float64:
/// force x, y, z, torque x, y, z).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct CdrEstimate {
    sec: i32,
    nanosec: u32,
    frame_id: String,
    wrench: [f64; 6],
    stddev: [f64; 6],
    estimated: [bool; 6],
    model_file: String,
    model_sha256: String,
    reading_age_s: f64,
    pdc_rise_counts: f64,
}

/// A wrench's six numbers, NaN where `masked`.
fn six(w: &Wrench, masked: impl Fn(usize) -> bool) -> [f64; 6] {
    Axis::ALL.map(|a| {
        if masked(a.index()) {
            f64::NAN
        } else {
            w.get(a)
        }
    })
}

/// `e` as a serialized message in `frame_id` (little-endian CDR with its
/// encapsulation header): NaN on the axes the model does not estimate,
/// and in `stddev` everywhere without `with_std`; made by `model`, `age_s`
/// after its reading. None when a number is not finite.
pub fn to_cdr(
    e: &WrenchEstimate,
    frame_id: &str,
    with_std: bool,
    model: &ModelId,
    age_s: f64,
) -> Option<Vec<u8>> {
    if !e.is_finite() {
        return None;
    }
    let (sec, nanosec) = split_stamp(e.stamp_s);
    let m = CdrEstimate {
        sec,
        nanosec,
        frame_id: frame_id.into(),
        wrench: six(&e.mean, |i| !e.estimated[i]),
        stddev: six(&e.std, |i| !with_std || !e.estimated[i]),
        estimated: e.estimated,
        model_file: model.file.clone(),
        model_sha256: model.sha256.clone(),
        reading_age_s: age_s,
        pdc_rise_counts: e.pdc_rise,
    };
    cdr::serialize::<_, _, cdr::CdrLe>(&m, cdr::Infinite).ok()
}

/// The estimate in a serialized message and its frame: 0 on the axes it
/// does not estimate, and a std of 0 when it has none at all (the
/// estimator's `with_std` false: the controller's out-of-range check then
/// rests on PDC alone); refused when an estimated axis's mean, or its std
/// while another axis has one, is not finite.
pub fn from_cdr(bytes: &[u8]) -> Result<(WrenchEstimate, String), EstimateMsgError> {
    let m: CdrEstimate =
        cdr::deserialize(bytes).map_err(|e| EstimateMsgError::Cdr(e.to_string()))?;
    let on = |i: usize| m.estimated[i];
    let has_std = (0..6).any(|i| on(i) && !m.stddev[i].is_nan());
    let read = |values: &[f64; 6], what: &'static str| {
        let mut w = Wrench::default();
        for a in Axis::ALL.into_iter().filter(|a| on(a.index())) {
            let x = values[a.index()];
            if !x.is_finite() {
                return Err(EstimateMsgError::NonFinite(what));
            }
            w.set(a, x);
        }
        Ok(w)
    };
    let e = WrenchEstimate {
        stamp_s: join_stamp(m.sec, m.nanosec),
        seq: 0,
        mean: read(&m.wrench, "wrench")?,
        std: if has_std {
            read(&m.stddev, "stddev")?
        } else {
            Wrench::default()
        },
        estimated: m.estimated,
        pdc_rise: m.pdc_rise_counts,
    };
    if !e.is_finite() {
        return Err(EstimateMsgError::NonFinite("pdc_rise_counts"));
    }
    Ok((e, m.frame_id))
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;

    fn estimate() -> WrenchEstimate {
        WrenchEstimate {
            stamp_s: 3.5,
            seq: 9,
            mean: Wrench::new(Vector3::new(0.1, -0.2, 1.5), Vector3::new(0.0, 0.01, 0.0)),
            std: Wrench::new(Vector3::new(0.05, 0.05, 0.04), Vector3::zeros()),
            estimated: [true, true, true, false, false, false],
            pdc_rise: 42.0,
        }
    }

    fn decoded(bytes: &[u8]) -> CdrEstimate {
        cdr::deserialize(bytes).unwrap()
    }

    #[test]
    fn an_estimate_is_one_message_nan_where_not_estimated_and_comes_back_whole() {
        let model = ModelId {
            file: "/m/gp.json".into(),
            sha256: "ba7816bf8f01cfea".into(),
        };
        let bytes = to_cdr(&estimate(), "biotac", true, &model, 0.004).unwrap();
        let m = decoded(&bytes);
        assert_eq!(
            (m.sec, m.nanosec, m.frame_id.as_str()),
            (3, 500_000_000, "biotac")
        );
        assert_eq!((m.wrench[2], m.stddev[2]), (1.5, 0.04));
        assert!(
            m.wrench[4].is_nan() && m.stddev[3].is_nan(),
            "torques not estimated"
        );
        assert_eq!(
            (m.model_file.as_str(), m.model_sha256.as_str()),
            ("/m/gp.json", "ba7816bf8f01cfea")
        );
        assert_eq!((m.reading_age_s, m.pdc_rise_counts), (0.004, 42.0));
        let (back, frame) = from_cdr(&bytes).unwrap();
        let mut expected = estimate();
        expected.mean.torque.y = 0.0; // 0 where not estimated, as the models give it
        expected.seq = 0; // ROS 2 headers carry none
        assert_eq!((back, frame.as_str()), (expected, "biotac"));
        // Without with_std: no std on the wire, 0 for the controller.
        let bytes = to_cdr(&estimate(), "biotac", false, &model, 0.004).unwrap();
        assert!(decoded(&bytes).stddev[2].is_nan());
        assert_eq!(from_cdr(&bytes).unwrap().0.std, Wrench::default());
    }

    #[test]
    fn nan_is_never_sent_and_refused_where_estimated() {
        let mut e = estimate();
        e.mean.force.x = f64::NAN;
        assert!(to_cdr(&e, "biotac", true, &ModelId::default(), 0.0).is_none());
        let good = decoded(&to_cdr(&estimate(), "biotac", true, &ModelId::default(), 0.0).unwrap());
        let bytes = |m: &CdrEstimate| cdr::serialize::<_, _, cdr::CdrLe>(m, cdr::Infinite).unwrap();
        let mut m = good.clone();
        m.wrench[1] = f64::INFINITY;
        assert_eq!(
            from_cdr(&bytes(&m)),
            Err(EstimateMsgError::NonFinite("wrench"))
        );
        let mut m = good.clone();
        m.stddev[0] = f64::NAN; // one std missing among others
        assert_eq!(
            from_cdr(&bytes(&m)),
            Err(EstimateMsgError::NonFinite("stddev"))
        );
        let cut = bytes(&good);
        assert!(matches!(
            from_cdr(&cut[..cut.len() - 9]),
            Err(EstimateMsgError::Cdr(_))
        ));
    }

    #[test]
    fn the_fields_are_those_of_the_message_file_in_its_order() {
        let text = include_str!("../../msg/msg/WrenchEstimate.msg");
        let fields: Vec<&str> = text
            .lines()
            .map(str::trim)
            .filter(|l| !l.is_empty() && !l.starts_with('#'))
            .collect();
        assert_eq!(
            fields,
            [
                "std_msgs/Header header",
                "geometry_msgs/Wrench wrench",
                "geometry_msgs/Wrench stddev",
                "bool[6] estimated",
                "string model_file",
                "string model_sha256",
                "float64 reading_age_s",
                "float64 pdc_rise_counts",
            ]
        );
    }
}
