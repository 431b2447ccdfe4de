//! The managed (lifecycle) node of ROS 2, whatever moves its requests (the
//! ROS side: `ros/lifecycle.rs`, with lifecycle_msgs): its states, the
//! transitions between them and what a node does on each ([`Managed`]).
//!
//! As rcl_lifecycle's default state machine (design.ros2.org, "Managed
//! nodes"): a node starts `unconfigured`; `configure` reads and checks its
//! parameters and opens what it needs (-> `inactive`); `activate` lets it
//! act (-> `active`); `deactivate` stops it acting (-> `inactive`);
//! `cleanup` lets go of what `configure` opened (-> `unconfigured`);
//! `shutdown`, from any of those three, ends it (-> `finalized`). A
//! transition passes through its transition state (`configuring`, ...);
//! one whose callback fails goes back to where it started.

use std::fmt;

/// A state of a managed node, with lifecycle_msgs/State's id and label.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum State {
    /// Created, nothing read or opened.
    Unconfigured,
    /// Configured, not acting.
    Inactive,
    /// Acting.
    Active,
    /// Ended; nothing more happens.
    Finalized,
    /// Between `unconfigured` and `inactive`.
    Configuring,
    /// Between `inactive` and `unconfigured`.
    CleaningUp,
    /// On the way to `finalized`.
    ShuttingDown,
    /// Between `inactive` and `active`.
    Activating,
    /// Between `active` and `inactive`.
    Deactivating,
}

impl State {
    /// Every state a node of this machine may be in.
    pub const ALL: [State; 9] = [
        State::Unconfigured,
        State::Inactive,
        State::Active,
        State::Finalized,
        State::Configuring,
        State::CleaningUp,
        State::ShuttingDown,
        State::Activating,
        State::Deactivating,
    ];

    /// lifecycle_msgs/State's id (`PRIMARY_STATE_*`, `TRANSITION_STATE_*`).
    pub fn id(self) -> u8 {
        match self {
            State::Unconfigured => 1,
            State::Inactive => 2,
            State::Active => 3,
            State::Finalized => 4,
            State::Configuring => 10,
            State::CleaningUp => 11,
            State::ShuttingDown => 12,
            State::Activating => 13,
            State::Deactivating => 14,
        }
    }

    /// Its label, as `ros2 lifecycle get` prints it.
    pub fn label(self) -> &'static str {
        match self {
            State::Unconfigured => "unconfigured",
            State::Inactive => "inactive",
            State::Active => "active",
            State::Finalized => "finalized",
            State::Configuring => "configuring",
            State::CleaningUp => "cleaningup",
            State::ShuttingDown => "shuttingdown",
            State::Activating => "activating",
            State::Deactivating => "deactivating",
        }
    }

    /// The state a node may start in (a parameter's value): unconfigured,
    /// inactive or active.
    pub fn start(name: &str) -> Result<State, String> {
        match name {
            "unconfigured" => Ok(State::Unconfigured),
            "inactive" => Ok(State::Inactive),
            "active" => Ok(State::Active),
            other => Err(format!(
                "{other:?}: expected unconfigured, inactive or active"
            )),
        }
    }
}

impl fmt::Display for State {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} [{}]", self.label(), self.id())
    }
}

/// A transition an operator asks for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Transition {
    /// unconfigured -> inactive.
    Configure,
    /// inactive -> unconfigured.
    Cleanup,
    /// inactive -> active.
    Activate,
    /// active -> inactive.
    Deactivate,
    /// unconfigured, inactive or active -> finalized.
    Shutdown,
}

impl Transition {
    const ALL: [Transition; 5] = [
        Transition::Configure,
        Transition::Cleanup,
        Transition::Activate,
        Transition::Deactivate,
        Transition::Shutdown,
    ];

