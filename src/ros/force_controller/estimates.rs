//! The estimate's two messages (mean and std), paired by stamp and handed
//! to the controller; while a calibration runs, the F/T wrench instead.

use r2r::geometry_msgs::msg::WrenchStamped;

use super::Shared;
use crate::ros::convert;

/// One of the two messages of an estimate, or the F/T sensor's wrench.
pub(super) enum EstimatePart {
    Mean(WrenchStamped),
    Std(WrenchStamped),
    Ft(WrenchStamped),
}

/// Stores `part`; once the mean and the std of one reading are both in,
/// hands the estimate to the controller and returns its reading's stamp
/// (time to step); None while waiting for the other half, and for an
/// estimate the controller refuses (no step: if none follows, the
/// late-estimate halt stops the arm).
pub(super) fn take_estimate(g: &mut Shared, part: EstimatePart) -> Option<f64> {
    match part {
        // While calibrating, the estimates wait; otherwise the F/T does.
        _ if g.calibration.is_some() != matches!(part, EstimatePart::Ft(_)) => return None,
        EstimatePart::Ft(m) => return take_ft(g, &m),
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

/// Hands the F/T wrench of a running calibration to the controller as its
/// force, recorded with the push running; its stamp (time to step), or None
/// for a wrench refused (not finite: no step, the late-input halt stops the arm).
fn take_ft(g: &mut Shared, m: &WrenchStamped) -> Option<f64> {
    let (stamp_s, w) = match convert::wrench_from_msg(m, "ft_sensor/wrench") {
        Ok(x) => x,
        Err(e) => {
            g.rejected += 1;
            tracing::debug!("{e}");
            return None;
        }
    };
    let w = g.ft_to_biotac.map_or(w, |t| t.apply(&w));
    let c = g.controller.as_mut()?;
    let e = g.calibration.as_mut()?.on_ft(stamp_s, w, c.push());
    g.force = w.force;
    c.on_estimate(e).ok().map(|()| stamp_s)
}
