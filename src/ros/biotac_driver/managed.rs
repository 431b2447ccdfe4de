//! `biotac_driver` as a managed node ([`crate::ros::lifecycle`]):
//! `configure` reads the link's and the readings' parameters again and
//! opens the link, polled on a thread of its own; `activate` publishes its
//! readings (its link's state goes to `/diagnostics` in every configured
//! state); `deactivate` stops publishing them; `cleanup` and `shutdown`
//! close the link. A driver that fails ends the node with the reason.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::Receiver;
use std::sync::{Arc, Mutex};

use super::{link, Outputs, Publishers};
use crate::nodes::lifecycle::{Managed, State};
use crate::ros::{ParamMap, RosClock, RosError};

/// The link's thread while configured.
struct Running {
    stop: Arc<AtomicBool>,
    publishing: Arc<AtomicBool>,
    thread: std::thread::JoinHandle<()>,
}

/// What the lifecycle's callbacks act on.
pub(super) struct Link {
    pub(super) params: ParamMap,
    pub(super) publishers: Publishers,
    pub(super) tare_requests: Arc<Mutex<Receiver<()>>>,
    pub(super) clock: RosClock,
    /// Where the thread says it failed.
    pub(super) failed: tokio::sync::mpsc::UnboundedSender<RosError>,
    running: Option<Running>,
    /// True while unconfigured: parameters may then be set.
    unconfigured: Arc<AtomicBool>,
}

impl Link {
    /// Not configured yet.
    pub(super) fn new(
        params: ParamMap,
        publishers: Publishers,
        tare_requests: Arc<Mutex<Receiver<()>>>,
        clock: RosClock,
        failed: tokio::sync::mpsc::UnboundedSender<RosError>,
        unconfigured: Arc<AtomicBool>,
    ) -> Self {
        Link {
            params,
            publishers,
            tare_requests,
            clock,
            failed,
            running: None,
            unconfigured,
        }
    }

    /// Closes the link: the thread stopped and waited for; `unconfigured`
    /// afterwards (else finalized).
    fn close(&mut self, unconfigured: bool) {
        self.unconfigured.store(unconfigured, Ordering::Relaxed);
        if let Some(r) = self.running.take() {
            r.stop.store(true, Ordering::Relaxed);
            let _ = r.thread.join();
            tracing::info!("link closed");
        }
    }

    fn publishing(&self, on: bool) {
        if let Some(r) = &self.running {
            r.publishing.store(on, Ordering::Relaxed);
        }
    }
}

impl Managed for Link {
    fn on_configure(&mut self) -> Result<(), String> {
        let (driver, name) = link::declare(&self.params).map_err(|e| e.to_string())?;
        let publishing = Arc::new(AtomicBool::new(false));
        let out = Outputs::read(
            &self.params,
            self.publishers.clone(),
            name,
            publishing.clone(),
        )
        .map_err(|e| e.to_string())?;
        let stop = Arc::new(AtomicBool::new(false));
        let (halt, tare) = (stop.clone(), self.tare_requests.clone());
        let (clock, failed) = (self.clock.clone(), self.failed.clone());
        let thread = std::thread::Builder::new()
            .name("biotac link".into())
            .spawn(move || {
                if let Err(e) = out.drive(driver, &tare, &clock, &halt) {
                    let _ = failed.send(e);
                }
            })
            .map_err(|e| format!("the link's thread: {e}"))?;
        self.running = Some(Running {
            stop,
            publishing,
            thread,
        });
        self.unconfigured.store(false, Ordering::Relaxed);
        Ok(())
    }

    fn on_cleanup(&mut self) {
        self.close(true);
    }

    fn on_activate(&mut self) -> Result<(), String> {
        self.publishing(true);
        Ok(())
    }

    fn on_deactivate(&mut self) {
        self.publishing(false);
    }

    fn on_shutdown(&mut self, _from: State) {
        self.close(false);
    }
}