    /// Its label (`ros2 lifecycle set NODE LABEL`).
    pub fn label(self) -> &'static str {
        match self {
            Transition::Configure => "configure",
            Transition::Cleanup => "cleanup",
            Transition::Activate => "activate",
            Transition::Deactivate => "deactivate",
            Transition::Shutdown => "shutdown",
        }
    }

    /// Where it may start, and its transition state.
    fn path(self) -> (&'static [State], State, State) {
        use State::*;
        match self {
            Transition::Configure => (&[Unconfigured], Configuring, Inactive),
            Transition::Cleanup => (&[Inactive], CleaningUp, Unconfigured),
            Transition::Activate => (&[Inactive], Activating, Active),
            Transition::Deactivate => (&[Active], Deactivating, Inactive),
            Transition::Shutdown => (&[Unconfigured, Inactive, Active], ShuttingDown, Finalized),
        }
    }

    /// lifecycle_msgs/Transition's id from `start` (`shutdown` has one per
    /// state it leaves: 5, 6, 7).
    pub fn id(self, start: State) -> u8 {
        match (self, start) {
            (Transition::Configure, _) => 1,
            (Transition::Cleanup, _) => 2,
            (Transition::Activate, _) => 3,
            (Transition::Deactivate, _) => 4,
            (Transition::Shutdown, State::Inactive) => 6,
            (Transition::Shutdown, State::Active) => 7,
            (Transition::Shutdown, _) => 5,
        }
    }

    /// The id of its callback's outcome (`ON_CONFIGURE_SUCCESS` 10, ...
    /// `ON_SHUTDOWN_FAILURE` 51).
    fn outcome_id(self, ok: bool) -> u8 {
        let base = match self {
            Transition::Configure => 10,
            Transition::Cleanup => 20,
            Transition::Activate => 30,
            Transition::Deactivate => 40,
            Transition::Shutdown => 50,
        };
        base + u8::from(!ok)
    }
}

/// What a managed node does on each transition; a callback that fails
/// says why, and the node stays where it was.
pub trait Managed {
    /// Reads and checks its parameters, opens what it needs.
    fn on_configure(&mut self) -> Result<(), String>;
    /// Lets go of what `on_configure` opened.
    fn on_cleanup(&mut self);
    /// Starts acting.
    fn on_activate(&mut self) -> Result<(), String>;
    /// Stops acting: a controller commands zero, its goals end.
    fn on_deactivate(&mut self);
    /// Ends, from the state it is in.
    fn on_shutdown(&mut self, from: State);
}

/// One step of a transition (lifecycle_msgs/TransitionEvent, unstamped).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Event {
    /// The transition's id.
    pub id: u8,
    /// Its label (a callback's outcome: `transition_success`, `transition_failure`).
    pub label: &'static str,
    /// Where the step started.
    pub start: State,
    /// Where it ended.
    pub goal: State,
}

/// A transition open from a state (lifecycle_msgs/TransitionDescription).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Available {
    /// The transition's id from `start`.
    pub id: u8,
    /// Its label.
    pub label: &'static str,
    /// Where it starts.
    pub start: State,
    /// Its transition state.
    pub goal: State,
}

/// A node's place in the state machine.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Lifecycle {
    state: State,
}

impl Default for Lifecycle {
    fn default() -> Self {
        Lifecycle {
            state: State::Unconfigured,
        }
    }
}

impl Lifecycle {
    /// The state it is in.
    pub fn state(&self) -> State {
        self.state
    }

    /// The transitions open from here.
    pub fn available(&self) -> Vec<Available> {
        Transition::ALL
            .into_iter()
            .filter(|t| t.path().0.contains(&self.state))
            .map(|t| Available {
                id: t.id(self.state),
                label: t.label(),
                start: self.state,
                goal: t.path().1,
            })
            .collect()
    }

    /// Every transition of the machine, from each state it may start in
    /// (`~/get_transition_graph`).
    pub fn graph() -> Vec<Available> {
        [State::Unconfigured, State::Inactive, State::Active]
            .into_iter()
            .flat_map(|state| Lifecycle { state }.available())
            .collect()
    }

