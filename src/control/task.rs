//! The task seam: every task the force controller can run is named here
//! once. Its name in the parameters and its shipped scene file
//! ([`TaskKind`]), its checked section ([`TaskParams`]), its gains from the
//! contact law and the safety envelope of its motion, and how it steps
//! ([`Task`]). The tasks themselves live in their own modules
//! ([`super::guarded`], [`super::guided`], [`super::calibrate`]). A task adds its module,
//! a variant to each enum here, its section to
//! [`crate::nodes::ControllerParams`] and its scene file.

use nalgebra::{Isometry3, Vector3};
use serde::Deserialize;

use super::calibrate::{CalibrateMove, CalibrateParams, PressLoop};
use super::guarded::GuardedInput;
use super::{
    Envelope, GuardedMove, GuardedParams, GuidedMove, GuidedParams, LoopDelays, PdParams, Phase,
    StopReason,
};
use crate::contact::{series_stiffness, shear_stiffness, BodyParams, SkinParams};
use crate::kinematics::ShippedRobot;
use crate::kinematics::Twist;
use crate::params::{
    Check, Checked, ParamsError, CALIBRATE_YAML, GUARDED_YAML, GUIDED_YAML, WORLD_YAML,
};
use crate::wrench::{Axis, AxisSet};

/// Which task the controller runs (the parameter `task`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TaskKind {
    /// Approach, touch, hold a force.
    Guarded,
    /// Follow a person's finger.
    Guided,
    /// Press a calibration block in a pattern, the F/T sensor as the force.
    Calibrate,
}

impl TaskKind {
    /// Every task.
    pub const ALL: [TaskKind; 3] = [TaskKind::Guarded, TaskKind::Guided, TaskKind::Calibrate];

    /// The name in the parameters, the JSON output and the command line.
    pub fn name(self) -> &'static str {
        match self {
            TaskKind::Guarded => "guarded",
            TaskKind::Guided => "guided",
            TaskKind::Calibrate => "calibrate",
        }
    }

    /// The shipped scene file of the task (`config/guarded_move.yaml`,
    /// `guided_move.yaml`, `calibrate.yaml`).
    pub fn scene_yaml(self) -> &'static str {
        match self {
            TaskKind::Guarded => GUARDED_YAML,
            TaskKind::Guided => GUIDED_YAML,
            TaskKind::Calibrate => CALIBRATE_YAML,
        }
    }

    /// The shipped parameter files of a run of the task on `robot`, in
    /// order: the world, the robot, the task's scene.
    pub fn shipped_layers(self, robot: ShippedRobot) -> [&'static str; 3] {
        [WORLD_YAML, robot.yaml(), self.scene_yaml()]
    }

    /// The names of every task, for messages ("guarded, guided or calibrate").
    pub fn names() -> String {
        let names: Vec<&str> = Self::ALL.iter().map(|t| t.name()).collect();
        match names.split_last() {
            Some((last, rest)) if !rest.is_empty() => format!("{} or {last}", rest.join(", ")),
            _ => names.join(""),
        }
    }
}

impl std::fmt::Display for TaskKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for TaskKind {
    type Err = ParamsError;

    fn from_str(s: &str) -> Result<Self, ParamsError> {
        Self::ALL
            .into_iter()
            .find(|t| t.name() == s)
            .ok_or_else(|| ParamsError::Invalid {
                key: "task".into(),
                value: s.into(),
                expected: Self::names(),
            })
    }
}

/// The checked section of the task that runs.
#[derive(Debug, Clone, PartialEq)]
pub enum TaskParams {
    /// `guarded`.
    Guarded(Checked<GuardedParams>),
    /// `guided`.
    Guided(Checked<GuidedParams>),
    /// `calibrate`.
    Calibrate(Checked<CalibrateParams>),
}

impl TaskParams {
    /// The section of `kind` among the scene's sections, checked.
    pub fn select(
        kind: TaskKind,
        guarded: Option<GuardedParams>,
        guided: Option<GuidedParams>,
        calibrate: Option<CalibrateParams>,
    ) -> Result<Self, ParamsError> {
        let key = kind.name();
        let absent = || ParamsError::Invalid {
            key: key.into(),
            value: "absent".into(),
            expected: format!("a `{key}` section for the task {key}"),
        };
        Ok(match kind {
            TaskKind::Guarded => TaskParams::Guarded(guarded.ok_or_else(absent)?.checked(key)?),
            TaskKind::Guided => TaskParams::Guided(guided.ok_or_else(absent)?.checked(key)?),
            TaskKind::Calibrate => {
                TaskParams::Calibrate(calibrate.ok_or_else(absent)?.checked(key)?)
            }
        })
    }

