//! Helpers shared by the closed-loop test files.

use std::sync::OnceLock;

use tactile_force::control::TaskKind;
use tactile_force::learn::default_model;
use tactile_force::learn::models::wrench_gp::WrenchGp;
use tactile_force::runtime::Scene;

/// The default model of a scene's task, trained from simulated data.
pub fn scene_model(task: TaskKind) -> WrenchGp {
    let recipe = Scene::builtin(task)
        .expect("the shipped scene parses")
        .estimator
        .default_model;
    default_model::train(&recipe).expect("the default model trains")
}

/// The guided scene's default model (fx, fy, fz), trained once for all the
/// tests of a file (it serves the guarded scene too).
pub fn model() -> WrenchGp {
    static MODEL: OnceLock<WrenchGp> = OnceLock::new();
    MODEL.get_or_init(|| scene_model(TaskKind::Guided)).clone()
}
