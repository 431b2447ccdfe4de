//! A ROS 2 action server made of r2r's services and publishers: the
//! protocol rcl_action serves (`<name>/_action/send_goal`, `cancel_goal`
//! and `get_result`, the topics `feedback` and `status`), in place of r2r
//! 0.9.7's own server, which keeps an entry for every goal request,
//! accepted or rejected, for the node's life (375 bytes each), and never
//! expires a finished goal, so that its wait set stays ready and the spin
//! loop turns at once (r2r issue #136). The goals and results it keeps,
//! each for a bounded time: [`ActionGoals`]. Every goal is accepted (one
//! the node refuses ends aborted at once, its reason in its result), and a
//! cancel is accepted for any goal still running (the controller's goals
//! withdraw on every cancel).

use std::sync::{Arc, Mutex};
use std::time::{Instant, SystemTime, UNIX_EPOCH};

use futures::channel::mpsc;
use futures::StreamExt;
use r2r::action_msgs::msg::{GoalInfo, GoalStatus, GoalStatusArray};
use r2r::action_msgs::srv::CancelGoal;
use r2r::builtin_interfaces::msg::Time;
use r2r::unique_identifier_msgs::msg::UUID;
use r2r::{QosProfile, ServiceRequest, WrappedActionTypeSupport as Action};

use super::{lock, RosError};
use crate::nodes::action_goals::{ActionGoals, CancelAnswer, Status};
pub use goal::{CancelRequest, GoalHandle, GoalRequest};

mod goal;

type GetResult<T> = <T as Action>::GetResult;

/// An action type whose messages the server's tasks may take (each
/// action the package serves says so: src/ros/force_controller.rs).
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

/// The goals and the two topics of one server.
struct Server<T: Served> {
    goals:
        ActionGoals<T::Result, ServiceRequest<GetResult<T>>, mpsc::UnboundedSender<CancelRequest>>,
    status: r2r::Publisher<GoalStatusArray>,
    feedback: r2r::Publisher<T::FeedbackMessage>,
    /// The server's start: the goals' clock.
    start: Instant,
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
    let server = Arc::new(Mutex::new(Server::<T> {
        goals: ActionGoals::default(),
        status: node.create_publisher(&format!("{name}/_action/status"), status_qos)?,
        feedback: node
            .create_publisher(&format!("{name}/_action/feedback"), QosProfile::default())?,
        start: Instant::now(),
    }));
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
            let mut server = lock(&server);
            let now_s = server.start.elapsed().as_secs_f64();
            if let Some((request, status, result)) = server.goals.result(id, request, now_s) {
                let _ = request.respond(T::make_result_response_msg(code(status), result));
            }
        }
    });
    Ok(out)
}

impl<T: Served> Server<T> {
    /// Sets the goals a cancel request names canceling, and its answer.
    fn cancel(&mut self, asked: &GoalInfo) -> CancelGoal::Response {
        let stamp = (asked.stamp.sec, asked.stamp.nanosec);
        let heard =
            |c: &mpsc::UnboundedSender<CancelRequest>| c.unbounded_send(CancelRequest).is_ok();
        let (return_code, canceling) = match self.goals.cancel(&asked.goal_id.uuid, stamp, heard) {
            CancelAnswer::Canceling(goals) => (CancelGoal::Response::ERROR_NONE as i8, goals),
            CancelAnswer::Ended => (CancelGoal::Response::ERROR_GOAL_TERMINATED as i8, vec![]),
            CancelAnswer::Unknown => (CancelGoal::Response::ERROR_UNKNOWN_GOAL_ID as i8, vec![]),
        };
        if !canceling.is_empty() {
            self.publish_status();
        }
        let goals_canceling = canceling
            .into_iter()
            .map(|(id, stamp)| info(id, stamp))
            .collect();
        CancelGoal::Response {
            return_code,
            goals_canceling,
        }
    }

    /// The goals' status on the status topic.
    fn publish_status(&self) {
        let status_list = (self.goals.statuses().into_iter())
            .map(|(id, stamp, status)| GoalStatus {
                goal_info: info(id, stamp),
                status: code(status),
            })
            .collect();
        let _ = self.status.publish(&GoalStatusArray { status_list });
    }
}

/// A goal's id and stamp as the protocol carries them.
fn info(id: Vec<u8>, (sec, nanosec): (i32, u32)) -> GoalInfo {
    GoalInfo {
        goal_id: UUID { uuid: id },
        stamp: Time { sec, nanosec },
    }
}

/// A status as the protocol codes it.
fn code(status: Status) -> i8 {
    let status = match status {
        Status::Unknown => r2r::GoalStatus::Unknown,
        Status::Executing => r2r::GoalStatus::Executing,
        Status::Canceling => r2r::GoalStatus::Canceling,
        Status::Succeeded => r2r::GoalStatus::Succeeded,
        Status::Canceled => r2r::GoalStatus::Canceled,
        Status::Aborted => r2r::GoalStatus::Aborted,
    };
    status.to_rcl()
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
