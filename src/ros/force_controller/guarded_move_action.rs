//! The `~/guarded_move` action server of `force_controller` (needs r2r's
//! generated types for tactile_force_msgs, so a real ROS build only): the
//! goal's life cycle is the node's ([`ForceControllerNode`]); this moves
//! its messages. A canceled goal ends once the pad has withdrawn out of
//! contact ([`ForceControllerNode::withdrawn`]). Goal requests beyond the
//! node's rate were rejected before they came here
//! ([`crate::ros::bounded::goals`]).

use futures::StreamExt;

use crate::ros::action_server::{CancelRequest, GoalHandle, GoalRequest};

use super::cancel::{CancelWatch, Canceling};
use super::*;
use crate::nodes::guarded_goal::GuardedGoal;
use crate::ros::RosClock;
use r2r::tactile_force_msgs::action::GuardedMove;

/// The result of a goal refused for `reason`.
pub(super) fn refused(reason: String) -> GuardedMove::Result {
    GuardedMove::Result {
        reason,
        ..Default::default()
    }
}

/// Serves the goals: each is started, or refused with the reason, as it
/// comes, and then followed on a task of its own, so that a goal that
/// comes while one runs is refused at once.
pub(super) async fn serve(
    mut goals: impl futures::Stream<Item = GoalRequest<GuardedMove::Action>> + Unpin,
    shared: Arc<Mutex<ForceControllerNode>>,
    period: Duration,
    clock: RosClock,
) {
    while let Some(req) = goals.next().await {
        let d = &req.goal.direction;
        let goal = GuardedGoal {
            direction: [d.x, d.y, d.z],
            speed_mps: req.goal.speed_mps,
            target_force_n: req.goal.target_force_n,
            max_distance_m: req.goal.max_distance_m,
        };
        let started = lock(&shared).start_guarded(&goal);
        let Ok((mut handle, cancel)) = req.accept() else {
            if started.is_ok() {
                lock(&shared).end_goal();
            }
            continue;
        };
        if let Err(e) = started {
            tracing::warn!("guarded_move goal refused: {e}");
            handle.abort(refused(format!("refused: {e}")));
            continue;
        }
        let cancel = CancelWatch::new(cancel);
        tokio::spawn(follow(
            handle,
            cancel,
            shared.clone(),
            period,
            clock.clone(),
        ));
    }
}

/// Follows a started goal each period until it ends: its feedback, then
/// its result; a cancel once the pad has withdrawn.
async fn follow(
    mut handle: GoalHandle<GuardedMove::Action>,
    mut cancel: CancelWatch<impl futures::Stream<Item = CancelRequest> + Unpin>,
    shared: Arc<Mutex<ForceControllerNode>>,
    period: Duration,
    clock: RosClock,
) {
    let mut ticker = tokio::time::interval(period);
    loop {
        ticker.tick().await;
        let progress = {
            let mut n = lock(&shared);
            // Stopped from outside the task (a signal, ~/stop, deactivate),
            // or its estimate came in the wrong frame.
            if let Some(reason) = n.goal_end() {
                tracing::warn!("guarded_move goal aborted: {reason}");
                handle.abort(GuardedMove::Result {
                    reason: reason.into(),
                    force_n: n.guarded_progress().map_or(0.0, |p| p.force_n),
                    ..Default::default()
                });
                break;
            }
            match cancel.poll(&mut n, clock.now_s()) {
                Canceling::No => n.guarded_progress(),
                Canceling::Withdrawing => continue,
                Canceling::Done(reason) => {
                    let force_n = n.guarded_progress().map_or(0.0, |p| p.force_n);
                    handle.cancel(GuardedMove::Result {
                        reason,
                        force_n,
                        ..Default::default()
                    });
                    break;
                }
            }
        };
        // A halt (inputs missing or stale, e.g. right after the goal
        // rebuilt the controller) pauses the move; the goal ends on the
        // task's own outcome.
        let Some(p) = progress else {
            continue;
        };
        let _ = handle.publish_feedback(GuardedMove::Feedback {
            force_n: p.force_n,
            phase: p.phase.name().into(),
        });
        if let Some(reason) = p.outcome {
            let result = GuardedMove::Result {
                force_n: p.force_n,
                reason: reason.into(),
                settled_sd_n: p.settled_sd_n.unwrap_or(0.0),
                stiffness_n_per_m: p.stiffness_n_per_m.unwrap_or(0.0),
                loop_delay_s: p.loop_delay_s,
                gain_m_per_s_per_n: p.gain_m_per_s_per_n.unwrap_or(0.0),
                ..Default::default()
            };
            if reason == "hold" {
                handle.succeed(result);
            } else {
                handle.abort(result);
            }
            break;
        }
    }
    lock(&shared).end_goal();
}
