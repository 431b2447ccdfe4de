//! The goals of an action server (ROS 2's action protocol, whatever
//! carries it): those running, with their cancel's way; the results of
//! those that ended, kept for [`RESULT_KEPT_S`] (at most [`RESULTS_KEPT`]);
//! the result requests waiting for a goal to end (at most
//! [`WAITING_MAX`]). A flood of goals or requests grows none of it for
//! longer than that.

use std::collections::{HashMap, VecDeque};

/// How long a finished goal's result waits for its client (s; rcl_action's
/// default result timeout in Jazzy).
pub const RESULT_KEPT_S: f64 = 10.0;
/// The most finished goals whose results are kept: ten seconds of goals
/// at 100 a second.
pub const RESULTS_KEPT: usize = 1000;
/// The most result requests that wait for goals to end; one more is
/// answered at once, with the status unknown.
pub const WAITING_MAX: usize = 64;
/// The ended goals the status lists (the last ones), beside those running:
/// a flood of refused goals does not grow each status message.
pub const STATUS_ENDED: usize = 16;

/// A goal's id (its UUID's bytes).
pub type Id = Vec<u8>;
/// A time stamp (s, ns).
pub type Stamp = (i32, u32);

/// A goal's status, as the protocol names them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Status {
    /// Not a goal the server knows (or knows any more).
    Unknown,
    /// Running.
    Executing,
    /// Running, its cancel asked.
    Canceling,
    /// Ended: reached.
    Succeeded,
    /// Ended: canceled.
    Canceled,
    /// Ended: failed or refused.
    Aborted,
}

/// How a cancel request is answered.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum CancelAnswer {
    /// These goals (id, accepted at) are canceling now.
    Canceling(Vec<(Id, Stamp)>),
    /// The goal named has ended.
    Ended,
    /// No goal of that id.
    Unknown,
}

/// A goal running: when it was accepted, its status, where its cancel goes.
struct Running<C> {
    stamp: Stamp,
    status: Status,
    cancel: C,
}

/// A goal ended: its result while kept.
struct Ended<R> {
    id: Id,
    stamp: Stamp,
    status: Status,
    result: R,
    at_s: f64,
}

/// The goals of one server: `R` a result, `W` a result request that waits,
/// `C` the way to a running goal's cancel.
pub struct ActionGoals<R, W, C> {
    running: HashMap<Id, Running<C>>,
    ended: VecDeque<Ended<R>>,
    waiting: Vec<(Id, W)>,
}

impl<R: Clone + Default, W, C> Default for ActionGoals<R, W, C> {
    fn default() -> Self {
        ActionGoals {
            running: HashMap::new(),
            ended: VecDeque::new(),
            waiting: Vec::new(),
        }
    }
}

impl<R: Clone + Default, W, C> ActionGoals<R, W, C> {
    /// A goal accepted at `stamp`: it runs; its cancel goes to `cancel`.
    pub fn start(&mut self, id: Id, stamp: Stamp, cancel: C) {
        let status = Status::Executing;
        self.running.insert(
            id,
            Running {
                stamp,
                status,
                cancel,
            },
        );
    }

    /// The goals a cancel request names that still run, set canceling:
    /// the one of `id`, or when `id` is all zeros every one accepted up to
    /// `stamp` (all of them when it is zero too). `notify` tells a goal's
    /// cancel and says whether it was heard (a goal whose handle is gone
    /// is not canceling).
    pub fn cancel(
        &mut self,
        id: &[u8],
        stamp: Stamp,
        mut notify: impl FnMut(&C) -> bool,
    ) -> CancelAnswer {
        let all = id.iter().all(|b| *b == 0);
        let mut canceling = Vec::new();
        for (goal_id, goal) in &mut self.running {
            let named = match all {
                true => stamp == (0, 0) || goal.stamp <= stamp,
                false => goal_id == id,
            };
            if named && notify(&goal.cancel) {
                goal.status = Status::Canceling;
                canceling.push((goal_id.clone(), goal.stamp));
            }
        }
        if !canceling.is_empty() || all {
            CancelAnswer::Canceling(canceling)
        } else if self.ended.iter().any(|e| e.id == id) {
            CancelAnswer::Ended
        } else {
            CancelAnswer::Unknown
        }
    }

    /// A result request for goal `id` at `now_s`: the answer at once for a
    /// goal that ended (unknown for one the server does not know), or None
    /// when the request waits for a goal running (while fewer than
    /// [`WAITING_MAX`] wait).
    pub fn result(&mut self, id: Id, request: W, now_s: f64) -> Option<(W, Status, R)> {
        self.forget_old(now_s);
        if self.running.contains_key(&id) && self.waiting.len() < WAITING_MAX {
            self.waiting.push((id, request));
            return None;
        }
        Some(match self.ended.iter().find(|e| e.id == id) {
            Some(e) => (request, e.status, e.result.clone()),
            None => (request, Status::Unknown, R::default()),
        })
    }