    /// The transition asked by its id (when not 0) or else its label, if
    /// it is open from here.
    pub fn find(&self, id: u8, label: &str) -> Result<Transition, String> {
        let asked = |t: &Transition| match id {
            0 => t.label() == label,
            id => t.id(self.state) == id,
        };
        let found = Transition::ALL.into_iter().find(asked);
        match found {
            Some(t) if t.path().0.contains(&self.state) => Ok(t),
            _ => {
                let open: Vec<_> = self.available().iter().map(|a| a.label).collect();
                let what = if id == 0 {
                    label.to_string()
                } else {
                    format!("id {id}")
                };
                Err(format!(
                    "transition {what} is not open from {} (open: {})",
                    self.state,
                    if open.is_empty() {
                        "none".into()
                    } else {
                        open.join(", ")
                    }
                ))
            }
        }
    }

    /// Runs `t` on `node` (open from here: [`Lifecycle::find`]): the
    /// events it went through, and Err with the callback's reason when it
    /// failed (back where it started).
    pub fn change(
        &mut self,
        t: Transition,
        node: &mut dyn Managed,
    ) -> (Vec<Event>, Result<(), String>) {
        let start = self.state;
        let (_, via, goal) = t.path();
        let result = match t {
            Transition::Configure => node.on_configure(),
            Transition::Cleanup => {
                node.on_cleanup();
                Ok(())
            }
            Transition::Activate => node.on_activate(),
            Transition::Deactivate => {
                node.on_deactivate();
                Ok(())
            }
            Transition::Shutdown => {
                node.on_shutdown(start);
                Ok(())
            }
        };
        let (label, end) = match result {
            Ok(()) => ("transition_success", goal),
            Err(_) => ("transition_failure", start),
        };
        self.state = end;
        let events = vec![
            Event {
                id: t.id(start),
                label: t.label(),
                start,
                goal: via,
            },
            Event {
                id: t.outcome_id(result.is_ok()),
                label,
                start: via,
                goal: end,
            },
        ];
        (events, result)
    }

