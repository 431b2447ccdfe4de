//! A goal's cancel as both action servers take it (the server accepted
//! it): the pad withdraws out of contact
//! ([`ForceControllerNode::cancel_goal`]); the goal ends canceled once it
//! has ([`ForceControllerNode::withdrawn`]), so the next goal starts clean.

use futures::StreamExt;

use crate::nodes::force_controller::ForceControllerNode;
use crate::ros::action_server::CancelRequest;

/// Where a goal's cancel is.
pub(super) enum Canceling {
    /// Not asked.
    No,
    /// Asked: the pad withdraws.
    Withdrawing,
    /// The goal may end canceled, with this reason.
    Done(String),
}

/// The cancel requests of one goal.
pub(super) struct CancelWatch<S> {
    requests: S,
    asked: bool,
}

impl<S: futures::Stream<Item = CancelRequest> + Unpin> CancelWatch<S> {
    pub(super) fn new(requests: S) -> Self {
        CancelWatch {
            requests,
            asked: false,
        }
    }

    /// Looks, each period at `now` under the node's lock, for a request
    /// and how the withdrawal goes.
    pub(super) fn poll(&mut self, n: &mut ForceControllerNode, now: f64) -> Canceling {
        if !self.asked {
            let Some(Some(CancelRequest)) = futures::FutureExt::now_or_never(self.requests.next())
            else {
                return Canceling::No;
            };
            n.cancel_goal(now);
            self.asked = true;
        }
        match n.withdrawn(now) {
            None => Canceling::Withdrawing,
            Some(Ok(())) => Canceling::Done("canceled".into()),
            Some(Err(why)) => Canceling::Done(format!("canceled; {why}")),
        }
    }
}
