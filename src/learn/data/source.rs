//! Where a data file's wrenches come from: the topics of a bag, how a bag
//! is cut into trials, and the F/T sensor's frame.

use super::bag::{Bag, BagTopics};
use super::trials::{split_trials, TrialSplit, TrialsArg};
use crate::biotac::hand::HandKind;
use crate::sensor::biotac;
use crate::wrench::FrameTransform;

/// At rest, by default: the force within this of the first readings' mean (N).
pub const DEFAULT_REST_FORCE_N: f64 = 0.1;
/// The shortest rest between two presses, by default (s).
pub const DEFAULT_REST_MIN_S: f64 = 0.5;

/// Where the files' wrenches come from: the topics of a bag, how a bag is
/// cut into trials, and the F/T sensor's frame.
#[derive(Debug, Clone, PartialEq)]
pub struct Source {
    /// Topics read from bags and how their stamps pair.
    pub topics: BagTopics,
    /// How a bag is cut into trials.
    pub trials: TrialsArg,
    /// At rest: the force within this of the first 50 readings' mean (N).
    pub rest_force_n: f64,
    /// The shortest rest between two presses (s).
    pub rest_min_s: f64,
    /// Where the F/T sensor sits in the BioTac frame; None: the files are
    /// in the BioTac frame already.
    pub ft_to_biotac: Option<FrameTransform>,
}

impl Default for Source {
    /// The default topics, trials as the bag's message type says, no frame change.
    fn default() -> Self {
        Source {
            topics: BagTopics::default(),
            trials: TrialsArg::Auto,
            rest_force_n: DEFAULT_REST_FORCE_N,
            rest_min_s: DEFAULT_REST_MIN_S,
            ft_to_biotac: None,
        }
    }
}

impl Source {
    /// Cuts a bag's records into trials; the number of trials.
    pub fn split(&self, bag: &mut Bag) -> usize {
        let rests = TrialSplit::Rests {
            force_n: self.rest_force_n,
            min_rest_s: self.rest_min_s,
            rest_samples: biotac::DEFAULT_TARE_SAMPLES,
        };
        let how = match &self.trials {
            TrialsArg::Auto if HandKind::of(&bag.reading_type).is_some() => rests,
            TrialsArg::Auto | TrialsArg::Whole => TrialSplit::Whole,
            TrialsArg::Rests => rests,
            TrialsArg::Starts(times) => TrialSplit::Starts(times.clone()),
        };
        split_trials(&mut bag.records, &how)
    }
}
