//! Replay over ROS 2 ([`Ros2PacketSink`]): `/pbr/accel` published from a node
//! `rockwatch_replay`, paced by what the node reports it has taken (`/pbr/intake`), so that
//! a replay ends only once the node has processed every packet — or says how many it did not.

use std::collections::VecDeque;
use std::time::{Duration, Instant};

use anyhow::{anyhow, bail};
use ros2_client::dds::rustdds::{no_key, DataWriterStatus, RTPSEntity, StatusEvented};
use ros2_client::Gid;

use super::intake_report::IntakeWatch;
use super::msg;
use super::names::{Naming, ACCEL_TOPIC, INTAKE_TOPIC};
use super::network::NetworkPlan;
use super::qos::{intake_qos, replay_qos, REPLAY_HISTORY};
use super::session::Ros2Session;
use crate::logging::MuteLibraries;
use crate::ports::PacketSink;
use rockwatch_core::engine::AccelPacket;

/// Most packets a replay has sent that the node has not yet reported taken. Below the node's
/// reader depth (`[ros2] input_depth`, default 1000), so the node's DDS reader (keep last) can
/// never overwrite a sample it has acknowledged but not handed over; it also bounds what the
/// replay's writer holds (its history keeps every unacknowledged sample).
pub const CREDIT_WINDOW: u64 = REPLAY_HISTORY as u64 / 2;

/// How often a replay checks that its DDS participant's threads still run.
pub const REPLAY_LIVENESS_CHECK: Duration = Duration::from_millis(100);

/// After rebuilding its participant, how long a replay waits for the node's report on its
/// previous writer (the node repeats its counts every second).
pub const PREVIOUS_REPORT_WAIT: Duration = Duration::from_secs(3);

/// How long a replay waits for the node's reports to move before it gives up (default; see
/// [`Ros2PacketSink::set_wait`]).
pub const DEFAULT_INTAKE_WAIT: Duration = Duration::from_secs(30);

/// Replay over ROS 2: publishes `/pbr/accel` from a node `rockwatch_replay`.
///
/// The writer is a plain RustDDS data writer on the node's participant and ROS 2 topic
/// (ros2-client's `Publisher` hides it, and its GUID names this replay in the node's reports).
/// The node reports on `/pbr/intake` how many messages of this writer it has taken
/// (`pbr_msgs/IntakeReport`); [`PacketSink::send`] waits while [`CREDIT_WINDOW`] packets are
/// unreported (flow control end to end: nothing is overwritten in the node's reader, and the
/// replay's memory stays bounded), and [`PacketSink::finish`] waits until the node has taken
/// every packet sent, else fails naming how many it did not.
///
/// A replay survives the death of its own DDS participant (RustDDS ends its threads on EINTR,
/// e.g. after SIGSTOP/SIGCONT of the replay): it notices within [`REPLAY_LIVENESS_CHECK`],
/// says so, builds a new participant and writer, learns from the node's report how many
/// packets of the dead writer the node took, and sends the rest again (it keeps the last
/// [`CREDIT_WINDOW`] packets for that). The writer is not listed under
/// the node in the ROS 2 graph (`ros2 topic info` shows the publisher without its node name).
pub struct Ros2PacketSink {
    writer: no_key::DataWriterCdr<msg::AccelPacket>,
    intake: IntakeWatch,
    /// Distinct packets sent (each resent one counted once).
    sent: u64,
    /// Packets of the writers before the current one that the node took: the current writer's
    /// k-th message is packet `base + k - 1`.
    base: u64,
    /// The last packets sent (at most [`CREDIT_WINDOW`]), the last one being packet `sent - 1`.
    recent: VecDeque<msg::AccelPacket>,
    /// Where and as what the participant was built (for a rebuild).
    plan: NetworkPlan,
    naming: Naming,
    last_liveness: Instant,
    /// Times the participant was found dead and rebuilt.
    pub rebuilds: u64,
    /// How long to wait for the node's reports to move.
    wait: Duration,
    /// Readers matched now, from the writer's publication-matched status events.
    matched: i32,
    /// A matched reader went away (the node stopped or died mid-replay).
    lost_reader: bool,
    /// Last: the endpoints above are dropped before their participant.
    _session: Ros2Session,
}

