//! The inputs a node watches for silence ([`InputWatch`]): each message
//! marks its topic as it passes, and the node's status names each input it
//! needs that has been silent longer than its bound, with what the ROS
//! graph shows of the topic's publishers (none, an incompatible QoS, or
//! quiet ones): logged once per silence, on `/diagnostics` while it lasts.

use std::sync::{Arc, Mutex};
use std::time::Instant;

use futures::StreamExt;

use super::bounded::Messages;
use super::{convert, lock, Graph};
use crate::nodes::input_watch::{why_silent, InputWatch, Qos};
use crate::nodes::status::{Level, Status};

/// A node's watched inputs: each topic and the QoS it subscribes with.
pub struct Inputs {
    watch: Mutex<InputWatch>,
    wanted: Vec<(&'static str, Qos)>,
    start: Instant,
}

impl Inputs {
    /// Watches `topics` from now: silent after `silent_after_s` without a
    /// message.
    pub fn new(topics: &[(&'static str, &r2r::QosProfile)], silent_after_s: f64) -> Arc<Self> {
        let names: Vec<&'static str> = topics.iter().map(|(t, _)| *t).collect();
        Arc::new(Inputs {
            watch: Mutex::new(InputWatch::new(&names, silent_after_s, 0.0)),
            wanted: topics.iter().map(|(t, q)| (*t, convert::qos(q))).collect(),
            start: Instant::now(),
        })
    }

    /// `messages` of `topic`, each marking it as heard.
    pub fn watched<T>(
        self: &Arc<Self>,
        topic: &'static str,
        messages: impl Messages<T>,
    ) -> impl Messages<T> {
        let inputs = self.clone();
        messages.inspect(move |_| inputs.heard(topic))
    }

    /// A message came on `topic`.
    pub fn heard(&self, topic: &str) {
        let now = self.start.elapsed().as_secs_f64();
        lock(&self.watch).arrived(topic, now);
    }

    /// Names in `status` each input `needed` names that is silent, with
    /// what `graph` shows of its publishers; logs it when newly silent.
    pub async fn report(&self, status: &mut Status, graph: &Graph, needed: impl Fn(&str) -> bool) {
        let now = self.start.elapsed().as_secs_f64();
        let silent = lock(&self.watch).silent(now, needed);
        for s in silent {
            let wanted = self
                .wanted
                .iter()
                .find(|(t, _)| *t == s.topic)
                .map_or(Qos::ANY_PUBLISHER, |(_, q)| *q);
            let publishers = graph.publishers(s.topic).await;
            let why = why_silent(s.topic, s.silent_s, wanted, &publishers);
            if s.new {
                tracing::warn!("silent input: {why}");
            }
            status.raise(Level::Warn, &format!("; silent: {why}"));
            status.push(format!("silent {}", s.topic), why);
        }
    }
}
