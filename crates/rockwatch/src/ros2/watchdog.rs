//! The node's watch over its ROS 2 participant ([`Watchdog`]): RustDDS ends a participant's
//! threads on any poll error (e.g. EINTR after SIGSTOP/SIGCONT or a debugger attach), which
//! leaves the participant dead for good; the event loop asks the watchdog at most every
//! [`LIVENESS_CHECK`] and, when a thread has ended, has it build a new participant, or end
//! the node once that has failed for [`REBUILD_GIVE_UP`].

use std::time::{Duration, Instant};

use anyhow::Context;
use ros2_client::dds::rustdds::mio1::{Registry, Token};

use super::node::Ros2Node;
use super::publish::Ros2Publisher;

/// How often the event loop checks that the ROS 2 participant's RustDDS threads still run
/// (see [`Ros2Node::ended_thread`]; two reads of /proc per check).
pub const LIVENESS_CHECK: Duration = Duration::from_millis(500);

/// How long the node keeps trying to rebuild a dead ROS 2 participant (one attempt per
/// [`LIVENESS_CHECK`]) before it gives up and exits with an error.
pub const REBUILD_GIVE_UP: Duration = Duration::from_secs(30);

/// Where the event loop registered the node's ROS 2 sources (registered again on the new
/// participant after a rebuild).
#[derive(Debug, Clone, Copy)]
pub struct Ros2Tokens {
    /// Input `i` is `Token(inputs_first + i)` ([`Ros2Node::register`]).
    pub inputs_first: usize,
    /// The `pbr/reset` service.
    pub reset: Token,
    /// The six parameter services.
    pub params: Token,
}

/// Watches the ROS 2 participant and rebuilds it when its RustDDS threads have ended.
#[derive(Debug)]
pub struct Watchdog {
    last_check: Instant,
    /// Since when the participant is dead and could not be rebuilt.
    down_since: Option<Instant>,
    rebuilds: u64,
}

impl Default for Watchdog {
    fn default() -> Self {
        Watchdog::new()
    }
}

impl Watchdog {
    /// A watchdog whose first check is due [`LIVENESS_CHECK`] from now.
    #[must_use]
    pub fn new() -> Watchdog {
        Watchdog {
            last_check: Instant::now(),
            down_since: None,
            rebuilds: 0,
        }
    }

    /// Whether the participant is up (never dead, or rebuilt since).
    #[must_use]
    pub fn is_up(&self) -> bool {
        self.down_since.is_none()
    }

    /// Participants rebuilt so far.
    #[must_use]
    pub fn rebuilds(&self) -> u64 {
        self.rebuilds
    }

    /// Whether [`LIVENESS_CHECK`] has passed since the last check (then a check is due now).
    pub fn due(&mut self) -> bool {
        self.due_at(Instant::now())
    }

    fn due_at(&mut self, now: Instant) -> bool {
        if now.saturating_duration_since(self.last_check) < LIVENESS_CHECK {
            return false;
        }
        self.last_check = now;
        true
    }

    /// The participant's `thread` has ended: says so, and replaces the participant (its
    /// subscriptions and services registered again with `registry` under `tokens`, its
    /// publisher replacing `publisher`, the 3-D view carried over). Returns whether it was
    /// rebuilt; an error once it could not be for [`REBUILD_GIVE_UP`].
    pub fn rebuild(
        &mut self,
        thread: &str,
        ros2: &mut Ros2Node,
        publisher: &mut Ros2Publisher,
        registry: &Registry,
        tokens: Ros2Tokens,
    ) -> anyhow::Result<bool> {
        let since = *self.down_since.get_or_insert_with(Instant::now);
        tracing::error!(
            "ROS 2 transport dead: the DDS participant's thread {thread} has ended \
             (RustDDS ends it on any poll error, e.g. EINTR after SIGSTOP/SIGCONT or a debugger \
             attach); rebuilding the participant ({} rebuilds so far)",
            self.rebuilds
        );
        let rebuilt = ros2.rebuild().and_then(|mut fresh| {
            // The 3-D view carries over: its frames and markers go out on the new participant.
            if let Some(scene) = publisher.take_scene() {
                fresh.show(scene);
            }
            *publisher = fresh;
            ros2.register(registry, tokens.inputs_first)
                .context("cannot register the ROS 2 subscriptions with the event loop")?;
            ros2.register_reset(registry, tokens.reset)
                .context("cannot register the ROS 2 reset service with the event loop")?;
            ros2.register_parameters(registry, tokens.params)
                .context("cannot register the ROS 2 parameter services with the event loop")
        });
        self.settle(rebuilt, since, Instant::now())
    }

    /// What a rebuild attempt of a participant dead since `since` means at `now`: rebuilt
    /// (counted, up again), to be tried again, or, [`REBUILD_GIVE_UP`] after `since`, the
    /// node's end.
    fn settle(
        &mut self,
        rebuilt: anyhow::Result<()>,
        since: Instant,
        now: Instant,
    ) -> anyhow::Result<bool> {
        let down_for = now.saturating_duration_since(since);
        match rebuilt {
            Ok(()) => {
                self.rebuilds += 1;
                self.down_since = None;
                tracing::info!(
                    "ROS 2 participant rebuilt after {:.1} s ({} rebuilds in all); the engine's state is kept",
                    down_for.as_secs_f64(),
                    self.rebuilds
                );
                Ok(true)
            }
            Err(e) if down_for < REBUILD_GIVE_UP => {
                tracing::error!("cannot rebuild the ROS 2 participant ({e:#}): trying again");
                Ok(false)
            }
            Err(e) => Err(e.context(format!(
                "the ROS 2 transport is dead and could not be rebuilt for {} s",
                REBUILD_GIVE_UP.as_secs()
            ))),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_check_is_due_once_per_liveness_period() {
        let mut watchdog = Watchdog::new();
        let start = watchdog.last_check;
        assert!(!watchdog.due_at(start));
        assert!(!watchdog.due_at(start + LIVENESS_CHECK - Duration::from_millis(1)));
        assert!(watchdog.due_at(start + LIVENESS_CHECK));
        // The next check is a whole period after the one just made.
        assert!(!watchdog.due_at(start + LIVENESS_CHECK + Duration::from_millis(1)));
        assert!(watchdog.due_at(start + 2 * LIVENESS_CHECK));
    }

    #[test]
    fn a_failed_rebuild_is_retried_until_the_give_up_time_then_ends_the_node() {
        let mut watchdog = Watchdog::new();
        let since = Instant::now();
        watchdog.down_since = Some(since);
        let failed = || Err(anyhow::anyhow!("no participant"));
        assert!(!watchdog.settle(failed(), since, since).unwrap());
        let just_before = since + REBUILD_GIVE_UP - Duration::from_millis(1);
        assert!(!watchdog.settle(failed(), since, just_before).unwrap());
        assert!(!watchdog.is_up());
        let given_up = watchdog.settle(failed(), since, since + REBUILD_GIVE_UP);
        let message = format!("{:#}", given_up.unwrap_err());
        assert!(
            message.contains("could not be rebuilt for 30 s"),
            "{message}"
        );
        assert!(message.contains("no participant"), "{message}");
        assert_eq!(watchdog.rebuilds(), 0);
    }

    #[test]
    fn a_rebuild_brings_the_participant_up_and_is_counted() {
        let mut watchdog = Watchdog::new();
        let since = Instant::now();
        watchdog.down_since = Some(since);
        assert!(watchdog.settle(Ok(()), since, since).unwrap());
        assert!(watchdog.is_up());
        assert_eq!(watchdog.rebuilds(), 1);
    }
}
