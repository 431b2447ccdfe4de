//! The estimate arrives as two messages, its mean and its standard
//! deviation, each stamped with the reading it came from: they are paired
//! by that stamp before the controller takes them.

use crate::wrench::{Wrench, WrenchEstimate};

/// One half of an estimate: the reading's stamp (s) and the wrench.
pub type Half = (f64, Wrench);

/// The newest mean and std not yet paired.
#[derive(Debug, Clone, Default)]
pub struct EstimatePairing {
    mean: Option<Half>,
    std: Option<Half>,
}

impl EstimatePairing {
    /// Takes a mean; the estimate once its std (same stamp) is in.
    pub fn mean(&mut self, half: Half, pdc_rise: f64) -> Option<WrenchEstimate> {
        self.mean = Some(half);
        self.paired(pdc_rise)
    }

    /// Takes a std; the estimate once its mean (same stamp) is in.
    pub fn std(&mut self, half: Half, pdc_rise: f64) -> Option<WrenchEstimate> {
        self.std = Some(half);
        self.paired(pdc_rise)
    }

    fn paired(&mut self, pdc_rise: f64) -> Option<WrenchEstimate> {
        let (Some((t_mean, _)), Some((t_std, _))) = (self.mean, self.std) else {
            return None;
        };
        if t_mean != t_std {
            return None;
        }
        let ((stamp_s, mean), (_, std)) = (self.mean.take()?, self.std.take()?);
        Some(WrenchEstimate {
            stamp_s,
            seq: 0,
            mean,
            std,
            estimated: [true; 6],
            pdc_rise,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;

    fn fz(v: f64) -> Wrench {
        Wrench::new(Vector3::new(0.0, 0.0, v), Vector3::zeros())
    }

    #[test]
    fn mean_and_std_pair_by_stamp_in_either_order_and_a_stale_half_is_replaced() {
        let mut p = EstimatePairing::default();
        assert_eq!(p.mean((1.00, fz(1.0)), 5.0), None);
        let e = p.std((1.00, fz(0.01)), 5.0).unwrap();
        assert_eq!(
            (e.stamp_s, e.mean, e.std, e.pdc_rise),
            (1.0, fz(1.0), fz(0.01), 5.0)
        );
        // The std first; a mean of another reading does not pair with it.
        assert_eq!(p.std((1.01, fz(0.02)), 0.0), None);
        assert_eq!(p.mean((1.02, fz(2.0)), 0.0), None);
        // The next std, of the mean's reading, pairs.
        let e = p.std((1.02, fz(0.03)), 0.0).unwrap();
        assert_eq!(
            (e.stamp_s, e.mean.force.z, e.std.force.z),
            (1.02, 2.0, 0.03)
        );
        // Each half is used once.
        assert_eq!(p.std((1.02, fz(0.03)), 0.0), None);
    }
}