impl Ros2PacketSink {
    /// Publishes on `pbr/accel` as the node `rockwatch_replay` in `naming`'s namespace (the
    /// node's: the topics resolve there, then its remaps).
    pub fn open(plan: &NetworkPlan, naming: impl Into<Naming>) -> anyhow::Result<Ros2PacketSink> {
        let naming = naming.into();
        let (session, writer, reports) = Self::open_parts(plan, &naming)?;
        let intake = IntakeWatch::new(reports, Gid::from(writer.guid()));
        Ok(Ros2PacketSink {
            _session: session,
            writer,
            intake,
            sent: 0,
            base: 0,
            recent: VecDeque::with_capacity(CREDIT_WINDOW as usize),
            plan: plan.clone(),
            naming,
            last_liveness: Instant::now(),
            rebuilds: 0,
            wait: DEFAULT_INTAKE_WAIT,
            matched: 0,
            lost_reader: false,
        })
    }

    /// A participant with the replay's writer and its subscription to the node's reports.
    #[allow(clippy::type_complexity)]
    fn open_parts(
        plan: &NetworkPlan,
        naming: &Naming,
    ) -> anyhow::Result<(
        Ros2Session,
        no_key::DataWriterCdr<msg::AccelPacket>,
        ros2_client::Subscription<msg::IntakeReport>,
    )> {
        let mut session = Ros2Session::open_client(plan, naming, "rockwatch_replay")?;
        let qos = replay_qos();
        let topic = session.topic(ACCEL_TOPIC, msg::PACKAGE, "AccelPacket", &qos)?;
        let dds_qos = ros2_client::dds::rustdds::QosPolicies::from(qos);
        let writer = session
            .context
            .domain_participant()
            .create_publisher(&dds_qos)
            .and_then(|p| p.create_datawriter_no_key_cdr(&topic, Some(dds_qos.clone())))
            .map_err(|e| anyhow!("ROS 2 publisher {ACCEL_TOPIC}: {e:?}"))?;
        let reports =
            session.subscription(INTAKE_TOPIC, msg::PACKAGE, "IntakeReport", intake_qos())?;
        Ok((session, writer, reports))
    }

    /// Packets the node has reported taken, over every writer of this replay.
    fn confirmed(&mut self) -> u64 {
        self.base + self.intake.taken()
    }

    /// Checks (at most every [`REPLAY_LIVENESS_CHECK`]) that the participant's threads run;
    /// rebuilds it if not.
    fn keep_alive(&mut self) -> anyhow::Result<()> {
        if self.last_liveness.elapsed() < REPLAY_LIVENESS_CHECK {
            return Ok(());
        }
        self.last_liveness = Instant::now();
        match self._session.ended_thread() {
            Some(thread) => self.rebuild(&thread),
            None => Ok(()),
        }
    }

    /// Replaces the dead participant: a new writer, the node's count of the dead writer's
    /// packets, and the packets after those sent again.
    fn rebuild(&mut self, thread: &str) -> anyhow::Result<()> {
        tracing::error!(
            "ROS 2 transport dead: the replay's DDS participant thread {thread} \
             has ended (RustDDS ends it on any poll error, e.g. EINTR after SIGSTOP/SIGCONT); \
             rebuilding it and sending again what the node has not taken"
        );
        let (session, writer, reports) = Self::open_parts(&self.plan, &self.naming)?;
        {
            // The dead participant's teardown: RustDDS logs each endpoint it cannot remove.
            let _quiet = MuteLibraries::new();
            self.intake.switch(reports, Gid::from(writer.guid()));
            // Endpoints before their participant (see the field order).
            self.writer = writer;
            self._session = session;
        }
        self.matched = 0;
        self.lost_reader = false;
        if !self.wait_for_subscriber(self.wait)? {
            bail!(
                "the replay's DDS participant was rebuilt, but no node subscribed again within {:.0} s",
                self.wait.as_secs_f64()
            );
        }
        let deadline = Instant::now() + PREVIOUS_REPORT_WAIT;
        while !self.intake.previous().is_some_and(|(_, heard)| heard) && Instant::now() < deadline {
            std::thread::sleep(Duration::from_millis(20));
        }
        let (taken, _) = self.intake.previous().unwrap_or((0, false));
        self.base += taken;
        let first_kept = self.sent - self.recent.len() as u64;
        if self.base < first_kept {
            bail!(
                "the replay's DDS participant was rebuilt, but the node has taken only {} of {} packets and the replay kept only the last {}",
                self.base,
                self.sent,
                self.recent.len()
            );
        }
        self.base = self.base.min(self.sent);
        let again: Vec<msg::AccelPacket> = self
            .recent
            .iter()
            .skip((self.base - first_kept) as usize)
            .cloned()
            .collect();
        for m in &again {
            self.send_msg(m.clone())?;
        }
        self.rebuilds += 1;
        tracing::info!(
            "replay participant rebuilt: the node had taken {} of {} packets; {} sent again",
            self.base,
            self.sent,
            again.len()
        );
        Ok(())
    }

