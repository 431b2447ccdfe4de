//! Cost of one control period of the closed loop (`runtime::run`), and of its
//! parts, against the 10 ms control period:
//!
//! - `estimator`: `EstimatorNode::on_reading` on an in-contact reading (the
//!   guarded move holding 1 N), after the tare, with the scenes' default
//!   models (guarded: fz; guided: fx, fy, fz) and, for comparison, the
//!   guarded recipe on all six axes, with and without the standard deviation;
//! - `tick`: `ForceController::tick` alone (watchdog, task, forward
//!   kinematics, Jacobian, damped least squares), repeated at the time of a
//!   tick that commanded motion: the guarded move holding, the guided move
//!   following a push;
//! - `period`: sample, estimate, tick, command and one period of physics
//!   (10 steps), stepping the shipped scenes on from that tick (and back to
//!   it when a run reaches the scene's duration); the guarded scene also with
//!   the six-axis model.
//!
//! After the criterion groups, a plain loop per item prints its median and
//! p99 and their share of the control period, which criterion does not report.
//! Setup trains the three models once each and prints their fit times.
//!
//! Run with `cargo bench --bench control`.

use std::hint::black_box;
use std::time::{Duration, Instant};

use criterion::{criterion_group, criterion_main, Criterion};
use nalgebra::Vector3;
use tactile_force::biotac::sim::BioTacSimConfig;
use tactile_force::biotac::BioTacReading;
use tactile_force::control::{ControlOutput, ForceController, Phase, TaskKind};
use tactile_force::kinematics::ShippedRobot;
use tactile_force::learn::default_model::{self, Recipe};
use tactile_force::learn::models::wrench_gp::WrenchGp;
use tactile_force::nodes::{EstimatorNode, SimRobot, SimSample};
use tactile_force::runtime::{Nodes, Scene};
use tactile_force::wrench::{Axis, AxisSet};

/// Noise seed of the simulated runs.
const SEED: u64 = 1;
/// Calls per item in the plain latency loop.
const LATENCY_CALLS: usize = 2000;

/// A shipped scene run up to a period that commanded motion in the state
/// to measure.
struct Run {
    /// Name of the state, for the benchmark ids.
    name: &'static str,
    nodes: Nodes,
    /// Time of that period's tick (s).
    t: f64,
    /// The BioTac readings up to that period: the tare first, in contact last.
    readings: Vec<BioTacReading>,
    /// Simulator and controller after that period, to restart from.
    restart: (SimRobot, ForceController),
}

impl Run {
    /// Runs `task`'s scene with `model` until `ready` holds for a period
    /// whose command moves the arm.
    fn new(
        name: &'static str,
        scene: Scene,
        model: WrenchGp,
        ready: fn(&SimSample, &ControlOutput) -> bool,
    ) -> Self {
        let mut nodes = scene
            .build(Box::new(model), &BioTacSimConfig::default(), SEED)
            .expect("shipped scene");
        let mut readings = Vec::new();
        loop {
            let p = nodes
                .step_period(&mut |_, _| {}, &mut |_, _| {})
                .expect("19 electrodes");
            let (s, out) = (p.sample, p.output);
            readings.push(s.reading);
            if ready(&s, &out) && out.velocity != Vector3::zeros() {
                let restart = (nodes.sim.clone(), nodes.controller.clone());
                return Run {
                    name,
                    nodes,
                    t: s.t,
                    readings,
                    restart,
                };
            }
            assert!(s.t < nodes.sim.duration_s(), "{name}: never reached");
        }
    }

    /// One period; at the scene's duration, the run restarts first.
    fn step(&mut self) -> ControlOutput {
        if self.nodes.sim.time() >= self.nodes.sim.duration_s() {
            self.nodes.sim = self.restart.0.clone();
            self.nodes.controller = self.restart.1.clone();
        }
        self.nodes
            .step_period(&mut |_, _| {}, &mut |_, _| {})
            .expect("19 electrodes")
            .output
    }
}

/// An estimator for `model`, tared on the first of `readings`.
fn tared(model: WrenchGp, with_std: bool, readings: &[BioTacReading]) -> EstimatorNode {
    let mut e: EstimatorNode =
        EstimatorNode::new(Box::new(model), with_std).expect("electrode model");
    for r in &readings[..e.tare_samples()] {
        e.on_reading(r).expect("tare reading");
    }
    assert!(e.is_tared());
    e
}

/// A benchmark: its name and the call it times.
type Item<'a> = (String, Box<dyn FnMut() + 'a>);

/// `f` as an item; its result goes through `black_box`.
fn item<'a, R>(name: impl Into<String>, mut f: impl FnMut() -> R + 'a) -> Item<'a> {
    (
        name.into(),
        Box::new(move || {
            black_box(f());
        }),
    )
}