    /// The envelope of the task's motion towards `body` (named `name`) in
    /// `lp`: the guarded move's approach, or the guided move's controlled
    /// axis that allows the slowest motion.
    pub fn envelope(
        &self,
        lp: &TaskLoop,
        body: &BodyParams,
        name: &str,
    ) -> Result<TaskEnvelope, ParamsError> {
        let reaction_s = lp.period_s + lp.delays.total_s();
        let (envelope, key, speed_mps) = match self {
            TaskParams::Guarded(g) => {
                let envelope = Envelope {
                    skin: **lp.skin,
                    stiffness_n_per_m: body.stiffness_n_per_m,
                    shear: false,
                    trigger_n: g.contact_force_n,
                    target_n: g.target_force_n,
                    limit_n: g.force_limit_n,
                    reaction_s,
                };
                (envelope, "guarded.approach_speed_mps", g.approach_speed_mps)
            }
            TaskParams::Guided(g) => {
                let envelope = guided_envelope(lp, g, body, reaction_s)
                    .ok_or_else(|| missing_axis(lp.axes, Axis::Fz))?;
                (envelope, "pd.max_speed_mps", lp.pd.max_speed_mps)
            }
            TaskParams::Calibrate(c) => {
                let top = c
                    .ladder_n
                    .iter()
                    .chain(&c.shear_force_n)
                    .copied()
                    .fold(0.0, f64::max);
                let envelope = Envelope {
                    skin: **lp.skin,
                    stiffness_n_per_m: body.stiffness_n_per_m,
                    shear: false,
                    trigger_n: c.contact_force_n,
                    target_n: top,
                    limit_n: c.force_limit_n,
                    reaction_s,
                };
                (
                    envelope,
                    "calibrate.approach_speed_mps",
                    c.approach_speed_mps,
                )
            }
        };
        Ok(TaskEnvelope {
            envelope,
            body: name.into(),
            key,
            speed_mps,
        })
    }

    /// The task, its gains set for a contact with `body` in `lp`.
    pub fn build(self, lp: &TaskLoop, body: &BodyParams) -> Task {
        match self {
            TaskParams::Calibrate(c) => Task::Calibrate(Box::new(CalibrateMove::new(
                c,
                PressLoop {
                    skin: *lp.skin,
                    body: *body,
                    pd: *lp.pd,
                    delays: *lp.delays,
                    period_s: lp.period_s,
                },
            ))),
            TaskParams::Guarded(g) => {
                let k = series_stiffness(lp.skin, body, g.target_force_n);
                Task::Guarded(GuardedMove::new(g, lp.pd, k, lp.period_s, lp.delays))
            }
            TaskParams::Guided(g) => {
                let normal = series_stiffness(lp.skin, body, g.target_force_n[2]);
                let shear = shear_stiffness(lp.skin, body);
                let k = [shear, shear, normal];
                let forces = lp.forces();
                let k = std::array::from_fn(|i| forces[i].then_some(k[i]));
                Task::Guided(GuidedMove::new(g, lp.pd, k, lp.period_s, lp.delays))
            }
        }
    }
}

/// The loop a task runs in: what its gains and envelope are computed from
/// besides its own section.
#[derive(Debug, Clone, Copy)]
pub struct TaskLoop<'a> {
    /// The BioTac skin law.
    pub skin: &'a Checked<SkinParams>,
    /// The PD law.
    pub pd: &'a Checked<PdParams>,
    /// The loop's delays.
    pub delays: &'a Checked<LoopDelays>,
    /// The control period (s).
    pub period_s: f64,
    /// The wrench axes the controller controls.
    pub axes: &'a AxisSet,
}

impl TaskLoop<'_> {
    /// Which of the x, y, z forces the controller controls.
    fn forces(&self) -> [bool; 3] {
        [Axis::Fx, Axis::Fy, Axis::Fz].map(|a| self.axes.axes().contains(&a))
    }
}

/// The error for an axis set that lacks `axis`, which the task reads.
pub fn missing_axis(axes: &AxisSet, axis: Axis) -> ParamsError {
    ParamsError::Invalid {
        key: "axes".into(),
        value: axes.to_string(),
        expected: format!("a set including {axis}, which the task reads"),
    }
}

