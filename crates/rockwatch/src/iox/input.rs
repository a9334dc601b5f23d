//! The iceoryx2 input ([`IoxInput`]): the subscription to `pbr/accel` plus the listener of the
//! event service of the same name, a mio event source drained by the node's event loop.

use std::sync::Arc;

use iceoryx2::prelude::*;
use mio::unix::SourceFd;

use super::cleanup::{clean_dead_nodes, DeadNodeCleanup};
use super::config::IoxConfig;
use super::intake::Intake;
use super::service::{create_node, iox_err, open_accel_service, open_event, open_intake_service};
use super::stats::{
    Counters, IoxInputStats, IoxStatsHandle, DEAD_NODES, RECV_ERRORS, SUBMITTED, WAKEUPS,
};
use super::types::{AccelHeader, AccelSample, IntakeIox};
use crate::intake::{Taken, WriterCounts};
use crate::ports::Received;
use rockwatch_core::engine::{Source, SourceTally, Verdict};

/// The input side, subscribed to `pbr/accel`: a subscriber plus the listener of the event
/// service of the same name. It has no thread: register it with a `mio::Poll` (it is a mio
/// event source, readable when a station has notified) and call [`IoxInput::drain`] whenever
/// it is ready, and [`IoxInput::maintain`] regularly (the node's event loop does both).
pub struct IoxInput {
    subscriber: iceoryx2::port::subscriber::Subscriber<ipc::Service, [AccelSample], AccelHeader>,
    listener: iceoryx2::port::listener::Listener<ipc::Service>,
    intake: Intake,
    counters: Arc<Counters>,
    cleanup: DeadNodeCleanup,
    /// What the node made of each publisher's packets, reported on `<accel service>/intake`.
    writers: WriterCounts,
    tally: Arc<SourceTally>,
    reports: iceoryx2::port::publisher::Publisher<ipc::Service, IntakeIox, ()>,
    /// Reports that could not be published.
    report_errors: u64,
    /// Samples taken so far: the sequence number the writer counts check order by.
    taken: i64,
    node: Node<ipc::Service>,
}

impl IoxInput {
    /// Cleans up dead iceoryx2 nodes (e.g. `kill -9`ed stations), then opens (or creates)
    /// `pbr/accel` and subscribes, and `pbr/accel/intake` to report to the senders what the
    /// node made of their packets (its engine counts verdicts in `tally`).
    pub fn open(config: &IoxConfig, tally: Arc<SourceTally>) -> anyhow::Result<IoxInput> {
        let node = create_node(config)?;
        let counters = Arc::new(Counters::default());
        counters.add(DEAD_NODES, clean_dead_nodes(&node));
        let service = open_accel_service(&node, config)?;
        let event = open_event(&node, &config.accel_service)?;
        let subscriber = service
            .subscriber_builder()
            .buffer_size(config.subscriber_buffer)
            .create()
            .map_err(iox_err("cannot create the pbr/accel subscriber"))?;
        let listener = event
            .listener_builder()
            .create()
            .map_err(iox_err("cannot create the pbr/accel listener"))?;
        let reports = open_intake_service(&node, config)?
            .publisher_builder()
            .create()
            .map_err(iox_err("cannot create the intake report publisher"))?;
        // Each publisher has its own buffer in the subscriber: the whole buffer is its window
        // (half of it, for margin), however many publishers there are.
        let writers = WriterCounts::new(
            crate::intake::node_id(),
            format!("rockwatch node (pid {})", std::process::id()),
            Arc::clone(&tally),
            config.subscriber_buffer as u64,
        )
        .per_writer_buffer();
        Ok(IoxInput {
            subscriber,
            listener,
            intake: Intake::default(),
            counters,
            cleanup: DeadNodeCleanup::new(config),
            writers,
            tally,
            reports,
            report_errors: 0,
            taken: 0,
            node,
        })
    }

    /// Counters so far.
    #[must_use]
    pub fn stats(&self) -> IoxInputStats {
        self.counters.snapshot()
    }

    /// A handle to read the counters from other threads.
    #[must_use]
    pub fn stats_handle(&self) -> IoxStatsHandle {
        IoxStatsHandle(Arc::clone(&self.counters))
    }

