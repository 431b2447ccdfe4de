//! The BioTac frame on `/tf_static` (tf2_msgs/TFMessage; reliable,
//! transient local and depth 1, as tf2's static broadcaster, so that a
//! listener started later still gets it): the transform the node decides
//! ([`ForceControllerNode::tool_frame`]), sent for each robot description
//! it takes and on each configure, unless it is the one sent last (a
//! listener subscribed early would hear it twice).

use std::sync::{Arc, Mutex};

use r2r::tf2_msgs::msg::TFMessage;
use r2r::QosProfile;

use crate::nodes::force_controller::tool_frame::StaticTransform;
use crate::nodes::force_controller::ForceControllerNode;
use crate::ros::{convert, RosClock, RosError};

/// The `/tf_static` publisher, the BioTac frame's name and the transform
/// sent last.
#[derive(Clone)]
pub(super) struct ToolFrame {
    tf: r2r::Publisher<TFMessage>,
    child: String,
    clock: RosClock,
    sent: Arc<Mutex<Option<StaticTransform>>>,
}

impl ToolFrame {
    /// The publisher of the frame `child` (the checked `biotac_frame`).
    pub(super) fn new(
        node: &mut r2r::Node,
        child: String,
        clock: RosClock,
    ) -> Result<Self, RosError> {
        let qos = QosProfile::default()
            .keep_last(1)
            .reliable()
            .transient_local();
        let tf = node.create_publisher("/tf_static", qos)?;
        Ok(ToolFrame {
            tf,
            child,
            clock,
            sent: Arc::default(),
        })
    }

    /// Publishes the BioTac frame on the tip of the arm `n` commands (none
    /// before a description, nor again the one sent last); a frame the
    /// node refuses is said, not sent.
    pub(super) fn publish(&self, n: &ForceControllerNode) {
        let mut last = self.sent.lock().unwrap_or_else(|e| e.into_inner());
        let sent = match n.tool_frame(&self.child) {
            Ok(Some(t)) if last.as_ref() == Some(&t) => Ok(()),
            Ok(Some(t)) => {
                tracing::info!("{} on /tf_static, in {}", t.child, t.parent);
                let sent = self.tf.publish(&convert::tf_msg(self.clock.now_s(), &t));
                *last = sent.is_ok().then_some(t);
                sent
            }
            Ok(None) => Ok(()),
            Err(e) => {
                tracing::warn!("the BioTac frame is not published: {e}");
                Ok(())
            }
        };
        if let Err(e) = sent {
            tracing::warn!("/tf_static: {e}");
        }
    }
}