/// The guided move's envelope: the controlled axis that allows the slowest
/// motion towards `body` (None when no force axis is controlled). On each
/// axis the PD stops advancing past the target plus the deadband, and the
/// axis may take what the force limit leaves beside the other axes' targets.
fn guided_envelope(
    lp: &TaskLoop,
    g: &GuidedParams,
    body: &BodyParams,
    reaction_s: f64,
) -> Option<Envelope> {
    let forces = lp.forces();
    let t = g.target_force_n;
    let total: f64 = t.iter().map(|v| v * v).sum();
    (0..3)
        .filter(|&i| forces[i])
        .map(|i| Envelope {
            skin: **lp.skin,
            stiffness_n_per_m: if i == 2 {
                body.stiffness_n_per_m
            } else {
                shear_stiffness(lp.skin, body)
            },
            shear: i != 2,
            trigger_n: t[i].abs() + g.deadband_n,
            target_n: t[i].abs(),
            limit_n: (g.force_limit_n.powi(2) - (total - t[i] * t[i])).sqrt(),
            reaction_s,
        })
        .min_by(|a, b| a.max_speed_mps().total_cmp(&b.max_speed_mps()))
}

/// A task's speed towards its bodies and the envelope it must stay in.
#[derive(Debug, Clone, PartialEq)]
pub struct TaskEnvelope {
    /// The envelope against the stiffest body the scene permits.
    pub envelope: Envelope,
    /// That body's name.
    pub body: String,
    /// The parameter that sets the speed.
    pub key: &'static str,
    /// The speed (m/s): the guarded move's approach, the guided move's
    /// largest commanded speed.
    pub speed_mps: f64,
}

impl TaskEnvelope {
    /// Refuses a speed above the envelope's limit, naming it.
    pub fn check(&self) -> Result<(), ParamsError> {
        self.envelope.check(self.key, self.speed_mps, &self.body)
    }
}

/// What a task sees each cycle.
#[derive(Debug, Clone, Copy)]
pub struct TaskInput<'a> {
    /// Estimated force on the BioTac, BioTac frame (N).
    pub force: &'a Vector3<f64>,
    /// PDC rise above its tare (counts).
    pub pdc_rise: f64,
    /// The BioTac's pose now, base frame.
    pub pose: &'a Isometry3<f64>,
    /// The BioTac's pose at the start of the run, base frame.
    pub start: &'a Isometry3<f64>,
    /// True when the input is outside what the estimator knows.
    pub out_of_range: bool,
    /// Time since the previous cycle (s).
    pub dt: f64,
}

/// The running task.
#[derive(Debug, Clone, PartialEq)]
pub enum Task {
    /// The guarded move.
    Guarded(GuardedMove),
    /// The guided move.
    Guided(GuidedMove),
    /// The calibration.
    Calibrate(Box<CalibrateMove>),
}

/// A twist with a linear velocity only (the orientation held).
fn translation(v: Vector3<f64>) -> Twist {
    Twist::new(v.x, v.y, v.z, 0.0, 0.0, 0.0)
}

impl Task {
    /// One cycle: the BioTac's twist (m/s, rad/s, base frame); the guarded
    /// and guided moves hold the orientation.
    pub fn step(&mut self, i: &TaskInput) -> Twist {
        match self {
            Task::Calibrate(c) => c.step(i),
            Task::Guarded(g) => {
                let d_tool = g.direction();
                let d_world = i.start.rotation * d_tool;
                let input = GuardedInput {
                    force_n: -d_tool.dot(i.force),
                    pdc_rise: i.pdc_rise,
                    travelled_m: (i.pose.translation.vector - i.start.translation.vector)
                        .dot(&d_world),
                    out_of_range: i.out_of_range,
                    dt: i.dt,
                };
                translation(d_world * g.step(&input))
            }
            Task::Guided(g) => translation(i.pose.rotation * g.step(i.force, i.out_of_range, i.dt)),
        }
    }

    /// The calibration's push running (0-based) and the set its rows are
    /// labelled with; None for the other tasks.
    pub fn push(&self) -> Option<(usize, u32)> {
        match self {
            Task::Calibrate(c) => c.current().map(|(i, p)| (i, p.kind.set())),
            _ => None,
        }
    }

    /// The calibration's number of pushes; None for another task.
    pub fn pushes(&self) -> Option<usize> {
        match self {
            Task::Calibrate(c) => Some(c.pushes().len()),
            _ => None,
        }
    }