    /// Takes the pending notifications, then up to `max` packets: each is checked (wire
    /// layout and station id; counted when rejected at the wire, with per-station sequence
    /// gaps), counted for its publisher (of a station the node `monitors` or not), and handed
    /// to `submit` with its publisher's slot (a malformed station id as its refusal, for the
    /// node to count as on every transport). Returns true if `max` was reached (more may be waiting: call again
    /// without waiting for readiness, which is edge-triggered).
    pub fn drain(
        &mut self,
        max: usize,
        monitors: &dyn Fn(&str) -> bool,
        submit: &mut impl FnMut(Received, Option<Source>),
    ) -> bool {
        self.counters.add(WAKEUPS, 1);
        // Consume the notifications first: a notifier sends again only once the listener has
        // taken them, and samples sent before a notification are then all visible below.
        if self.listener.try_wait(|_| {}).is_err() {
            self.counters.add(RECV_ERRORS, 1);
        }
        for _ in 0..max {
            match self.subscriber.receive() {
                Ok(Some(sample)) => {
                    let writer = sample.header().publisher_id().value().to_le_bytes();
                    let packet =
                        self.intake
                            .accept(sample.user_header(), sample.payload(), &self.counters);
                    drop(sample); // return the shared-memory slot before the engine runs
                    self.taken += 1;
                    // A packet refused (at the wire, or for its malformed station id) is
                    // refused, not ignored: its publisher is told.
                    let monitored = match &packet {
                        Some(Ok(p)) => monitors(p.station.as_str()),
                        Some(Err(_)) | None => true,
                    };
                    let Taken::New(slot) = self.writers.taken(writer, self.taken, monitored) else {
                        continue; // unreachable: the sequence number only grows
                    };
                    match packet {
                        Some(received) => {
                            if received.is_ok() {
                                self.counters.add(SUBMITTED, 1);
                            }
                            submit(received, Some(slot));
                        }
                        // Refused at the wire: its publisher is told.
                        None => self.tally.count(slot, Verdict::Refused),
                    }
                }
                Ok(None) => return false,
                Err(_) => {
                    self.counters.add(RECV_ERRORS, 1);
                    return false;
                }
            }
        }
        true
    }

    /// Whether an intake report will be due without any new packet ([`WriterCounts::pending`]).
    #[must_use]
    pub fn intake_pending(&self) -> bool {
        self.writers.pending()
    }

    /// Publishes the intake reports due on `<accel service>/intake` (`force`: every changed
    /// count now). Cheap when none is: call it after every turn of the event loop.
    pub fn publish_intake_reports(&mut self, force: bool) {
        let reader = self.subscriber.id().value().to_le_bytes();
        let (reports, errors) = (&self.reports, &mut self.report_errors);
        self.writers.due(force, reader, &mut |count| {
            if let Err(e) = reports.send_copy(IntakeIox::from(&count)) {
                *errors += 1;
                if errors.is_power_of_two() {
                    tracing::warn!("iceoryx2 intake report not published ({e:?}; {errors} in all)");
                }
            }
        });
    }

    /// Cleans up dead iceoryx2 nodes when [`IoxConfig::dead_node_check_s`] has passed since
    /// the last clean-up (cheap otherwise: call it on every turn of the event loop).
    pub fn maintain(&mut self) {
        self.counters
            .add(DEAD_NODES, self.cleanup.maintain(&self.node));
    }

    fn raw_fd(&self) -> i32 {
        // SAFETY: `native_handle` is unsafe only because the number must not outlive the
        // listener nor be closed by the caller; it is used transiently to (de)register the
        // listener's socket with a poller, and the listener lives as long as `self`.
        unsafe { self.listener.file_descriptor().native_handle() }
    }
}

/// Readable when a station has notified `pbr/accel` (the listener's socket).
impl mio::event::Source for IoxInput {
    fn register(
        &mut self,
        registry: &mio::Registry,
        token: mio::Token,
        interests: mio::Interest,
    ) -> std::io::Result<()> {
        SourceFd(&self.raw_fd()).register(registry, token, interests)
    }

    fn reregister(
        &mut self,
        registry: &mio::Registry,
        token: mio::Token,
        interests: mio::Interest,
    ) -> std::io::Result<()> {
        SourceFd(&self.raw_fd()).reregister(registry, token, interests)
    }

    fn deregister(&mut self, registry: &mio::Registry) -> std::io::Result<()> {
        SourceFd(&self.raw_fd()).deregister(registry)
    }
}
