//! A managed node's lifecycle services and topic (lifecycle_msgs; r2r has
//! no lifecycle node, so this serves them on its services, as rclcpp's
//! LifecycleNode does): `~/change_state`, `~/get_state`,
//! `~/get_available_states`, `~/get_available_transitions`,
//! `~/get_transition_graph` and `~/transition_event`, so that
//! `ros2 lifecycle get|list|set` and a launch file's lifecycle events work.
//! The state machine and the callbacks are the node's
//! ([`crate::nodes::lifecycle`]); this moves their messages.

use std::sync::{Arc, Mutex};

use futures::StreamExt;
use r2r::lifecycle_msgs::msg::{
    State as StateMsg, Transition as TransitionMsg, TransitionDescription, TransitionEvent,
};
use r2r::lifecycle_msgs::srv::{
    ChangeState, GetAvailableStates, GetAvailableTransitions, GetState,
};
use r2r::QosProfile;

use super::{lock, RosError};
use crate::nodes::lifecycle::{Available, Event, Lifecycle, Managed, State};

/// A managed node: its lifecycle and its callbacks, shared by the services.
pub struct Managing<M> {
    lifecycle: Lifecycle,
    node: M,
    events: r2r::Publisher<TransitionEvent>,
}

impl<M: Managed> Managing<M> {
    /// The state it is in.
    pub fn state(&self) -> State {
        self.lifecycle.state()
    }

    /// Runs the transition of `id` (else `label`), publishing its events;
    /// Err says why it was not open or failed.
    pub fn change(&mut self, id: u8, label: &str) -> Result<(), String> {
        let t = self.lifecycle.find(id, label)?;
        let (events, result) = self.lifecycle.change(t, &mut self.node);
        self.publish(&events);
        result
    }

    /// Brings the node to `target` at start-up (logged when it stops short).
    fn start(&mut self, target: State) {
        let (events, result) = self.lifecycle.start(target, &mut self.node);
        self.publish(&events);
        match result {
            Ok(()) => tracing::info!("lifecycle: {}", self.state()),
            Err(why) => tracing::error!(
                "lifecycle: {why}; {} (asked {})",
                self.state(),
                target.label()
            ),
        }
    }

    fn publish(&self, events: &[Event]) {
        let nanos = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_nanos() as u64);
        for e in events {
            tracing::info!("lifecycle: {} -> {} ({})", e.start, e.goal, e.label);
            let msg = TransitionEvent {
                timestamp: nanos,
                transition: TransitionMsg {
                    id: e.id,
                    label: e.label.into(),
                },
                start_state: state_msg(e.start),
                goal_state: state_msg(e.goal),
            };
            if let Err(err) = self.events.publish(&msg) {
                tracing::warn!("transition_event: {err}");
            }
        }
    }
}

fn state_msg(s: State) -> StateMsg {
    StateMsg {
        id: s.id(),
        label: s.label().into(),
    }
}

fn description(a: &Available) -> TransitionDescription {
    TransitionDescription {
        transition: TransitionMsg {
            id: a.id,
            label: a.label.into(),
        },
        start_state: state_msg(a.start),
        goal_state: state_msg(a.goal),
    }
}

/// Serves `node`'s lifecycle on `ros`, and brings it to `start`; the
/// shared handle the node's other paths read its state from.
pub fn serve<M: Managed + Send + 'static>(
    ros: &mut r2r::Node,
    node: M,
    start: State,
) -> Result<Arc<Mutex<Managing<M>>>, RosError> {
    let qos = QosProfile::services_default;
    let events = ros.create_publisher("~/transition_event", QosProfile::default())?;
    let shared = Arc::new(Mutex::new(Managing {
        lifecycle: Lifecycle::default(),
        node,
        events,
    }));
    let mut change = ros.create_service::<ChangeState::Service>("~/change_state", qos())?;
    let mut get = ros.create_service::<GetState::Service>("~/get_state", qos())?;
    let mut states =
        ros.create_service::<GetAvailableStates::Service>("~/get_available_states", qos())?;
    let mut open = ros
        .create_service::<GetAvailableTransitions::Service>("~/get_available_transitions", qos())?;
    let mut graph =
        ros.create_service::<GetAvailableTransitions::Service>("~/get_transition_graph", qos())?;
    let s = shared.clone();
    tokio::spawn(async move {
        while let Some(req) = change.next().await {
            let t = &req.message.transition;
            let result = lock(&s).change(t.id, &t.label);
            if let Err(why) = &result {
                tracing::warn!("lifecycle: {why}");
            }
            let _ = req.respond(ChangeState::Response {
                success: result.is_ok(),
            });
        }
    });
    let s = shared.clone();
    tokio::spawn(async move {
        while let Some(req) = get.next().await {
            let current_state = state_msg(lock(&s).state());
            let _ = req.respond(GetState::Response { current_state });
        }
    });
    tokio::spawn(async move {
        while let Some(req) = states.next().await {
            let available_states = State::ALL.into_iter().map(state_msg).collect();
            let _ = req.respond(GetAvailableStates::Response { available_states });
        }
    });
    let s = shared.clone();
    tokio::spawn(async move {
        while let Some(req) = open.next().await {
            let available = lock(&s).lifecycle.available();
            let available_transitions = available.iter().map(description).collect();
            let _ = req.respond(GetAvailableTransitions::Response {
                available_transitions,
            });
        }
    });
    tokio::spawn(async move {
        while let Some(req) = graph.next().await {
            let available_transitions = Lifecycle::graph().iter().map(description).collect();
            let _ = req.respond(GetAvailableTransitions::Response {
                available_transitions,
            });
        }
    });
    lock(&shared).start(start);
    Ok(shared)
}
