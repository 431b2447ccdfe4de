//! `force_controller`'s command outputs: the joint velocities
//! (`velocity_controller/commands`) or the twist (`twist_commands`) of each
//! step, and the zero command every way out publishes on both (a signal,
//! `~/stop`, a deactivation, a panic in any thread, a fatal error): a real
//! arm's velocity controller keeps the last command it got.
//!
//! Each command and each zero is sent under one lock, so that a zero is
//! never overtaken by the command of a step that ran before it; after the
//! last zero (the node ending) nothing else is sent. The zero a panic
//! sends takes no other lock (the panicking thread may hold one) and waits
//! for this one at most [`ZERO_WAIT`].

use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Mutex, TryLockError};
use std::time::{Duration, Instant};

use r2r::geometry_msgs::msg::TwistStamped;
use r2r::std_msgs::msg::Float64MultiArray;
use r2r::QosProfile;

use crate::kinematics::{JointVector, Twist};
use crate::nodes::force_controller::{CommandInterface, ForceControllerNode};
use crate::ros::{convert, lock, RosError};

/// How long a panic's zero waits for a command being sent.
const ZERO_WAIT: Duration = Duration::from_millis(20);

/// The publishers, and what a zero needs to know of the arm last
/// commanded: its joints and base link.
struct Outputs {
    joints: r2r::Publisher<Float64MultiArray>,
    twists: r2r::Publisher<TwistStamped>,
    dof: usize,
    base: String,
}

/// The command publishers.
pub(super) struct Commands {
    interface: CommandInterface,
    /// Held while a command or a zero is sent.
    sending: Mutex<Outputs>,
    /// The same publishers for a panic's zero when the panicking thread
    /// holds `sending`; only that zero takes this lock.
    spare: Mutex<Outputs>,
    /// The joints last commanded, for that zero.
    dof: AtomicUsize,
    /// Set by the last zero: nothing more is sent.
    ended: AtomicBool,
}

impl Commands {
    /// Advertises both outputs; the node commands on `interface`.
    pub(super) fn create(
        node: &mut r2r::Node,
        interface: CommandInterface,
    ) -> Result<Self, RosError> {
        let joints =
            node.create_publisher("velocity_controller/commands", QosProfile::default())?;
        let twists = node.create_publisher("twist_commands", QosProfile::default())?;
        let outputs = |joints, twists| Outputs {
            joints,
            twists,
            dof: 0,
            base: String::new(),
        };
        Ok(Commands {
            interface,
            spare: Mutex::new(outputs(joints.clone(), twists.clone())),
            sending: Mutex::new(outputs(joints, twists)),
            dof: AtomicUsize::new(0),
            ended: AtomicBool::new(false),
        })
    }

    /// Publishes the command of the node's last step.
    pub(super) fn publish(&self, n: &ForceControllerNode, now: f64) {
        let Some(c) = n.controller() else { return };
        let mut out = lock(&self.sending);
        if self.ended.load(Ordering::SeqCst) {
            return;
        }
        self.remember(&mut out, c.command().len(), &c.robot().links.0);
        let sent = match self.interface {
            CommandInterface::JointVelocities => {
                out.joints.publish(&convert::commands_msg(c.command()))
            }
            CommandInterface::Twist => {
                out.twists
                    .publish(&convert::twist_msg(now, &out.base, c.twist()))
            }
        };
        if let Err(e) = sent {
            tracing::warn!("command: {e}");
        }
        // A panic's zero sent meanwhile without this lock: zero again.
        if self.ended.load(Ordering::SeqCst) {
            self.send_zero(&out, now, true);
        }
    }

    /// Keeps the arm last commanded, for the zeros: `dof` joints from
    /// `base`; the spare publishers learn a new base.
    fn remember(&self, out: &mut Outputs, dof: usize, base: &str) {
        out.dof = dof;
        self.dof.store(dof, Ordering::SeqCst);
        if out.base != base {
            out.base = base.to_string();
            lock(&self.spare).base = base.to_string();
        }
    }

    /// Publishes a zero command on both outputs, for the arm of `n` (none
    /// before a robot description: nothing was commanded); `last`: the
    /// node is ending, and sends nothing more.
    pub(super) fn zero(&self, n: &ForceControllerNode, now: f64, last: bool) {
        let mut out = lock(&self.sending);
        if let (Some(dof), Some(c)) = (n.zero_command(), n.controller()) {
            self.remember(&mut out, dof, &c.robot().links.0);
        }
        self.send_zero(&out, now, last);
    }

    /// The zero of a panic, the last: the node not locked, `sending`
    /// waited for at most [`ZERO_WAIT`], else the spare publishers used.
    pub(super) fn zero_on_panic(&self) {
        let now = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0.0, |d| d.as_secs_f64());
        let since = Instant::now();
        loop {
            match self.sending.try_lock() {
                Ok(out) => return self.send_zero(&out, now, true),
                Err(TryLockError::Poisoned(p)) => {
                    return self.send_zero(&p.into_inner(), now, true)
                }
                Err(TryLockError::WouldBlock) if since.elapsed() < ZERO_WAIT => {
                    std::thread::sleep(Duration::from_millis(1));
                }
                // Held by the panicking thread itself.
                Err(TryLockError::WouldBlock) => break,
            }
        }
        let mut spare = lock(&self.spare);
        spare.dof = self.dof.load(Ordering::SeqCst);
        self.send_zero(&spare, now, true);
    }

    fn send_zero(&self, out: &Outputs, now: f64, last: bool) {
        if last {
            self.ended.store(true, Ordering::SeqCst);
        }
        if out.dof > 0 {
            let zero = JointVector::zeros(out.dof);
            if let Err(e) = out.joints.publish(&convert::commands_msg(&zero)) {
                tracing::warn!("zero command: {e}");
            }
        }
        let twist = convert::twist_msg(now, &out.base, &Twist::zeros());
        if let Err(e) = out.twists.publish(&twist) {
            tracing::warn!("zero twist: {e}");
        }
    }
}
