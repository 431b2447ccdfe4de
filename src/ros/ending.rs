//! How a node's process ends: SIGINT (Ctrl-C), SIGTERM (a supervisor, or
//! `ros2 launch` on its way out) and a panic in any of its threads are
//! heard, and the node does what its way out needs before it exits
//! (force_controller: a zero command on every output, its goals ended with
//! the reason). A signal ends the process with exit code 0, as a ROS 2
//! node's does; a panic with 1.

use std::future::Future;
use std::panic::AssertUnwindSafe;
use std::sync::{Arc, OnceLock};

use futures::FutureExt;
use tokio::signal::unix::{signal, Signal, SignalKind};
use tokio::sync::Notify;

use super::RosError;

/// What ended the node.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Ending {
    /// SIGINT.
    Interrupt,
    /// SIGTERM.
    Terminate,
    /// A panic in one of its threads.
    Panic,
}

/// The action a panic takes first, on the panicking thread.
type FirstAction = Box<dyn Fn() + Send + Sync>;

/// SIGINT, SIGTERM and panics, heard from [`Endings::listen`] on.
pub struct Endings {
    interrupt: Signal,
    terminate: Signal,
    panicked: Arc<Notify>,
    first: Arc<OnceLock<FirstAction>>,
}

impl Endings {
    /// Hears SIGINT and SIGTERM from now on (they no longer end the
    /// process at once) and any panic (after Rust's own report of it).
    pub fn listen() -> Result<Self, RosError> {
        let interrupt = signal(SignalKind::interrupt()).map_err(RosError::Runtime)?;
        let terminate = signal(SignalKind::terminate()).map_err(RosError::Runtime)?;
        let panicked = Arc::new(Notify::new());
        let first: Arc<OnceLock<FirstAction>> = Arc::new(OnceLock::new());
        let (notify, act) = (panicked.clone(), first.clone());
        let report = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if let Some(act) = act.get() {
                act();
            }
            report(info);
            notify.notify_one();
        }));
        Ok(Endings {
            interrupt,
            terminate,
            panicked,
            first,
        })
    }

    /// What a panic in any thread does first, on that thread, before the
    /// node hears of it: it must take no lock the panicking thread may
    /// hold. Set once.
    pub fn on_panic(&self, act: impl Fn() + Send + Sync + 'static) {
        let _ = self.first.set(Box::new(act));
    }

    /// The next signal or panic.
    pub async fn next(&mut self) -> Ending {
        tokio::select! {
            _ = self.interrupt.recv() => Ending::Interrupt,
            _ = self.terminate.recv() => Ending::Terminate,
            _ = self.panicked.notified() => Ending::Panic,
        }
    }

    /// Runs `node` until it ends, a signal comes (Ok: nothing more to do
    /// on the way out) or a panic (an error).
    pub async fn until(
        &mut self,
        node: impl Future<Output = Result<(), RosError>>,
    ) -> Result<(), RosError> {
        let ending = tokio::select! {
            ended = AssertUnwindSafe(node).catch_unwind() => {
                return ended.unwrap_or(Err(RosError::Panicked));
            }
            ending = self.next() => ending,
        };
        ending.into_result()
    }
}

impl Ending {
    /// The process's end for it: Ok for a signal, an error for a panic.
    pub fn into_result(self) -> Result<(), RosError> {
        match self {
            Ending::Panic => Err(RosError::Panicked),
            signal => {
                tracing::info!("{signal:?}: ending");
                Ok(())
            }
        }
    }
}

/// Test-only: with `TACTILE_FORCE_INJECT_PANIC` set to `place`, resolves
/// when SIGUSR1 comes, for the caller to panic there (tests/ros: a panic
/// stops the arm as a signal does); never otherwise.
pub async fn injected_panic(place: &str) {
    if std::env::var("TACTILE_FORCE_INJECT_PANIC").as_deref() == Ok(place) {
        if let Ok(mut usr1) = signal(SignalKind::user_defined1()) {
            usr1.recv().await;
            return;
        }
    }
    std::future::pending().await
}
