//! A guarded-move goal (the `force_controller/guarded_move` action of the
//! ROS 2 node, tactile_force_msgs/action/GuardedMove): the start-up
//! parameters with the goal's fields applied, checked like any scene (the
//! safety envelope included), and how the move ended, for the result.

use crate::control::{ControlOutput, ControllerParams, Goal, GuardedParams, Phase, TaskSection};
use crate::params::ParamsError;

/// A guarded-move goal; zero fields keep the parameter's value.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct GuardedGoal {
    /// Approach direction, BioTac frame (zero vector: keep).
    pub direction: [f64; 3],
    /// Approach speed (m/s).
    pub speed_mps: f64,
    /// Force to hold (N).
    pub target_force_n: f64,
    /// Approach distance before a timeout (m).
    pub max_distance_m: f64,
}

impl Goal for GuardedGoal {
    /// The node's parameters (the start-up ones with the live sets since)
    /// with this goal applied (task = guarded).
    fn apply(&self, base: &ControllerParams) -> Result<ControllerParams, ParamsError> {
        let mut p = base.clone();
        p.task = GuardedParams::NAME.into();
        let mut g: GuardedParams = p.section()?;
        if self.direction != [0.0; 3] {
            g.direction = self.direction;
        }
        let set = |slot: &mut f64, v: f64| {
            if v != 0.0 {
                *slot = v;
            }
        };
        set(&mut g.approach_speed_mps, self.speed_mps);
        set(&mut g.target_force_n, self.target_force_n);
        set(&mut g.max_distance_m, self.max_distance_m);
        p.set_section(&g);
        Ok(p)
    }
}

/// How a guarded move ended, for the action result; None while it runs.
pub fn guarded_outcome(out: &ControlOutput) -> Option<&'static str> {
    match (out.phase, out.reason) {
        (Phase::HOLD, _) => Some("hold"),
        (Phase::STOPPED, Some(reason)) => Some(reason.name()),
        (Phase::STOPPED, None) => Some("stopped"),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::control::{ForceController, TaskKind};
    use crate::kinematics::Robot;
    use crate::nodes::tasks::shipped;
    use crate::runtime::scene::Scene;

    fn goal(speed_mps: f64) -> GuardedGoal {
        GuardedGoal {
            direction: [0.0; 3],
            speed_mps,
            target_force_n: 0.0,
            max_distance_m: 0.0,
        }
    }

    #[test]
    fn a_goal_overrides_only_what_it_sets_and_is_checked() {
        let base = Scene::builtin(TaskKind::Guided).unwrap().controller;
        // The guided scene has no guarded section: refused, named.
        assert!(goal(0.02).apply(&base).is_err());
        let base = Scene::builtin(TaskKind::Guarded).unwrap().controller;
        let p = goal(0.02).apply(&base).unwrap();
        let (g, b) = (
            p.section::<GuardedParams>().unwrap(),
            base.section::<GuardedParams>().unwrap(),
        );
        assert_eq!(g.approach_speed_mps, 0.02);
        assert_eq!(g.target_force_n, b.target_force_n);
        assert_eq!(g.direction, b.direction);
        ForceController::for_goal(&goal(0.02), &base, Robot::pa10(), &shipped()).unwrap();
        assert!(
            ForceController::for_goal(&goal(f64::NAN), &base, Robot::pa10(), &shipped()).is_err()
        );
    }

    #[test]
    fn a_goal_beyond_the_safety_envelope_is_refused_with_the_limit() {
        let base = Scene::builtin(TaskKind::Guarded).unwrap().controller;
        for speed in [0.2, 5.0] {
            let e = ForceController::for_goal(&goal(speed), &base, Robot::pa10(), &shipped())
                .unwrap_err()
                .to_string();
            assert!(
                e.contains("approach_speed_mps") && e.contains("at most 0.0238 m/s"),
                "{e}"
            );
        }
        let over = GuardedGoal {
            target_force_n: 4.0,
            ..goal(0.01)
        };
        let e = ForceController::for_goal(&over, &base, Robot::pa10(), &shipped())
            .unwrap_err()
            .to_string();
        assert!(e.contains("force_limit_n"), "a target past the limit: {e}");
    }

    #[test]
    fn the_outcome_is_known_only_when_the_move_holds_or_stops() {
        let base = Scene::builtin(TaskKind::Guarded).unwrap().controller;
        let mut c =
            ForceController::for_goal(&goal(0.0), &base, Robot::pa10(), &shipped()).unwrap();
        let out = c.tick(0.0);
        assert!(out.halt.is_some(), "no input yet: the watchdog halts");
        assert_eq!(guarded_outcome(&out), None);
    }
}