    /// Goal `id` ended at `now_s` with `status` and `result`: kept, and
    /// the requests that waited for it, to be answered with it.
    pub fn end(&mut self, id: &[u8], status: Status, result: R, now_s: f64) -> Vec<W> {
        let Some(goal) = self.running.remove(id) else {
            return Vec::new();
        };
        let answered = self.waiting.extract_if(.., |(w, _)| w == id);
        let answered = answered.map(|(_, request)| request).collect();
        self.forget_old(now_s);
        if self.ended.len() == RESULTS_KEPT {
            self.ended.pop_front();
        }
        self.ended.push_back(Ended {
            id: id.to_vec(),
            stamp: goal.stamp,
            status,
            result,
            at_s: now_s,
        });
        answered
    }

    /// The status of the goals running and of the last [`STATUS_ENDED`]
    /// that ended (id, accepted at, status).
    pub fn statuses(&self) -> Vec<(Id, Stamp, Status)> {
        let running = self.running.iter().map(|(id, g)| (id, g.stamp, g.status));
        let ended = self.ended.iter().rev().take(STATUS_ENDED);
        let ended = ended.map(|e| (&e.id, e.stamp, e.status));
        running
            .chain(ended)
            .map(|(id, stamp, status)| (id.clone(), stamp, status))
            .collect()
    }

    /// Forgets the results kept longer than [`RESULT_KEPT_S`] at `now_s`.
    fn forget_old(&mut self, now_s: f64) {
        while self
            .ended
            .front()
            .is_some_and(|e| now_s - e.at_s > RESULT_KEPT_S)
        {
            self.ended.pop_front();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    type Goals = ActionGoals<String, u32, bool>;

    fn id(n: u8) -> Id {
        vec![n; 16]
    }

    #[test]
    fn a_result_asked_while_the_goal_runs_is_answered_when_it_ends() {
        let mut g = Goals::default();
        g.start(id(1), (1, 0), true);
        assert!(g.result(id(1), 7, 0.0).is_none(), "waits");
        assert_eq!(
            g.end(&id(1), Status::Succeeded, "hold".into(), 1.0),
            vec![7]
        );
        assert_eq!(
            g.result(id(1), 8, 2.0),
            Some((8, Status::Succeeded, "hold".into()))
        );
        assert_eq!(
            g.result(id(2), 9, 2.0),
            Some((9, Status::Unknown, String::new()))
        );
    }

    #[test]
    fn results_are_kept_for_their_time_and_number_only() {
        let mut g = Goals::default();
        g.start(id(1), (1, 0), true);
        g.end(&id(1), Status::Aborted, "refused".into(), 0.0);
        let asked = g.result(id(1), 1, RESULT_KEPT_S + 0.1);
        assert_eq!(
            asked,
            Some((1, Status::Unknown, String::new())),
            "forgotten after 10 s"
        );
        for n in 0..=RESULTS_KEPT {
            let key = (n as u32).to_le_bytes().to_vec();
            g.start(key.clone(), (1, 0), true);
            g.end(&key, Status::Aborted, n.to_string(), 20.0);
        }
        assert_eq!(g.ended.len(), RESULTS_KEPT);
        assert_eq!(
            g.ended.front().map(|e| e.result.as_str()),
            Some("1"),
            "the oldest went"
        );
        assert_eq!(
            g.statuses().len(),
            STATUS_ENDED,
            "the status lists the last ones"
        );
    }

    #[test]
    fn waiting_requests_are_bounded() {
        let mut g = Goals::default();
        g.start(id(1), (1, 0), true);
        for n in 0..WAITING_MAX as u32 {
            assert!(g.result(id(1), n, 0.0).is_none());
        }
        let over = g.result(id(1), 99, 0.0);
        assert_eq!(
            over,
            Some((99, Status::Unknown, String::new())),
            "answered at once"
        );
        assert_eq!(
            g.end(&id(1), Status::Succeeded, "hold".into(), 1.0).len(),
            WAITING_MAX
        );
    }

    #[test]
    fn a_cancel_names_one_goal_or_those_accepted_up_to_its_stamp() {
        let mut g = Goals::default();
        g.start(id(1), (1, 0), true);
        g.start(id(2), (5, 0), true);
        g.start(id(3), (9, 0), false);
        let heard = |c: &bool| *c;
        assert_eq!(
            g.cancel(&id(2), (0, 0), heard),
            CancelAnswer::Canceling(vec![(id(2), (5, 0))])
        );
        let CancelAnswer::Canceling(mut up_to) = g.cancel(&id(0), (5, 0), heard) else {
            panic!("a stamp names goals")
        };
        up_to.sort();
        assert_eq!(up_to, vec![(id(1), (1, 0)), (id(2), (5, 0))]);
        assert_eq!(
            g.cancel(&id(3), (0, 0), heard),
            CancelAnswer::Unknown,
            "not heard"
        );
        let status = |g: &Goals, n| g.statuses().into_iter().find(|s| s.0 == id(n)).map(|s| s.2);
        assert_eq!(status(&g, 2), Some(Status::Canceling));
        assert_eq!(status(&g, 3), Some(Status::Executing));
        g.end(&id(2), Status::Canceled, "canceled".into(), 1.0);
        assert_eq!(g.cancel(&id(2), (0, 0), heard), CancelAnswer::Ended);
        assert_eq!(g.cancel(&id(7), (0, 0), heard), CancelAnswer::Unknown);
    }
}
