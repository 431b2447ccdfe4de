//! Every way the arm is stopped from outside the task: the `~/stop`
//! service (std_srvs/Trigger; the node stays, idle until a new goal or a
//! `task` set) and the node's end (a signal, a panic, a fatal error, the
//! end of its loop), each a zero command on every output at once and the
//! goal running ended with the reason ([`Stopped`]).

use std::future::Future;
use std::panic::AssertUnwindSafe;
use std::sync::Mutex;
use std::time::Duration;

use futures::FutureExt;

use super::commands::Commands;
use crate::nodes::force_controller::stop::Stopped;
use crate::nodes::force_controller::ForceControllerNode;
use crate::nodes::lifecycle::State;
use crate::ros::ending::{Ending, Endings};
use crate::ros::{lock, RosClock, RosError};

/// How long the node's end waits for its goals' results to go out.
const RESULTS_WAIT: Duration = Duration::from_millis(500);

/// Why the node ends, for its goal's result.
fn stopped_by(ending: Ending) -> Stopped {
    match ending {
        Ending::Interrupt => Stopped::Interrupt,
        Ending::Terminate => Stopped::Terminate,
        Ending::Panic => Stopped::Panic,
    }
}

/// Runs the control loop `stepping` until it ends, panics, or a signal or
/// a panic elsewhere comes ([`Endings`]); then the node's end ([`end`]),
/// and the process's exit: Ok after a signal.
pub(super) async fn run_to_the_end(
    stepping: impl Future<Output = Result<(), RosError>>,
    mut endings: Endings,
    shared: &Mutex<ForceControllerNode>,
    commands: &Commands,
    clock: &RosClock,
    period: Duration,
) -> Result<(), RosError> {
    let (why, ended) = tokio::select! {
        ended = AssertUnwindSafe(stepping).catch_unwind() => match ended {
            Ok(Ok(())) => (Stopped::Error, Ok(())),
            Ok(Err(e)) => (Stopped::Error, Err(e)),
            Err(_) => (Stopped::Panic, Err(RosError::Panicked)),
        },
        ending = endings.next() => (stopped_by(ending), ending.into_result()),
    };
    end(shared, commands, why, clock, period).await;
    ended
}

/// The node's end: the arm stopped for `why` and the last command, a zero,
/// sent on every output; then the goal running ends with the reason (its
/// follower sends the result within a period), the node still spinning
/// so that the result reaches its client.
async fn end(
    shared: &Mutex<ForceControllerNode>,
    commands: &Commands,
    why: Stopped,
    clock: &RosClock,
    period: Duration,
) {
    {
        let mut n = lock(shared);
        n.stop(why);
        // No goal or task taken on the way out.
        n.leave_active(why, State::Finalized);
        commands.zero(&n, clock.now_s(), true);
    }
    let since = tokio::time::Instant::now();
    while lock(shared).goal_running() && since.elapsed() < RESULTS_WAIT {
        tokio::time::sleep(period).await;
    }
    // The result's answer leaves on the spin thread.
    tokio::time::sleep(2 * period).await;
}

/// Serves `~/stop`: the arm stopped at once (a zero command, any goal
/// ended `stopped: service`), answered with what was stopped.
#[cfg(not(feature = "ros2-doc-only"))]
pub(super) fn serve_stop(
    node: &mut r2r::Node,
    shared: std::sync::Arc<Mutex<ForceControllerNode>>,
    commands: std::sync::Arc<Commands>,
    clock: RosClock,
) -> Result<(), RosError> {
    use futures::StreamExt;
    use r2r::std_srvs::srv::Trigger;
    let mut requests =
        node.create_service::<Trigger::Service>("~/stop", r2r::QosProfile::services_default())?;
    tokio::spawn(async move {
        while let Some(req) = requests.next().await {
            let message = {
                let mut n = lock(&shared);
                let goal = n.goal_running();
                n.stop(Stopped::Service);
                commands.zero(&n, clock.now_s(), false);
                match goal {
                    true => "stopped: zero velocity; the goal running ends `stopped: service`",
                    false => "stopped: zero velocity",
                }
            };
            let _ = req.respond(Trigger::Response {
                success: true,
                message: format!("{message}; idle until a new goal or a task set"),
            });
        }
    });
    Ok(())
}
