//! The inputs a node needs, and which one is silent: no message for longer
//! than `silent_input_s`. A silent input is named once when it goes silent
//! (logged) and on every status while it is (`/diagnostics`), with what the
//! ROS graph says of its publishers: none, some whose QoS cannot reach this
//! node's subscription, or some that send nothing ([`why_silent`]).

/// A subscription's or a publisher's QoS, as far as it decides whether a
/// publisher reaches a subscription (DDS request-offered rules).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Qos {
    /// Reliable (else best effort).
    pub reliable: bool,
    /// Transient local (else volatile).
    pub transient_local: bool,
}

impl Qos {
    /// Best effort, volatile: what the nodes' sensor inputs subscribe
    /// with, which every publisher reaches.
    pub const ANY_PUBLISHER: Qos = Qos {
        reliable: false,
        transient_local: false,
    };

    /// Why a publisher offering `self` cannot reach a subscription asking
    /// `wanted`; None when it can.
    pub fn cannot_reach(self, wanted: Qos) -> Option<&'static str> {
        if wanted.reliable && !self.reliable {
            return Some("it publishes best effort, the subscription asks reliable");
        }
        if wanted.transient_local && !self.transient_local {
            return Some("it publishes volatile, the subscription asks transient local");
        }
        None
    }
}

/// A publisher on a topic, as the ROS graph lists it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Publisher {
    /// Its node, with its namespace.
    pub node: String,
    /// What it offers.
    pub qos: Qos,
}

/// Why `topic`, subscribed with `wanted`, has brought nothing for
/// `silent_s` seconds, given its `publishers`.
pub fn why_silent(topic: &str, silent_s: f64, wanted: Qos, publishers: &[Publisher]) -> String {
    let head = format!("{topic}: no message for {silent_s:.1} s");
    if publishers.is_empty() {
        return format!("{head}: no publisher");
    }
    let blocked: Vec<String> = publishers
        .iter()
        .filter_map(|p| {
            p.qos
                .cannot_reach(wanted)
                .map(|why| format!("{} ({why})", p.node))
        })
        .collect();
    if blocked.is_empty() {
        return format!("{head}: {} publisher(s), none sending", publishers.len());
    }
    format!("{head}: incompatible QoS: {}", blocked.join("; "))
}

/// One input: its topic and when it last brought a message.
#[derive(Debug, Clone)]
struct Input {
    topic: &'static str,
    last_s: f64,
    said: bool,
}

/// When each input last brought a message (seconds on a monotonic clock).
#[derive(Debug, Clone)]
pub struct InputWatch {
    silent_after_s: f64,
    inputs: Vec<Input>,
}

impl InputWatch {
    /// Watches `topics` from `now`: each is silent once `silent_after_s`
    /// pass without a message.
    pub fn new(topics: &[&'static str], silent_after_s: f64, now: f64) -> Self {
        let inputs = topics
            .iter()
            .map(|&topic| Input {
                topic,
                last_s: now,
                said: false,
            })
            .collect();
        InputWatch {
            silent_after_s,
            inputs,
        }
    }

    /// A message came on `topic` at `now`.
    pub fn arrived(&mut self, topic: &str, now: f64) {
        if let Some(i) = self.inputs.iter_mut().find(|i| i.topic == topic) {
            i.last_s = now;
            i.said = false;
        }
    }

    /// The inputs that `needed` names and that are silent at `now`, with
    /// how long, and whether each is newly so (to be logged once).
    pub fn silent(&mut self, now: f64, needed: impl Fn(&str) -> bool) -> Vec<Silence> {
        let after = self.silent_after_s;
        self.inputs
            .iter_mut()
            .filter(|i| needed(i.topic) && now - i.last_s > after)
            .map(|i| Silence {
                topic: i.topic,
                silent_s: now - i.last_s,
                new: !std::mem::replace(&mut i.said, true),
            })
            .collect()
    }
}

/// An input silent for `silent_s`.
#[derive(Debug, Clone, PartialEq)]
pub struct Silence {
    /// Its topic.
    pub topic: &'static str,
    /// For how long (s).
    pub silent_s: f64,
    /// True the first time it is reported in this silence.
    pub new: bool,
}

#[cfg(test)]
mod tests {
    use super::*;

    const RELIABLE: Qos = Qos {
        reliable: true,
        transient_local: false,
    };

    #[test]
    fn an_input_is_silent_after_the_bound_once_named_and_back_when_a_message_comes() {
        let mut w = InputWatch::new(&["joint_states", "ft_sensor/wrench"], 2.0, 10.0);
        let all = |_: &str| true;
        assert!(w.silent(11.9, all).is_empty());
        w.arrived("joint_states", 11.0);
        let s = w.silent(12.5, all);
        assert_eq!(s.len(), 1);
        assert_eq!((s[0].topic, s[0].new), ("ft_sensor/wrench", true));
        assert!((s[0].silent_s - 2.5).abs() < 1e-12);
        assert!(!w.silent(13.0, all)[0].new, "said once per silence");
        w.arrived("ft_sensor/wrench", 13.1);
        assert!(w.silent(14.0, |t| t == "ft_sensor/wrench").is_empty());
        // Not needed: not named, however long.
        assert!(w.silent(100.0, |t| t == "nothing").is_empty());
    }

    #[test]
    fn a_best_effort_subscription_hears_any_publisher_a_reliable_one_not_a_best_effort_one() {
        let best_effort = Qos::ANY_PUBLISHER;
        assert_eq!(RELIABLE.cannot_reach(best_effort), None);
        assert_eq!(best_effort.cannot_reach(best_effort), None);
        assert!(best_effort
            .cannot_reach(RELIABLE)
            .unwrap()
            .contains("best effort"));
        let latched = Qos {
            reliable: true,
            transient_local: true,
        };
        assert!(RELIABLE.cannot_reach(latched).unwrap().contains("volatile"));
        assert_eq!(latched.cannot_reach(RELIABLE), None);
    }

    #[test]
    fn the_reason_names_the_topic_and_what_the_graph_shows() {
        let p = |node: &str, qos| Publisher {
            node: node.into(),
            qos,
        };
        let none = why_silent("ft_sensor/wrench", 3.04, RELIABLE, &[]);
        assert_eq!(none, "ft_sensor/wrench: no message for 3.0 s: no publisher");
        let blocked = why_silent(
            "ft_sensor/wrench",
            3.0,
            RELIABLE,
            &[p("/ft_driver", Qos::ANY_PUBLISHER)],
        );
        assert!(
            blocked.contains("incompatible QoS: /ft_driver (it publishes best effort"),
            "{blocked}"
        );
        let quiet = why_silent(
            "joint_states",
            2.5,
            Qos::ANY_PUBLISHER,
            &[p("/arm", RELIABLE)],
        );
        assert!(quiet.ends_with("1 publisher(s), none sending"), "{quiet}");
    }
}
