//! The frames the node's wrenches must come in, checked on every message:
//! the estimate's (`biotac/wrench_estimate`) in the BioTac
//! frame (`biotac_frame`, the estimator's `frame_id`), the F/T sensor's
//! (`ft_sensor/wrench`) in the frame declared for it (`ft_frame`; empty:
//! the BioTac frame, for a sensor whose wrenches are in it already). A
//! wrench in another frame is refused, not used, and said once per frame
//! it came in (log and `/diagnostics`); if the task uses it, the task
//! stops and the goal running ends with both names.

use super::ForcePart;
use crate::params::ParamsError;

/// A wrench that came in another frame than its topic's.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Mismatch {
    /// Its topic.
    pub topic: &'static str,
    /// The frame it came in.
    pub got: String,
    /// The frame the parameters declare for it.
    pub expected: String,
    /// The parameter that declares it.
    pub param: &'static str,
}

impl std::fmt::Display for Mismatch {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} came in frame {:?}, not {:?} ({})",
            self.topic, self.got, self.expected, self.param
        )
    }
}

/// The declared frames, and the mismatches said so far.
#[derive(Debug, Clone)]
pub struct Frames {
    biotac: String,
    ft: String,
    said: Vec<Mismatch>,
}

impl Frames {
    /// The BioTac frame, and the F/T sensor's (`ft_frame`; empty: the
    /// BioTac frame). A sensor placed by `ft_to_biotac` is in a frame of
    /// its own, which must then be named.
    pub fn new(biotac: &str, ft_frame: &str, ft_placed: bool) -> Result<Self, ParamsError> {
        if ft_placed && ft_frame.is_empty() {
            return Err(ParamsError::Invalid {
                key: "ft_frame".into(),
                value: String::new(),
                expected: "the frame_id of the F/T sensor's wrenches, since ft_to_biotac places \
                           the sensor apart from the BioTac frame"
                    .into(),
            });
        }
        let ft = match ft_frame {
            "" => biotac,
            named => named,
        };
        Ok(Frames {
            biotac: biotac.into(),
            ft: ft.into(),
            said: Vec::new(),
        })
    }

    /// Checks the frame a wrench of `part` came in; a mismatch comes back,
    /// `new` the first time it is seen (to be said).
    pub fn check(&mut self, part: ForcePart, frame_id: &str) -> Result<(), (Mismatch, bool)> {
        let (expected, param) = match part {
            ForcePart::Estimate => (&self.biotac, "biotac_frame"),
            ForcePart::Ft => (&self.ft, "ft_frame"),
        };
        if frame_id == expected {
            return Ok(());
        }
        let m = Mismatch {
            topic: part.topic(),
            got: frame_id.into(),
            expected: expected.clone(),
            param,
        };
        let new = !self.said.contains(&m);
        if new {
            self.said.push(m.clone());
        }
        Err((m, new))
    }

    /// The mismatches seen, for `/diagnostics`.
    pub fn refused(&self) -> &[Mismatch] {
        &self.said
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_wrench_in_another_frame_is_refused_with_both_names_said_once() {
        let mut f = Frames::new("biotac", "", false).unwrap();
        assert!(f.check(ForcePart::Estimate, "biotac").is_ok());
        assert!(
            f.check(ForcePart::Ft, "biotac").is_ok(),
            "F/T in the BioTac frame"
        );
        let (m, new) = f.check(ForcePart::Ft, "ft_sensor_link").unwrap_err();
        assert!(new);
        assert_eq!(
            m.to_string(),
            "ft_sensor/wrench came in frame \"ft_sensor_link\", not \"biotac\" (ft_frame)"
        );
        assert!(
            !f.check(ForcePart::Ft, "ft_sensor_link").unwrap_err().1,
            "said once"
        );
        let (m, _) = f.check(ForcePart::Estimate, "").unwrap_err();
        assert_eq!(
            (m.topic, m.param),
            ("biotac/wrench_estimate", "biotac_frame")
        );
        assert_eq!(f.refused().len(), 2);
    }

    #[test]
    fn a_placed_ft_sensor_must_name_its_frame() {
        let e = Frames::new("biotac", "", true).unwrap_err().to_string();
        assert!(e.contains("ft_frame"), "{e}");
        let mut f = Frames::new("biotac", "ft_link", true).unwrap();
        assert!(f.check(ForcePart::Ft, "ft_link").is_ok());
        assert!(f.check(ForcePart::Ft, "biotac").is_err());
    }
}