    /// Proportional gain of each force axis x, y, z (m/s per N), None where
    /// not controlled. For the guarded move, the gain along its direction is
    /// reported on the axis it mostly points along.
    pub fn gains(&self) -> [Option<f64>; 3] {
        match self {
            Task::Guarded(g) => {
                let d = g.direction();
                let mut out = [None; 3];
                out[d.iamax()] = Some(g.pd().gain());
                out
            }
            Task::Guided(g) => g.gains(),
            Task::Calibrate(c) => [None, None, c.gain()],
        }
    }

    /// Desired force along x, y, z of the BioTac frame on the controlled
    /// axes (N).
    pub fn targets(&self) -> [Option<f64>; 3] {
        match self {
            Task::Guarded(g) => {
                let d = g.direction();
                let mut t = [None; 3];
                t[d.iamax()] = Some(g.target_force_n() * -d[d.iamax()]);
                t
            }
            Task::Guided(g) => g.targets(),
            Task::Calibrate(c) => [None, None, c.target_n()],
        }
    }

    /// The directions the task moves the BioTac along (BioTac frame), each
    /// with its name for messages: the guarded move's approach, the guided
    /// move's controlled axes, the calibration's press and slides.
    pub fn directions(&self) -> Vec<(String, Vector3<f64>)> {
        match self {
            Task::Calibrate(_) => vec![
                ("-z of the BioTac frame (its presses)".into(), -Vector3::z()),
                ("x of the BioTac frame (its slides)".into(), Vector3::x()),
                ("y of the BioTac frame (its slides)".into(), Vector3::y()),
            ],
            Task::Guarded(g) => {
                let d = g.direction();
                let name = format!("the approach direction [{}, {}, {}]", d.x, d.y, d.z);
                vec![(name, d)]
            }
            Task::Guided(g) => ["x", "y", "z"]
                .iter()
                .zip(g.targets())
                .enumerate()
                .filter(|(_, (_, t))| t.is_some())
                .map(|(i, (name, _))| (format!("{name} of the BioTac frame"), Vector3::ith(i, 1.0)))
                .collect(),
        }
    }

    /// The force axes the task reads.
    pub fn force_axes(&self) -> Vec<Axis> {
        let forces = [Axis::Fx, Axis::Fy, Axis::Fz];
        match self {
            Task::Guarded(g) => {
                let d = g.direction();
                forces.into_iter().filter(|a| d[a.index()] != 0.0).collect()
            }
            Task::Guided(g) => forces
                .into_iter()
                .zip(g.targets())
                .filter_map(|(a, t)| t.map(|_| a))
                .collect(),
            Task::Calibrate(_) => vec![Axis::Fz],
        }
    }

    /// Where the task is.
    pub fn phase(&self) -> Phase {
        match self {
            Task::Guarded(g) => g.phase(),
            Task::Guided(g) => g.phase(),
            Task::Calibrate(c) => c.phase(),
        }
    }

    /// Why the task stopped, if it stopped on its own.
    pub fn reason(&self) -> Option<StopReason> {
        match self {
            Task::Guarded(g) => g.reason(),
            Task::Guided(g) => g.reason(),
            Task::Calibrate(c) => c.reason(),
        }
    }

    /// Forgets the force history after a pause in the estimates.
    pub fn pause(&mut self) {
        match self {
            Task::Guarded(g) => g.pause(),
            Task::Guided(g) => g.pause(),
            Task::Calibrate(c) => c.pause(),
        }
    }

    /// Stops where it is: no motion any more.
    pub fn stop(&mut self) {
        match self {
            Task::Guarded(g) => g.stop(),
            Task::Guided(g) => g.stop(),
            Task::Calibrate(c) => c.stop(),
        }
    }

    /// Stops for good with `reason`.
    pub fn stop_on(&mut self, reason: StopReason) {
        match self {
            Task::Guarded(g) => g.stop_on(reason),
            Task::Guided(g) => g.stop_on(reason),
            Task::Calibrate(c) => c.stop_on(Some(reason)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn task_names_parse_back_and_others_are_refused_with_the_list() {
        for t in TaskKind::ALL {
            assert_eq!(t.name().parse::<TaskKind>().unwrap(), t);
            assert!(!t.scene_yaml().is_empty());
        }
        let e = "joystick".parse::<TaskKind>().unwrap_err().to_string();
        assert!(e.contains("guarded, guided or calibrate"), "{e}");
    }

    #[test]
    fn an_absent_section_is_named() {
        let e = TaskParams::select(TaskKind::Guided, None, None, None).unwrap_err();
        assert!(e.to_string().contains("`guided` section"), "{e}");
    }
}