    /// Brings `node` from `unconfigured` to `target` (unconfigured,
    /// inactive or active) at start-up; the events on the way, or why it
    /// stopped short (where it stands says how far it went).
    pub fn start(
        &mut self,
        target: State,
        node: &mut dyn Managed,
    ) -> (Vec<Event>, Result<(), String>) {
        let steps: &[Transition] = match target {
            State::Inactive => &[Transition::Configure],
            State::Active => &[Transition::Configure, Transition::Activate],
            _ => &[],
        };
        let mut events = Vec::new();
        for &t in steps {
            let (mut e, result) = self.change(t, node);
            events.append(&mut e);
            if let Err(why) = result {
                return (events, Err(format!("{}: {why}", t.label())));
            }
        }
        (events, Ok(()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A node that records its callbacks, failing those named in `fail`.
    #[derive(Default)]
    struct Recorder {
        calls: Vec<String>,
        fail: Vec<&'static str>,
    }

    impl Recorder {
        fn call(&mut self, name: &'static str) -> Result<(), String> {
            self.calls.push(name.into());
            match self.fail.contains(&name) {
                true => Err(format!("{name} refused")),
                false => Ok(()),
            }
        }
    }

    impl Managed for Recorder {
        fn on_configure(&mut self) -> Result<(), String> {
            self.call("configure")
        }
        fn on_cleanup(&mut self) {
            self.calls.push("cleanup".into());
        }
        fn on_activate(&mut self) -> Result<(), String> {
            self.call("activate")
        }
        fn on_deactivate(&mut self) {
            self.calls.push("deactivate".into());
        }
        fn on_shutdown(&mut self, from: State) {
            self.calls.push(format!("shutdown from {}", from.label()));
        }
    }

    fn run(l: &mut Lifecycle, node: &mut Recorder, label: &str) -> Result<(), String> {
        let t = l.find(0, label)?;
        l.change(t, node).1
    }

    #[test]
    fn a_node_goes_round_the_primary_states_and_ends_finalized() {
        let (mut l, mut n) = (Lifecycle::default(), Recorder::default());
        assert_eq!(l.state(), State::Unconfigured);
        for (label, then) in [
            ("configure", State::Inactive),
            ("activate", State::Active),
            ("deactivate", State::Inactive),
            ("cleanup", State::Unconfigured),
            ("configure", State::Inactive),
            ("activate", State::Active),
            ("shutdown", State::Finalized),
        ] {
            run(&mut l, &mut n, label).unwrap();
            assert_eq!(l.state(), then, "after {label}");
        }
        assert_eq!(n.calls.last().unwrap(), "shutdown from active");
        assert!(l.available().is_empty());
        let e = run(&mut l, &mut n, "configure").unwrap_err();
        assert!(
            e.contains("not open from finalized [4] (open: none)"),
            "{e}"
        );
    }

    #[test]
    fn only_the_transitions_of_the_state_are_open_with_rcl_ids() {
        let (mut l, mut n) = (Lifecycle::default(), Recorder::default());
        let open = |l: &Lifecycle| {
            l.available()
                .iter()
                .map(|a| (a.id, a.label, a.goal.id()))
                .collect::<Vec<_>>()
        };
        assert_eq!(open(&l), [(1, "configure", 10), (5, "shutdown", 12)]);
        let e = run(&mut l, &mut n, "activate").unwrap_err();
        assert!(
            e.contains("activate is not open from unconfigured [1] (open: configure, shutdown)"),
            "{e}"
        );
        assert!(n.calls.is_empty(), "a refused transition calls nothing");
        run(&mut l, &mut n, "configure").unwrap();
        assert_eq!(
            open(&l),
            [(2, "cleanup", 11), (3, "activate", 13), (6, "shutdown", 12)]
        );
        // By id, as `ros2 lifecycle set` sends it: 7 is shutdown from active only.
        assert!(l.find(7, "").is_err());
        let ids: Vec<u8> = Lifecycle::graph().iter().map(|a| a.id).collect();
        assert_eq!(ids, [1, 5, 2, 3, 6, 4, 7]);
        assert_eq!(l.find(6, "").unwrap(), Transition::Shutdown);
        assert_eq!(
            l.find(3, "ignored when the id is set").unwrap(),
            Transition::Activate
        );
    }

    #[test]
    fn a_failed_callback_leaves_the_node_where_it_was_and_says_why() {
        let mut n = Recorder {
            fail: vec!["configure"],
            ..Recorder::default()
        };
        let mut l = Lifecycle::default();
        let t = l.find(0, "configure").unwrap();
        let (events, result) = l.change(t, &mut n);
        assert_eq!(result.unwrap_err(), "configure refused");
        assert_eq!(l.state(), State::Unconfigured);
        let steps: Vec<_> = events
            .iter()
            .map(|e| (e.id, e.label, e.start, e.goal))
            .collect();
        assert_eq!(
            steps,
            [
                (1, "configure", State::Unconfigured, State::Configuring),
                (
                    11,
                    "transition_failure",
                    State::Configuring,
                    State::Unconfigured
                ),
            ]
        );
    }

    #[test]
    fn a_start_goes_as_far_as_asked_and_stops_at_a_failure() {
        let (mut l, mut n) = (Lifecycle::default(), Recorder::default());
        let (events, r) = l.start(State::Active, &mut n);
        r.unwrap();
        assert_eq!(l.state(), State::Active);
        assert_eq!(events.len(), 4);
        assert_eq!(events[3].id, 30);
        let mut l = Lifecycle::default();
        l.start(State::Unconfigured, &mut n).1.unwrap();
        assert_eq!(l.state(), State::Unconfigured);
        let mut failing = Recorder {
            fail: vec!["activate"],
            ..Recorder::default()
        };
        let e = l.start(State::Active, &mut failing).1.unwrap_err();
        assert_eq!(e, "activate: activate refused");
        assert_eq!(l.state(), State::Inactive);
        assert_eq!(State::start("inactive"), Ok(State::Inactive));
        assert!(State::start("finalized")
            .unwrap_err()
            .contains("expected unconfigured"));
    }
}
