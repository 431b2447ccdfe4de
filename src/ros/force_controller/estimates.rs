//! The estimate's two messages (mean and std), paired by stamp and handed
//! to the controller.

use r2r::geometry_msgs::msg::WrenchStamped;

use super::Shared;
use crate::ros::convert;

/// One of the two messages of an estimate.
pub(super) enum EstimatePart {
    Mean(WrenchStamped),
    Std(WrenchStamped),
}

/// Stores `part`; once the mean and the std of one reading are both in,
/// hands the estimate to the controller and returns its reading's stamp
/// (time to step); None while waiting for the other half, and for an
/// estimate the controller refuses (no step: if none follows, the
/// late-estimate halt stops the arm).
pub(super) fn take_estimate(g: &mut Shared, part: EstimatePart) -> Option<f64> {
    match part {
        EstimatePart::Mean(m) => g.mean = Some(m),
        EstimatePart::Std(m) => g.stddev = Some(m),
    }
    let paired =
        matches!((&g.mean, &g.stddev), (Some(m), Some(s)) if m.header.stamp == s.header.stamp);
    if !paired {
        return None;
    }
    let (mean, std) = (g.mean.take()?, g.stddev.take()?);
    let stamp_s = convert::time_s(&mean.header.stamp);
    let ok = convert::estimate_from_msgs(&mean, Some(&std), g.pdc.as_ref())
        .map_err(|e| e.to_string())
        .and_then(|e| {
            g.force = e.mean.force;
            match g.controller.as_mut() {
                Some(c) => c.on_estimate(e).map_err(|e| e.to_string()),
                None => Err("no robot description yet".into()),
            }
        });
    match ok {
        Ok(()) => Some(stamp_s),
        Err(e) => {
            g.rejected += 1;
            tracing::debug!("biotac/wrench refused: {e}");
            None
        }
    }
}
