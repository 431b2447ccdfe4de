//! The `~/guarded_move` action server of `force_controller` (needs r2r's
//! generated types for tactile_force_msgs, so a real ROS build only).

use super::*;
use crate::nodes::guarded_goal::{guarded_outcome, GuardedGoal};
use r2r::tactile_force_msgs::action::GuardedMove;

pub(super) async fn serve(
    mut goals: impl futures::Stream<Item = r2r::ActionServerGoalRequest<GuardedMove::Action>> + Unpin,
    shared: Arc<Mutex<Shared>>,
    period: Duration,
) {
    while let Some(req) = goals.next().await {
        let d = &req.goal.direction;
        let goal = GuardedGoal {
            direction: [d.x, d.y, d.z],
            speed_mps: req.goal.speed_mps,
            target_force_n: req.goal.target_force_n,
            max_distance_m: req.goal.max_distance_m,
        };
        let started = {
            let mut g = lock(&shared);
            match g.robot.clone() {
                Some(robot) => goal.start(&g.base, robot).map_err(|e| e.to_string()),
                None => Err("no robot description yet".to_string()),
            }
            .map(|c| {
                g.controller = Some(c);
                g.task = TaskKind::Guarded;
                g.goal_active = true;
                g.last = None;
            })
        };
        let Ok((mut handle, mut cancel)) = req.accept() else {
            lock(&shared).goal_active = false;
            continue;
        };
        if let Err(e) = started {
            tracing::warn!("guarded_move goal refused: {e}");
            let _ = handle.abort(GuardedMove::Result {
                reason: format!("refused: {e}"),
                ..Default::default()
            });
            continue;
        }
        let mut ticker = tokio::time::interval(period);
        loop {
            ticker.tick().await;
            if let Some(Some(c)) = futures::FutureExt::now_or_never(cancel.next()) {
                if let Some(c) = lock(&shared).controller.as_mut() {
                    c.stop();
                }
                c.accept();
                let _ = handle.cancel(GuardedMove::Result {
                    reason: "canceled".into(),
                    ..Default::default()
                });
                break;
            }
            let (last, force) = {
                let g = lock(&shared);
                (g.last.clone(), g.force)
            };
            let Some(out) = last else { continue };
            // The estimated force on the controlled axis.
            let axis = out.targets.iter().position(Option::is_some).unwrap_or(2);
            let force_n = force[axis];
            let _ = handle.publish_feedback(GuardedMove::Feedback {
                force_n,
                phase: out.phase.name().into(),
            });
            // A halt (inputs missing or stale, e.g. right after the
            // goal rebuilt the controller) pauses the move; the goal
            // ends on the task's own outcome.
            if let Some(reason) = guarded_outcome(&out) {
                let result = GuardedMove::Result {
                    force_n,
                    reason: reason.into(),
                    ..Default::default()
                };
                let _ = if reason == "hold" {
                    handle.succeed(result)
                } else {
                    handle.abort(result)
                };
                break;
            }
        }
        lock(&shared).goal_active = false;
    }
}
