//! The goals an action server knows: those running, the results of those
//! that ended (kept for [`RESULT_KEPT`], at most [`RESULTS_KEPT`]), the
//! result requests waiting for a goal to end, and the status and feedback
//! topics.

use std::collections::{HashMap, VecDeque};
use std::time::Instant;

use futures::channel::mpsc;
use r2r::action_msgs::msg::{GoalInfo, GoalStatus, GoalStatusArray};
use r2r::action_msgs::srv::CancelGoal;
use r2r::builtin_interfaces::msg::Time;
use r2r::GoalStatus as Status;
use r2r::ServiceRequest;

use super::{CancelRequest, GetResult, Served, RESULTS_KEPT, RESULT_KEPT};
use crate::ros::RosError;

/// The ended goals the status topic lists (the last ones), beside those
/// running: a flood of refused goals does not grow each status message.
const STATUS_ENDED: usize = 16;
/// The most result requests that wait for goals to end; one more is
/// answered at once, with the status unknown.
const WAITING_MAX: usize = 64;

/// A goal's result as a client asks for it.
struct Ended<T: Served> {
    info: GoalInfo,
    status: i8,
    result: T::Result,
    at: Instant,
}

/// A goal running: its status and where its cancel goes.
struct Running {
    info: GoalInfo,
    status: i8,
    cancel: mpsc::UnboundedSender<CancelRequest>,
}

/// The goals the server knows and its two topics.
pub(super) struct Server<T: Served> {
    running: HashMap<Vec<u8>, Running>,
    ended: VecDeque<Ended<T>>,
    asked: Vec<(Vec<u8>, ServiceRequest<GetResult<T>>)>,
    status: r2r::Publisher<GoalStatusArray>,
    feedback: r2r::Publisher<T::FeedbackMessage>,
}

impl<T: Served> Server<T> {
    /// No goal yet, the status and feedback publishers.
    pub(super) fn new(
        status: r2r::Publisher<GoalStatusArray>,
        feedback: r2r::Publisher<T::FeedbackMessage>,
    ) -> Self {
        Server {
            running: HashMap::new(),
            ended: VecDeque::new(),
            asked: Vec::new(),
            status,
            feedback,
        }
    }

    /// A goal accepted: it runs (executing); its cancels go to `cancel`.
    pub(super) fn start(&mut self, info: GoalInfo, cancel: mpsc::UnboundedSender<CancelRequest>) {
        let key = info.goal_id.uuid.clone();
        let status = Status::Executing.to_rcl();
        self.running.insert(
            key,
            Running {
                info,
                status,
                cancel,
            },
        );
        self.publish_status();
    }

    /// Publishes a goal's feedback.
    pub(super) fn feedback(&self, message: &T::FeedbackMessage) -> Result<(), RosError> {
        Ok(self.feedback.publish(message)?)
    }

    /// The goals a cancel request names (one, or every one accepted up to
    /// its stamp when its id is zero, all when the stamp is zero too)
    /// that still run, set canceling.
    pub(super) fn cancel(&mut self, asked: &GoalInfo) -> CancelGoal::Response {
        let all = asked.goal_id.uuid.iter().all(|b| *b == 0);
        let stamp = |t: &Time| (t.sec, t.nanosec);
        let until = stamp(&asked.stamp);
        let mut canceling = Vec::new();
        for (id, goal) in &mut self.running {
            let named = if all {
                until == (0, 0) || stamp(&goal.info.stamp) <= until
            } else {
                *id == asked.goal_id.uuid
            };
            if named && goal.cancel.unbounded_send(CancelRequest).is_ok() {
                goal.status = Status::Canceling.to_rcl();
                canceling.push(goal.info.clone());
            }
        }
        let ended = self.ended.iter().any(|e| e.info.goal_id == asked.goal_id);
        let return_code = match () {
            _ if !canceling.is_empty() || all => CancelGoal::Response::ERROR_NONE as i8,
            _ if ended => CancelGoal::Response::ERROR_GOAL_TERMINATED as i8,
            _ => CancelGoal::Response::ERROR_UNKNOWN_GOAL_ID as i8,
        };
        if !canceling.is_empty() {
            self.publish_status();
        }
        CancelGoal::Response {
            return_code,
            goals_canceling: canceling,
        }
    }

    /// Answers a result request: at once for a goal that ended (unknown
    /// for one the server does not know), when it ends for one running
    /// (while fewer than [`WAITING_MAX`] wait).
    pub(super) fn result(&mut self, id: Vec<u8>, request: ServiceRequest<GetResult<T>>) {
        self.forget_old();
        if self.running.contains_key(&id) && self.asked.len() < WAITING_MAX {
            self.asked.push((id, request));
            return;
        }
        let answer = match self.ended.iter().find(|e| e.info.goal_id.uuid == id) {
            Some(e) => T::make_result_response_msg(e.status, e.result.clone()),
            None => T::make_result_response_msg(Status::Unknown.to_rcl(), Default::default()),
        };
        let _ = request.respond(answer);
    }

    /// A goal ended: its result kept, and sent to the clients that asked.
    pub(super) fn end(&mut self, info: &GoalInfo, status: i8, result: T::Result) {
        let id = &info.goal_id.uuid;
        self.running.remove(id);
        for (_, request) in self.asked.extract_if(.., |(asked, _)| asked == id) {
            let _ = request.respond(T::make_result_response_msg(status, result.clone()));
        }
        self.forget_old();
        if self.ended.len() == RESULTS_KEPT {
            self.ended.pop_front();
        }
        self.ended.push_back(Ended {
            info: info.clone(),
            status,
            result,
            at: Instant::now(),
        });
        self.publish_status();
    }

    /// Forgets the results kept longer than [`RESULT_KEPT`].
    fn forget_old(&mut self) {
        while self
            .ended
            .front()
            .is_some_and(|e| e.at.elapsed() > RESULT_KEPT)
        {
            self.ended.pop_front();
        }
    }

    /// The status of the goals running and of the last [`STATUS_ENDED`]
    /// that ended, on the status topic.
    fn publish_status(&mut self) {
        self.forget_old();
        let running = self.running.values().map(|g| (&g.info, g.status));
        let ended = self.ended.iter().rev().take(STATUS_ENDED);
        let ended = ended.map(|e| (&e.info, e.status));
        let status_list = running
            .chain(ended)
            .map(|(info, status)| GoalStatus {
                goal_info: info.clone(),
                status,
            })
            .collect();
        let _ = self.status.publish(&GoalStatusArray { status_list });
    }
}
