//! A goal request as the server hands it to the node, and the handle of a
//! goal accepted: its feedback and its end.

use futures::channel::mpsc;
use r2r::action_msgs::msg::GoalInfo;
use r2r::ServiceRequest;

use super::{code, Served, Shared};
use crate::nodes::action_goals::Status;
use crate::ros::lock;
use crate::ros::RosError;

/// A goal sent, not yet answered.
pub struct GoalRequest<T: Served> {
    /// The goal.
    pub goal: T::Goal,
    pub(super) info: GoalInfo,
    pub(super) request: ServiceRequest<T::SendGoal>,
    pub(super) server: Shared<T>,
}

impl<T: Served> GoalRequest<T> {
    /// Accepts the goal: it runs (executing) until its handle ends it; the
    /// cancel requests it gets.
    pub fn accept(
        self,
    ) -> Result<(GoalHandle<T>, mpsc::UnboundedReceiver<CancelRequest>), RosError> {
        let (cancel, requests) = mpsc::unbounded();
        // Under the lock: a result request for the goal waits until it runs.
        let mut server = lock(&self.server);
        self.request
            .respond(T::make_goal_response_msg(true, self.info.stamp.clone()))?;
        let stamp = (self.info.stamp.sec, self.info.stamp.nanosec);
        server
            .goals
            .start(self.info.goal_id.uuid.clone(), stamp, cancel);
        server.publish_status();
        drop(server);
        let handle = GoalHandle {
            info: self.info,
            server: self.server,
            ended: false,
        };
        Ok((handle, requests))
    }
}

/// A client asked to cancel its goal (already accepted: the goal is
/// canceling).
pub struct CancelRequest;

/// A goal running: its feedback and its end. Dropped without an end, the
/// goal ends aborted.
pub struct GoalHandle<T: Served> {
    info: GoalInfo,
    server: Shared<T>,
    ended: bool,
}

impl<T: Served> GoalHandle<T> {
    /// Publishes feedback on the goal.
    pub fn publish_feedback(&self, feedback: T::Feedback) -> Result<(), RosError> {
        let message = T::make_feedback_msg(self.info.goal_id.clone(), feedback);
        Ok(lock(&self.server).feedback.publish(&message)?)
    }

    /// Ends the goal succeeded with `result`.
    pub fn succeed(&mut self, result: T::Result) {
        self.end(Status::Succeeded, result);
    }

    /// Ends the goal aborted with `result`.
    pub fn abort(&mut self, result: T::Result) {
        self.end(Status::Aborted, result);
    }

    /// Ends the goal canceled with `result`.
    pub fn cancel(&mut self, result: T::Result) {
        self.end(Status::Canceled, result);
    }

    fn end(&mut self, status: Status, result: T::Result) {
        if std::mem::replace(&mut self.ended, true) {
            return;
        }
        let mut server = lock(&self.server);
        let now_s = server.start.elapsed().as_secs_f64();
        let id = &self.info.goal_id.uuid;
        for request in server.goals.end(id, status, result.clone(), now_s) {
            let _ = request.respond(T::make_result_response_msg(code(status), result.clone()));
        }
        server.publish_status();
    }
}

impl<T: Served> Drop for GoalHandle<T> {
    fn drop(&mut self) {
        self.end(Status::Aborted, T::Result::default());
    }
}