/// Benchmarks `items` as the criterion group `group`, then times
/// `LATENCY_CALLS` plain calls of each; returns a line per item with the
/// median and p99, also as shares of `period_s`.
fn measure(c: &mut Criterion, group: &str, period_s: f64, mut items: Vec<Item>) -> Vec<String> {
    let mut g = c.benchmark_group(group);
    for (name, f) in &mut items {
        g.bench_function(name.as_str(), |b| b.iter(&mut *f));
    }
    g.finish();
    items
        .into_iter()
        .map(|(name, mut f)| {
            let mut lat: Vec<f64> = (0..LATENCY_CALLS)
                .map(|_| {
                    let t0 = Instant::now();
                    f();
                    t0.elapsed().as_secs_f64()
                })
                .collect();
            lat.sort_by(f64::total_cmp);
            let at = |q: f64| {
                let s = lat[(lat.len() as f64 * q) as usize];
                format!("{:8.1} us ({:5.2}%)", s * 1e6, 100.0 * s / period_s)
            };
            format!(
                "{:<28} median {}   p99 {}",
                format!("{group}/{name}"),
                at(0.5),
                at(0.99)
            )
        })
        .collect()
}

/// Trains the model of `recipe`, printing the fit time (the simulated data
/// set excluded).
fn train(name: &str, recipe: &Recipe) -> WrenchGp {
    let (data, tare) = default_model::training_data(&recipe.axes).expect("simulated data");
    let t0 = Instant::now();
    let model = default_model::fit(recipe, &data, tare).expect("default model trains");
    println!(
        "fit {name} ({}, {} rows): {:.2} s",
        recipe.describe(),
        data.len(),
        t0.elapsed().as_secs_f64()
    );
    model
}

fn benches(c: &mut Criterion) {
    let recipe = |task| {
        Scene::builtin(task)
            .expect("shipped scene")
            .estimator
            .default_model
    };
    let fz = train("guarded scene", &recipe(TaskKind::Guarded));
    let forces = train("guided scene", &recipe(TaskKind::Guided));
    let six_axes = Recipe {
        axes: AxisSet::new(Axis::ALL.to_vec()).expect("six axes"),
        ..recipe(TaskKind::Guarded)
    };
    let six = train("guarded recipe, six axes", &six_axes);
    let hold = |_: &SimSample, out: &ControlOutput| out.phase == Phase::HOLD;
    let pushed =
        |s: &SimSample, _: &ControlOutput| s.finger.is_some_and(|f| f.velocity != Vector3::zeros());
    let scene = |task, robot| Scene::shipped(task, robot).expect("shipped scene");
    let mut guarded = Run::new(
        "guarded_hold",
        scene(TaskKind::Guarded, ShippedRobot::Pa10),
        fz.clone(),
        hold,
    );
    let mut guarded_six = Run::new(
        "guarded_hold_six_axes",
        scene(TaskKind::Guarded, ShippedRobot::Pa10),
        six.clone(),
        hold,
    );
    let mut guided = Run::new(
        "guided_follow",
        scene(TaskKind::Guided, ShippedRobot::Pa10),
        forces.clone(),
        pushed,
    );
    // The tick on other arms: six joints by a singularity (damped), seven.
    let guided_ur5 = Run::new(
        "guided_follow_ur5",
        scene(TaskKind::Guided, ShippedRobot::Ur5),
        forces.clone(),
        pushed,
    );
    let guided_panda = Run::new(
        "guided_follow_panda",
        scene(TaskKind::Guided, ShippedRobot::Panda),
        forces.clone(),
        pushed,
    );
    let period_s = guarded.nodes.sim.period_s();
    let mut summary = Vec::new();

    let readings = &guarded.readings;
    let contact = readings.last().expect("a reading");
    let mut estimators = Vec::new();
    for (axes, model) in [("fz", &fz), ("fxyz", &forces), ("six", &six)] {
        for (what, with_std) in [("mean_std", true), ("mean_only", false)] {
            let mut e = tared(model.clone(), with_std, readings);
            estimators.push(item(format!("{axes}_{what}"), move || {
                e.on_reading(contact).expect("estimate")
            }));
        }
    }
    summary.extend(measure(c, "estimator", period_s, estimators));

    let ticks = [&guarded, &guided, &guided_ur5, &guided_panda].map(|run| {
        let (mut controller, t) = (run.nodes.controller.clone(), run.t);
        assert_ne!(
            controller.tick(t).velocity,
            Vector3::zeros(),
            "{}",
            run.name
        );
        item(run.name, move || controller.tick(t))
    });
    summary.extend(measure(c, "tick", period_s, ticks.into()));

    let periods =
        [&mut guarded, &mut guarded_six, &mut guided].map(|run| item(run.name, move || run.step()));
    summary.extend(measure(c, "period", period_s, periods.into()));

    println!(
        "\n{LATENCY_CALLS} plain calls each; share of the {:.0} ms control period:",
        period_s * 1e3
    );
    for line in summary {
        println!("{line}");
    }
}

criterion_group! {
    name = control;
    config = Criterion::default()
        .sample_size(30)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(3));
    targets = benches
}
criterion_main!(control);
