//! The nail camera's loop: `camera/image` (sensor_msgs/Image) -> estimates.
//! Every frame is registered and normalised on its own
//! (crate::nail::preprocess); a frame without its four markers is dropped
//! and counted. The first frames (the model's tare, 30 by default: the
//! finger out of contact) make the baseline, as the BioTac's readings do.
//! An image over the camera's size (the model's frames, in the widest
//! encoding read: [`image_max_bytes`]) is refused before it is decoded,
//! and counted.

use futures::StreamExt;
use r2r::sensor_msgs::msg::Image;
use r2r::QosProfile;

use super::{Outputs, Settings, REPORT};
use crate::learn::models::wrench_model::WrenchModel;
use crate::nodes::bounds::image_max_bytes;
use crate::nodes::EstimatorNode;
use crate::ros::inputs::Inputs;
use crate::ros::params::RuntimeParams;
use crate::ros::{bounded, convert, RosError};
use crate::sensor::nail::NailInput;

/// Runs the nail-camera estimator until the process ends.
pub(super) async fn run(
    mut node: r2r::Node,
    model: Box<dyn WrenchModel>,
    s: Settings,
    mut out: Outputs,
) -> Result<(), RosError> {
    let mut estimator = EstimatorNode::<NailInput>::new(model, s.with_std)
        .and_then(|e| e.with_stale_timeout(s.stale_s))?
        .with_ready_after(s.ready_after_s);
    let guard = estimator.guard().clone();
    let (width, height) = estimator.sensor().frame_size();
    let (qos, max) = (QosProfile::sensor_data(), image_max_bytes(width, height));
    let image_type = "sensor_msgs/msg/Image";
    let images = bounded::typed::<Image>(
        &mut node,
        "camera/image",
        image_type,
        qos.clone(),
        max,
        &guard,
    )?;
    let inputs = Inputs::new(&[("camera/image", &qos)], s.silent_after_s);
    let mut images = inputs.watched("camera/image", images);
    let clock = crate::ros::serve_parameters(&mut node, RuntimeParams::none(&guard))?;
    let spinning = crate::ros::spin(node);
    let graph = spinning.graph();

    let mut report = tokio::time::interval(REPORT);
    let mut seq = 0u16;
    loop {
        let msg = tokio::select! {
            m = images.next() => match m {
                Some(m) => m,
                None => return Ok(()),
            },
            _ = report.tick() => {
                let status = out.status(&estimator);
                out.report(status, &clock, (&inputs, &graph)).await;
                continue;
            }
        };
        seq = seq.wrapping_add(1);
        match convert::nail_frame(&msg, seq) {
            Ok(frame) => {
                let was_tared = estimator.is_tared();
                if let Some(e) = estimator.on_received(&frame, clock.now_s()) {
                    out.publish(&e, clock.now_s());
                }
                if !was_tared && estimator.is_tared() {
                    tracing::info!("tared on {} frames", estimator.tare_samples());
                }
            }
            Err(e) => {
                estimator.count_unusable(false);
                tracing::debug!("camera/image: {e}");
            }
        }
    }
}
