//! A ROS 2 action server made of r2r's services and publishers: the
//! protocol rcl_action serves (`<name>/_action/send_goal`, `cancel_goal`
//! and `get_result`, the topics `feedback` and `status`), in place of r2r
//! 0.9.7's own server, which keeps an entry for every goal request,
//! accepted or rejected, for the node's life (375 bytes each), and never
//! expires a finished goal, so that its wait set stays ready and the spin
//! loop turns at once (r2r issue #136). Here a goal is held while it runs
//! and its result for [`RESULT_KEPT`] after (at most [`RESULTS_KEPT`]).
//! Every goal is accepted (one the node refuses ends aborted at once, its
//! reason in its result), and a cancel is accepted for any goal still
//! running (the controller's goals withdraw on every cancel).

use std::sync::{Arc, Mutex};
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use futures::channel::mpsc;
use futures::StreamExt;
use r2r::action_msgs::msg::GoalInfo;
use r2r::action_msgs::srv::CancelGoal;
use r2r::builtin_interfaces::msg::Time;
use r2r::GoalStatus as Status;
use r2r::{QosProfile, ServiceRequest, WrappedActionTypeSupport as Action};

use super::RosError;
use goals::Server;

mod goals;

/// How long a finished goal's result waits for its client (rcl_action's
/// default result timeout in Jazzy).
pub const RESULT_KEPT: Duration = Duration::from_secs(10);
/// The most finished goals whose results are kept: ten seconds of goals
/// at 100 a second.
pub const RESULTS_KEPT: usize = 1000;

type GetResult<T> = <T as Action>::GetResult;

/// An action type whose messages the server's tasks may take.
pub trait Served:
    Action<
        Goal: Send,
        Result: Send,
        SendGoal: 'static,
        GetResult: 'static,
        FeedbackMessage: 'static,
    > + 'static
{
}

impl<T> Served for T where
    T: Action<
            Goal: Send,
            Result: Send,
            SendGoal: 'static,
            GetResult: 'static,
            FeedbackMessage: 'static,
        > + 'static
{
}

type Shared<T> = Arc<Mutex<Server<T>>>;

/// The goal requests sent to action `name` of `node`, each to be
/// accepted; the services are answered on tasks of their own.
pub fn create<T: Served>(
    node: &mut r2r::Node,
    name: &str,
) -> Result<mpsc::UnboundedReceiver<GoalRequest<T>>, RosError> {
    let services = QosProfile::services_default();
    let status_qos = QosProfile::default().keep_last(1).transient_local();
    let server = Arc::new(Mutex::new(Server::<T>::new(
        node.create_publisher(&format!("{name}/_action/status"), status_qos)?,
        node.create_publisher(&format!("{name}/_action/feedback"), QosProfile::default())?,
    )));
    let mut goals =
        node.create_service::<T::SendGoal>(&format!("{name}/_action/send_goal"), services.clone())?;
    let mut cancels = node.create_service::<CancelGoal::Service>(
        &format!("{name}/_action/cancel_goal"),
        services.clone(),
    )?;
    let mut results =
        node.create_service::<GetResult<T>>(&format!("{name}/_action/get_result"), services)?;
    let (requests, out) = mpsc::unbounded();
    let s = server.clone();
    tokio::spawn(async move {
        while let Some(request) = goals.next().await {
            let (id, goal) = T::destructure_goal_request_msg(request.message.clone());
            let info = GoalInfo {
                goal_id: id,
                stamp: now(),
            };
            let server = s.clone();
            if requests
                .unbounded_send(GoalRequest {
                    goal,
                    info,
                    request,
                    server,
                })
                .is_err()
            {
                return;
            }
        }
    });
    let s = server.clone();
    tokio::spawn(async move {
        while let Some(request) = cancels.next().await {
            let response = lock(&s).cancel(&request.message.goal_info);
            let _ = request.respond(response);
        }
    });
    tokio::spawn(async move {
        while let Some(request) = results.next().await {
            let id = T::destructure_result_request_msg(request.message.clone()).uuid;
            lock(&server).result(id, request);
        }
    });
    Ok(out)
}

/// A goal sent, not yet answered.
pub struct GoalRequest<T: Served> {
    /// The goal.
    pub goal: T::Goal,
    info: GoalInfo,
    request: ServiceRequest<T::SendGoal>,
    server: Shared<T>,
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
        server.start(self.info.clone(), cancel);
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
        lock(&self.server).feedback(&message)
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
        if !std::mem::replace(&mut self.ended, true) {
            lock(&self.server).end(&self.info, status.to_rcl(), result);
        }
    }
}

impl<T: Served> Drop for GoalHandle<T> {
    fn drop(&mut self) {
        self.end(Status::Aborted, T::Result::default());
    }
}

/// The lock of `m`, also after a panic while another held it.
fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

/// The wall clock as a ROS time stamp.
fn now() -> Time {
    let t = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .unwrap_or_default();
    Time {
        sec: i32::try_from(t.as_secs()).unwrap_or(i32::MAX),
        nanosec: t.subsec_nanos(),
    }
}
