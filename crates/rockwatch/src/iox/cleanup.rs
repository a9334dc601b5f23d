//! Clean-up of dead iceoryx2 nodes (e.g. a `kill -9`ed station): their resources are
//! released at start-up and then every [`IoxConfig::dead_node_check_s`].

use std::time::{Duration, Instant};

use iceoryx2::prelude::*;

use super::config::IoxConfig;

/// Cleans up the dead iceoryx2 nodes `node` can see now; returns how many were cleaned.
pub(super) fn clean_dead_nodes(node: &Node<ipc::Service>) -> u64 {
    node.try_cleanup_dead_nodes().cleanups
}

/// The periodic clean-up: its period and when it last ran.
pub(super) struct DeadNodeCleanup {
    period: Duration,
    last: Instant,
}

impl DeadNodeCleanup {
    /// The clean-up every [`IoxConfig::dead_node_check_s`] (clamped to 0.01 s … 1 h), counted
    /// from now.
    pub(super) fn new(config: &IoxConfig) -> DeadNodeCleanup {
        DeadNodeCleanup {
            period: Duration::from_secs_f64(config.dead_node_check_s.clamp(0.01, 3600.0)),
            last: Instant::now(),
        }
    }

    /// Cleans up dead nodes if the period has passed since the last clean-up; returns how
    /// many were cleaned (cheap otherwise: call it on every turn of the event loop).
    pub(super) fn maintain(&mut self, node: &Node<ipc::Service>) -> u64 {
        if self.last.elapsed() < self.period {
            return 0;
        }
        let cleaned = clean_dead_nodes(node);
        self.last = Instant::now();
        cleaned
    }
}
