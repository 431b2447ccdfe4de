//! A recorded session cut into trials: at the rests out of contact
//! between presses (found from the force), or at given times.

use std::str::FromStr;

use crate::record::Record;

/// How a session's records are cut into trials.
#[derive(Debug, Clone, PartialEq)]
pub enum TrialSplit {
    /// One trial.
    Whole,
    /// A new trial in the middle of every rest: a stretch of at least
    /// `min_rest_s` where |F - F0| <= `force_n`, F0 the mean force of the
    /// first `rest_samples` records (out of contact, as for the tare).
    Rests {
        /// Largest force change from F0 at rest (N).
        force_n: f64,
        /// Shortest rest that separates two presses (s).
        min_rest_s: f64,
        /// Records that give F0.
        rest_samples: usize,
    },
    /// A new trial at each of these times (s from the first record),
    /// increasing.
    Starts(Vec<f64>),
}

/// `--trials`: `rests`, `whole`, or the times trials 2, 3, ... start at.
#[derive(Debug, Clone, PartialEq)]
pub enum TrialsArg {
    /// The reader's default for the bag's message type.
    Auto,
    /// At the rests ([`TrialSplit::Rests`]).
    Rests,
    /// One trial.
    Whole,
    /// At these times (s from the first paired reading).
    Starts(Vec<f64>),
}

impl FromStr for TrialsArg {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "auto" => return Ok(TrialsArg::Auto),
            "rests" => return Ok(TrialsArg::Rests),
            "whole" => return Ok(TrialsArg::Whole),
            _ => {}
        }
        let times = (s.split(','))
            .map(|t| t.trim().parse::<f64>())
            .collect::<Result<Vec<f64>, _>>()
            .map_err(|_| {
                format!("{s:?}: expected auto, rests, whole or times in s such as 9.6,15.4")
            })?;
        let increasing = times.windows(2).all(|w| w[0] < w[1]);
        if !increasing || !times.iter().all(|t| t.is_finite() && *t > 0.0) {
            return Err(format!(
                "{s:?}: trial start times must be positive and increasing"
            ));
        }
        Ok(TrialsArg::Starts(times))
    }
}

/// Numbers the records' trials (1, 2, ...) as `how` cuts them; the
/// records in time order. Returns the number of trials.
pub fn split_trials(records: &mut [Record], how: &TrialSplit) -> usize {
    let starts = match how {
        TrialSplit::Whole => Vec::new(),
        TrialSplit::Starts(times) => times.clone(),
        TrialSplit::Rests {
            force_n,
            min_rest_s,
            rest_samples,
        } => rest_middles(records, *force_n, *min_rest_s, *rest_samples),
    };
    for r in records.iter_mut() {
        r.trial = 1 + starts.iter().filter(|&&s| s <= r.t).count() as u32;
    }
    records.last().map_or(0, |r| r.trial as usize)
}

/// The middle times of the rests between contacts.
fn rest_middles(
    records: &[Record],
    force_n: f64,
    min_rest_s: f64,
    rest_samples: usize,
) -> Vec<f64> {
    let n0 = rest_samples.clamp(1, records.len().max(1));
    let Some(first) = records.get(..n0) else {
        return Vec::new();
    };
    let f0 = first
        .iter()
        .map(|r| r.wrench.force)
        .sum::<nalgebra::Vector3<f64>>()
        / n0 as f64;
    let touching = |r: &Record| (r.wrench.force - f0).norm() > force_n;
    let mut middles = Vec::new();
    // The last contact's time, and the rest since it began (s).
    let mut last_contact: Option<f64> = None;
    let mut rest_from: Option<f64> = None;
    for r in records {
        if touching(r) {
            if let (Some(_), Some(from)) = (last_contact, rest_from) {
                if r.t - from >= min_rest_s {
                    middles.push(0.5 * (from + r.t));
                }
            }
            last_contact = Some(r.t);
            rest_from = None;
        } else if last_contact.is_some() && rest_from.is_none() {
            rest_from = Some(r.t);
        }
    }
    middles
}

#[cfg(test)]
mod tests;
