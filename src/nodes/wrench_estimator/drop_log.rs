//! What the estimator's log says of the readings it dropped, once a report
//! period ([`DropLog::line`]): the counts since the last report, the
//! reason readings of another layout are refused, and once, the first time
//! readings are dropped as stale by another clock than the node's, how to
//! replay a recording ([`EstimatorNode::stale_hint`]). `/diagnostics`
//! carries the hint for as long as it holds ([`EstimatorNode::status`]).

use super::{Dropped, EstimatorNode};
use crate::nodes::status::Level;
use crate::sensor::SensorInput;

/// The counts the log last said, and whether it gave the stale hint.
#[derive(Debug, Default, Clone, PartialEq, Eq)]
pub struct DropLog {
    reported: Dropped,
    hinted: bool,
}

impl DropLog {
    /// The line to log for what `node` dropped since the last call, and
    /// its level; None when it dropped nothing. A refusal (another
    /// electrode layout) is an error, said each time; drops are a warning;
    /// the stale hint comes on the first line that counts a stale reading
    /// while the hint holds, and not again.
    pub fn line<S: SensorInput>(&mut self, node: &EstimatorNode<S>) -> Option<(Level, String)> {
        let d = node.dropped();
        let said = d.since(&self.reported);
        let stale = d.stale > self.reported.stale;
        self.reported = d;
        let said = format!("{} in the last second", said?);
        if let Some(why) = node.refusal() {
            return Some((Level::Error, format!("{said}; {why}")));
        }
        match node.stale_hint().filter(|_| stale && !self.hinted) {
            Some(hint) => {
                self.hinted = true;
                Some((Level::Warn, format!("{said}; {hint}")))
            }
            None => Some((Level::Warn, said)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::tests::{electrode_model, reading};
    use super::*;
    use crate::sensor::biotac::BioTacInput;

    fn node() -> EstimatorNode<BioTacInput> {
        EstimatorNode::<BioTacInput>::new(electrode_model(), true)
            .unwrap()
            .with_stale_timeout(0.03)
            .unwrap()
    }

    #[test]
    fn the_replay_hint_is_logged_once_and_the_counts_every_time() {
        let (mut node, mut log) = (node(), DropLog::default());
        assert_eq!(log.line(&node), None, "nothing dropped");
        // A recording's readings on the wall clock: an hour old.
        for i in 0..5 {
            let _ = node.on_received(&reading(1.0 + i as f64 * 0.01, 0), 3601.0);
        }
        let (level, first) = log.line(&node).unwrap();
        assert_eq!(level, Level::Warn);
        assert!(
            first
                .starts_with("dropped 5 readings: 0 undecodable, 0 with invalid channels, 5 stale"),
            "{first}"
        );
        assert!(
            first.contains("use_sim_time:=true") && first.contains("--clock"),
            "{first}"
        );
        assert_eq!(log.line(&node), None, "nothing new");
        for _ in 0..3 {
            let _ = node.on_received(&reading(1.1, 0), 3602.0);
        }
        let (level, second) = log.line(&node).unwrap();
        assert_eq!(level, Level::Warn);
        assert!(second.starts_with("dropped 3 readings"), "{second}");
        assert!(!second.contains("use_sim_time"), "said once: {second}");
        // /diagnostics keeps saying it, with the count.
        let status = node.status();
        assert!(
            status.message.contains("8 readings dropped as stale")
                && status.message.contains("use_sim_time:=true")
                && status.message.contains("--clock"),
            "{}",
            status.message
        );
        assert!(status
            .values
            .contains(&("dropped_stale".into(), "8".into())));
    }

    #[test]
    fn late_readings_of_this_clock_are_counted_without_the_hint() {
        let (mut node, mut log) = (node(), DropLog::default());
        let _ = node.on_received(&reading(1.0, 0), 1.5);
        let (_, line) = log.line(&node).unwrap();
        assert_eq!(
            line,
            "dropped 1 readings: 0 undecodable, 0 with invalid channels, 1 stale, 0 of another \
             electrode layout, 0 non-finite in the last second"
        );
        assert!(!node.status().message.contains("dropped as stale"));
        // A reading of another clock later: the hint then, once.
        let _ = node.on_received(&reading(1.0, 0), 90.0);
        assert!(log.line(&node).unwrap().1.contains("--clock"));
    }

    #[test]
    fn readings_before_the_clock_started_say_to_play_with_the_clock() {
        let (mut node, mut log) = (node(), DropLog::default());
        // use_sim_time:=true and no /clock: the node's clock reads no time.
        let _ = node.on_received(&reading(1.0, 0), f64::NAN);
        let (_, line) = log.line(&node).unwrap();
        assert!(
            line.contains("read no time") && line.contains("ros2 bag play --clock"),
            "{line}"
        );
        assert!(node
            .status()
            .message
            .contains("1 readings dropped as stale"));
    }
}