    /// How long [`PacketSink::send`] and [`PacketSink::finish`] wait for the node's reports
    /// to move before giving up.
    pub fn set_wait(&mut self, wait: Duration) {
        self.wait = wait;
    }

    /// Sends a raw message (tests of malformed input), without flow control.
    pub fn send_msg(&mut self, m: msg::AccelPacket) -> anyhow::Result<()> {
        self.writer
            .write(m, Some(ros2_client::dds::rustdds::Timestamp::now()))
            .map_err(|e| anyhow!("ROS 2 publish on {ACCEL_TOPIC}: {e:?}"))
    }

    /// Packets sent so far, and of those the node has reported taken.
    pub fn progress(&mut self) -> (u64, u64) {
        (self.sent, self.confirmed())
    }

    /// Readers matched now (after taking the writer's pending status events).
    fn matched_readers(&mut self) -> i32 {
        while let Some(status) = self.writer.try_recv_status() {
            if let DataWriterStatus::PublicationMatched { current, .. } = status {
                self.matched = current.count();
                self.lost_reader |= current.count_change() < 0;
            }
        }
        self.matched
    }

    /// Waits until at most `unreported` packets are not reported taken by the node; false if
    /// the reports stood still for the wait ([`Ros2PacketSink::set_wait`]).
    fn wait_for_intake(&mut self, unreported: u64) -> anyhow::Result<bool> {
        let mut taken = self.confirmed();
        let mut last_move = Instant::now();
        while self.sent - taken.min(self.sent) > unreported {
            std::thread::sleep(Duration::from_micros(200));
            self.keep_alive()?;
            let now = self.confirmed();
            if now != taken {
                taken = now;
                last_move = Instant::now();
            } else if last_move.elapsed() >= self.wait {
                return Ok(false);
            }
        }
        Ok(true)
    }

    /// One line on why the node has not taken everything.
    fn shortfall(&mut self) -> String {
        let (sent, taken) = self.progress();
        let why = if self.intake.heard == 0 {
            format!(
                "no report of the node on {INTAKE_TOPIC} (is the subscriber a rockwatch node of this version?)"
            )
        } else if self.matched_readers() == 0 || self.lost_reader {
            "the node went away".to_string()
        } else {
            "lost on the way, e.g. the node's participant was rebuilt".to_string()
        };
        format!(
            "sent {sent} packets, but the node did not acknowledge them all within {:.0} s: it took {taken}, {} not processed ({why})",
            self.wait.as_secs_f64(),
            sent - taken.min(sent)
        )
    }
}

impl PacketSink for Ros2PacketSink {
    fn wait_for_subscriber(&mut self, timeout: Duration) -> anyhow::Result<bool> {
        let deadline = Instant::now() + timeout;
        loop {
            if self.matched_readers() > 0 {
                return Ok(true);
            }
            if Instant::now() >= deadline {
                return Ok(false);
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    fn send(&mut self, packet: &AccelPacket) -> anyhow::Result<()> {
        self.keep_alive()?;
        if !self.wait_for_intake(CREDIT_WINDOW - 1)? {
            bail!("{}", self.shortfall());
        }
        let m = msg::AccelPacket::from(packet);
        if self.recent.len() == CREDIT_WINDOW as usize {
            self.recent.pop_front();
        }
        self.recent.push_back(m.clone());
        self.send_msg(m)?;
        self.sent += 1;
        Ok(())
    }

    fn finish(&mut self, timeout: Duration) -> anyhow::Result<bool> {
        self.wait = timeout;
        if !self.wait_for_intake(0)? {
            bail!("{}", self.shortfall());
        }
        Ok(true)
    }
}
