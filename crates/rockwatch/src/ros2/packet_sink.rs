//! The packet sender over ROS 2 ([`Ros2PacketSink`]) of `rockwatch replay` and `rockwatch
//! acquire`: `/pbr/accel` published from a node `rockwatch_replay`, paced by what the node
//! reports it has taken (`/pbr/intake`), so that a replay ends only once the node has
//! processed every packet — or says how many it did not.
//! To a scaled-out service (docs/capacity.md) each station's packets go to its partition's
//! topic, one writer per partition, each paced and confirmed by the node that reads it. A live
//! sender (`rockwatch acquire`) also publishes its status on `/diagnostics` through it.

use std::collections::{BTreeSet, VecDeque};
use std::time::{Duration, Instant};

use anyhow::{anyhow, bail};
use ros2_client::dds::rustdds::{
    dds::WriteError, no_key, DataWriterStatus, RTPSEntity, StatusEvented, GUID,
};
use ros2_client::Gid;

use super::diagnostics::{DiagnosticArray, DiagnosticsWriter};
use super::msg;
use super::msg::IntakeReport;
use super::names::{accel_topic, IntoNaming, Naming, INTAKE_TOPIC};
use super::network::NetworkPlan;
use super::qos::{intake_qos, replay_qos, sender_status_qos, REPLAY_HISTORY};
use super::session::Ros2Session;
use crate::intake::{ignored_line, refusal_line, Delivery, IntakeCount};
use crate::logging::MuteLibraries;
use crate::ports::PacketSink;
use crate::status::StatusReport;
use rockwatch_core::engine::AccelPacket;
use rockwatch_core::partition::{Partition, PartitionMap};

/// Most packets a replay has sent that a node has not yet reported taken, whatever window the
/// nodes grant (each node shares its reader depth, `[ros2] input_depth`, among the writers it
/// hears: `IntakeCount::window`). It bounds what the replay's writer holds (its history
/// keeps every unacknowledged sample) and what the replay keeps to send again.
pub const CREDIT_WINDOW: u64 = REPLAY_HISTORY as u64 / 2;

/// How often a replay checks that its DDS participant's threads still run.
pub const REPLAY_LIVENESS_CHECK: Duration = Duration::from_millis(100);

/// After rebuilding its participant, how long a replay waits for the node's report on its
/// previous writer (the node repeats its counts every second).
pub const PREVIOUS_REPORT_WAIT: Duration = Duration::from_secs(3);

/// Times in a row a replay builds its participant again when the new one dies before a node
/// has subscribed.
pub const MAX_REBUILD_ATTEMPTS: u32 = 20;

/// A live sender (acquire) warns at most this often that the node ignores some of its packets.
pub const IGNORED_WARNING_INTERVAL: Duration = Duration::from_secs(60);

/// Stations a lane remembers by name, to name them when the node ignores packets.
const NAMED_STATIONS: usize = 64;

/// How long a replay waits for the node's reports to move before it gives up (default; see
/// [`Ros2PacketSink::set_wait`]).
pub const DEFAULT_INTAKE_WAIT: Duration = Duration::from_secs(30);

/// Replay over ROS 2: publishes `/pbr/accel` from a node `rockwatch_replay`.
///
/// The writer is a plain RustDDS data writer on the node's participant and ROS 2 topic
/// (ros2-client's `Publisher` hides it, and its GUID names this replay in the node's reports).
/// Every node subscribed reports on `/pbr/intake` how many messages of this writer it has
/// taken and processed, how many it refused, and the window it grants this writer
/// (`pbr_msgs/IntakeReport`, `crate::intake`); [`PacketSink::send`] waits while the node
/// furthest behind has a window's worth unreported (flow control end to end, per writer:
/// nothing is overwritten in any node's reader, however many replays share it, and the
/// replay's memory stays bounded), and [`PacketSink::finish`] waits until every node has
/// processed every packet sent, else fails naming each node that did not and how much, or
/// that refused packets or dropped them as data it had. A subscriber that never reports (not a rockwatch node: `ros2 topic
/// echo`, a bag recorder) is named in a warning and not waited for.
///
/// To a service of N partitioned nodes ([`Ros2PacketSink::open_partitioned`]) the sink has one
/// writer ("lane") per partition topic `pbr/accel/p<i>of<N>`, and sends each packet on its
/// station's partition's lane. Only the node of partition i reads lane i's writer, so the
/// reports about that writer (one GUID) come from that node alone and every lane is paced and
/// confirmed exactly as a single node's replay: the accounting needs no change in the nodes.
///
/// A replay survives the death of its own DDS participant (RustDDS ends its threads on EINTR,
/// e.g. after SIGSTOP/SIGCONT of the replay): it notices within [`REPLAY_LIVENESS_CHECK`],
/// says so, builds a new participant and writers, learns from the nodes' reports how many
/// packets of each dead writer they took, and sends the rest again (it keeps the last
/// [`CREDIT_WINDOW`] packets of each lane for that). The writers are not listed under
/// the node in the ROS 2 graph (`ros2 topic info` shows the publisher without its node name).
pub struct Ros2PacketSink {
    /// One per partition (one lane, `pbr/accel`, without partitions).
    lanes: Vec<Lane>,
    /// Which lane a station's packets take (None: the one lane).
    map: Option<PartitionMap>,
    /// Where and as what the participant was built (for a rebuild).
    plan: NetworkPlan,
    naming: Naming,
    last_liveness: Instant,
    /// Times the participant was found dead and rebuilt.
    pub rebuilds: u64,
    /// How long to wait for the node's reports to move.
    wait: Duration,
    /// Ignored packets when the last warning about them was logged, and when.
    ignored_warned: (u64, Option<Instant>),
    /// The nodes' reports on `/pbr/intake`: one subscription for every lane.
    reports: ros2_client::Subscription<IntakeReport>,
    /// The sender's `/diagnostics` writer, made at its first [`PacketSink::status`] (a replay
    /// has none) and again after a rebuild of the participant.
    diagnostics: Option<DiagnosticsWriter>,
    /// Last: the endpoints above are dropped before their participant.
    _session: Ros2Session,
}

/// One writer of a replay and what the nodes reading it have made of its packets.
struct Lane {
    topic: String,
    writer: no_key::DataWriterCdr<msg::AccelPacket>,
    /// Packets sent on this lane and what every node made of them.
    delivery: Delivery,
    /// The stations sent on this lane (the first [`NAMED_STATIONS`]).
    stations: BTreeSet<String>,
    /// The last packets sent (at most [`CREDIT_WINDOW`]), the last one being packet `sent - 1`.
    recent: VecDeque<msg::AccelPacket>,
    /// Readers matched now, from the writer's publication-matched status events.
    matched: BTreeSet<[u8; 16]>,
    /// A matched reader went away (a node stopped or died mid-replay).
    lost_reader: bool,
}

impl Lane {
    fn new(topic: String, writer: no_key::DataWriterCdr<msg::AccelPacket>) -> Lane {
        Lane {
            delivery: Delivery::new(gid_of(writer.guid())),
            topic,
            writer,
            stations: BTreeSet::new(),
            recent: VecDeque::with_capacity(CREDIT_WINDOW as usize),
            matched: BTreeSet::new(),
            lost_reader: false,
        }
    }

    /// Readers matched now (after taking the writer's pending status events).
    fn matched_readers(&mut self) -> usize {
        while let Some(status) = self.writer.try_recv_status() {
            if let DataWriterStatus::PublicationMatched {
                current, reader, ..
            } = status
            {
                let gid = gid_of(reader);
                if current.count_change() > 0 {
                    self.matched.insert(gid);
                } else if current.count_change() < 0 {
                    self.matched.remove(&gid);
                    self.lost_reader = true;
                }
            }
        }
        self.matched.len()
    }

    /// Sends `m`; while the writer's history is full (a node stopped acknowledging), waits
    /// up to `wait`.
    fn write(&mut self, m: msg::AccelPacket, wait: Duration) -> anyhow::Result<()> {
        let deadline = Instant::now() + wait;
        let mut m = m;
        loop {
            match self
                .writer
                .write(m, Some(ros2_client::dds::rustdds::Timestamp::now()))
            {
                Ok(()) => return Ok(()),
                Err(WriteError::WouldBlock { data }) if Instant::now() < deadline => m = data,
                Err(WriteError::WouldBlock { .. }) => bail!(
                    "ROS 2 publish on {}: the writer's history stayed full for {:.0} s: a node \
                     stopped acknowledging (paused or overloaded?)",
                    self.topic,
                    wait.as_secs_f64()
                ),
                Err(e) => bail!("ROS 2 publish on {}: {e}", self.topic),
            }
        }
    }
}

/// The rmw gid of a DDS GUID (prefix, then entity id).
fn gid_of(guid: GUID) -> [u8; 16] {
    Gid::from(guid).to_bytes16()
}

/// A new participant, its subscription to the nodes' reports and its writers (one per topic).
type Parts = (
    Ros2Session,
    ros2_client::Subscription<IntakeReport>,
    Vec<no_key::DataWriterCdr<msg::AccelPacket>>,
);

impl Ros2PacketSink {
    /// Publishes on `pbr/accel` as the node `rockwatch_replay` in `naming`'s namespace (the
    /// node's: the topics resolve there, then its remaps): a replay to one node (or nodes
    /// without partitions).
    pub fn open(plan: &NetworkPlan, naming: impl IntoNaming) -> anyhow::Result<Ros2PacketSink> {
        Self::open_partitioned(plan, naming, None)
    }

    /// A replay to a service partitioned by `map` (each station's packets on its partition's
    /// topic `pbr/accel/p<i>of<N>`), or to `pbr/accel` if None; every topic resolved by
    /// `naming` as the nodes resolve theirs.
    pub fn open_partitioned(
        plan: &NetworkPlan,
        naming: impl IntoNaming,
        map: Option<PartitionMap>,
    ) -> anyhow::Result<Ros2PacketSink> {
        let naming = naming.into_naming()?;
        let topics = Self::topics(map.as_ref())?;
        let (session, reports, writers) = Self::open_parts(plan, &naming, &topics)?;
        let lanes = topics
            .into_iter()
            .zip(writers)
            .map(|(topic, writer)| Lane::new(topic, writer))
            .collect();
        Ok(Ros2PacketSink {
            reports,
            diagnostics: None,
            _session: session,
            lanes,
            map,
            plan: plan.clone(),
            naming,
            last_liveness: Instant::now(),
            rebuilds: 0,
            wait: DEFAULT_INTAKE_WAIT,
            ignored_warned: (0, None),
        })
    }

    /// The input topics of the service: one per partition of `map`, else `pbr/accel`.
    fn topics(map: Option<&PartitionMap>) -> anyhow::Result<Vec<String>> {
        match map {
            None => Ok(vec![accel_topic(None)]),
            Some(map) => (0..map.count())
                .map(|i| Ok(accel_topic(Some(Partition::new(i, map.count())?))))
                .collect(),
        }
    }

    /// A participant with one subscription to the nodes' reports and one writer per topic.
    fn open_parts(plan: &NetworkPlan, naming: &Naming, topics: &[String]) -> anyhow::Result<Parts> {
        let mut session = Ros2Session::open_client(plan, naming, "rockwatch_replay")?;
        let reports =
            session.subscription(INTAKE_TOPIC, msg::PACKAGE, "IntakeReport", intake_qos())?;
        let qos = replay_qos();
        let dds_qos = ros2_client::dds::rustdds::QosPolicies::from(qos.clone());
        let mut writers = Vec::with_capacity(topics.len());
        for name in topics {
            let topic = session.topic(name, msg::PACKAGE, "AccelPacket", &qos)?;
            let writer = session
                .context
                .domain_participant()
                .create_publisher(&dds_qos)
                .and_then(|p| p.create_datawriter_no_key_cdr(&topic, Some(dds_qos.clone())))
                .map_err(|e| anyhow!("ROS 2 publisher {name}: {e:?}"))?;
            writers.push(writer);
        }
        Ok((session, reports, writers))
    }

    /// Takes the nodes' reports waiting and hands each to every lane's watch.
    fn read_reports(&mut self) {
        while let Ok(Some((report, _))) = self.reports.take() {
            let report = IntakeCount::from(report);
            for lane in &mut self.lanes {
                lane.delivery.watch.offer(&report);
            }
        }
    }

    /// The lane of `station`'s packets.
    fn lane_of(&self, station: &str) -> usize {
        self.map
            .as_ref()
            .map_or(0, |m| m.partition_of(station) as usize)
    }

    /// Checks (at most every [`REPLAY_LIVENESS_CHECK`]) that the participant's threads run;
    /// rebuilds it if not.
    fn keep_alive(&mut self) -> anyhow::Result<()> {
        if self.last_liveness.elapsed() < REPLAY_LIVENESS_CHECK {
            return Ok(());
        }
        self.last_liveness = Instant::now();
        self.warn_ignored();
        match self._session.ended_thread() {
            Some(thread) => self.rebuild(&thread),
            None => Ok(()),
        }
    }

    /// Logs (at most every [`IGNORED_WARNING_INTERVAL`]) that the node ignores packets of
    /// this sender, when their number has grown.
    fn warn_ignored(&mut self) {
        let (warned, at) = self.ignored_warned;
        if at.is_some_and(|t| t.elapsed() < IGNORED_WARNING_INTERVAL) {
            return;
        }
        self.read_reports();
        let ignored: u64 = self.lanes.iter().map(|l| l.delivery.ignored()).sum();
        if ignored > warned {
            tracing::warn!("{}", self.ignored_line(ignored));
            self.ignored_warned = (ignored, Some(Instant::now()));
        }
    }

    /// One line on the `ignored` packets: the node does not monitor their station.
    fn ignored_line(&mut self, ignored: u64) -> String {
        let sent: u64 = self.lanes.iter().map(|l| l.delivery.sent).sum();
        let mut stations = BTreeSet::new();
        for lane in &self.lanes {
            if lane.delivery.ignored() > 0 {
                stations.extend(lane.stations.iter().map(String::as_str));
            }
        }
        ignored_line(ignored, sent, &stations, self.map.is_some())
    }

    /// Replaces the dead participant: new writers, the nodes' count of each dead writer's
    /// packets, and the packets after those sent again.
    fn rebuild(&mut self, thread: &str) -> anyhow::Result<()> {
        tracing::error!(
            "ROS 2 transport dead: the replay's DDS participant thread {thread} \
             has ended (RustDDS ends it on any poll error, e.g. EINTR after SIGSTOP/SIGCONT); \
             rebuilding it and sending again what the node has not taken"
        );
        let topics: Vec<String> = self.lanes.iter().map(|l| l.topic.clone()).collect();
        // The new participant may die too while it waits for the nodes (another signal):
        // watched like any, and built again, a bounded number of times.
        // Whether a new writer has replaced the dead one yet (an attempt whose participant
        // could not be built makes none).
        let mut switched = false;
        for attempt in 1..=MAX_REBUILD_ATTEMPTS {
            // Building fails too when a signal lands in RustDDS's start-up (its discovery
            // thread misses the hand-shake: "Discovery thread channel error: Timeout"): another
            // attempt, as a participant that dies while it waits.
            let (session, reports, writers) =
                match Self::open_parts(&self.plan, &self.naming, &topics) {
                    Ok(parts) => parts,
                    Err(e) if attempt < MAX_REBUILD_ATTEMPTS => {
                        tracing::error!(
                            "the replay's DDS participant could not be built again ({e:#}): \
                             trying again ({attempt} of {MAX_REBUILD_ATTEMPTS})"
                        );
                        std::thread::sleep(Duration::from_millis(100));
                        continue;
                    }
                    Err(e) => {
                        return Err(e.context(format!(
                            "the replay's DDS participant could not be built again \
                             {MAX_REBUILD_ATTEMPTS} times in a row: giving up"
                        )))
                    }
                };
            {
                // The dead participant's teardown: RustDDS logs each endpoint it cannot remove.
                let _quiet = MuteLibraries::new();
                self.read_reports();
                self.reports = reports;
                // Made again on the new participant at the next report.
                self.diagnostics = None;
                for (lane, writer) in self.lanes.iter_mut().zip(writers) {
                    let writer_gid = gid_of(writer.guid());
                    if !switched {
                        lane.delivery.watch.switch(writer_gid);
                    } else {
                        // The previous attempt's writer sent nothing: the dead one stays the
                        // previous writer.
                        lane.delivery.watch.retarget(writer_gid);
                    }
                    // Endpoints before their participant (see the field order).
                    lane.writer = writer;
                    lane.matched.clear();
                    lane.lost_reader = false;
                }
                self._session = session;
                switched = true;
            }
            let deadline = Instant::now() + self.wait;
            let died = loop {
                if self.lanes.iter_mut().all(|l| l.matched_readers() > 0) {
                    break None;
                }
                if let Some(thread) = self._session.ended_thread() {
                    break Some(thread);
                }
                if Instant::now() >= deadline {
                    bail!(
                        "the replay's DDS participant was rebuilt, but no node subscribed again within {:.0} s",
                        self.wait.as_secs_f64()
                    );
                }
                std::thread::sleep(Duration::from_millis(20));
            };
            match died {
                None => break,
                Some(thread) if attempt < MAX_REBUILD_ATTEMPTS => tracing::error!(
                    "the replay's rebuilt DDS participant died too (thread {thread} ended) before a node subscribed again: rebuilding it again ({attempt} of {MAX_REBUILD_ATTEMPTS})"
                ),
                Some(thread) => bail!(
                    "the replay's DDS participant died {MAX_REBUILD_ATTEMPTS} times in a row (thread {thread} ended) before a node subscribed again: giving up"
                ),
            }
        }
        let deadline = Instant::now() + PREVIOUS_REPORT_WAIT;
        loop {
            self.read_reports();
            let heard = self
                .lanes
                .iter()
                .all(|l| l.delivery.sent == 0 || l.delivery.watch.previous_heard());
            if heard || Instant::now() >= deadline {
                break;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        let (mut taken_all, mut sent_all, mut again_all) = (0, 0, 0);
        let wait = self.wait;
        for lane in &mut self.lanes {
            // Every node has the packets up to the one that took fewest; the others are
            // sent again from there (a node that had them drops them as duplicates).
            let d = &mut lane.delivery;
            d.base += d.watch.previous_least_taken();
            let first_kept = d.sent - lane.recent.len() as u64;
            if d.base < first_kept {
                bail!(
                    "the replay's DDS participant was rebuilt, but a node of {} has taken only {} of {} packets and the replay kept only the last {}",
                    lane.topic,
                    d.base,
                    d.sent,
                    lane.recent.len()
                );
            }
            d.base = d.base.min(d.sent);
            let (base, sent) = (d.base, d.sent);
            let again: Vec<msg::AccelPacket> = lane
                .recent
                .iter()
                .skip((base - first_kept) as usize)
                .cloned()
                .collect();
            for m in &again {
                lane.write(m.clone(), wait)?;
            }
            lane.delivery.resent += again.len() as u64;
            taken_all += base;
            sent_all += sent;
            again_all += again.len();
        }
        self.rebuilds += 1;
        tracing::info!(
            "replay participant rebuilt: every node had taken {taken_all} of {sent_all} packets; {again_all} sent again"
        );
        Ok(())
    }

    /// How long [`PacketSink::send`] and [`PacketSink::finish`] wait for the node's reports
    /// to move before giving up.
    pub fn set_wait(&mut self, wait: Duration) {
        self.wait = wait;
    }

    /// Sends a raw message (tests of malformed input), without flow control, on the lane of
    /// its `frame_id`.
    pub fn send_msg(&mut self, m: msg::AccelPacket) -> anyhow::Result<()> {
        let lane = self.lane_of(&m.header.frame_id);
        let wait = self.wait;
        self.lanes[lane].write(m, wait)
    }

    /// Packets sent so far, and of those the node(s) have reported taken.
    pub fn progress(&mut self) -> (u64, u64) {
        self.read_reports();
        self.lanes.iter().fold((0, 0), |(s, t), l| {
            (s + l.delivery.sent, t + l.delivery.confirmed())
        })
    }

    /// Waits until at most `unreported` packets of lane `lane` are not reported taken by its
    /// nodes; false if the reports stood still for the wait ([`Ros2PacketSink::set_wait`]).
    fn wait_for_intake(&mut self, lane: usize, unreported: u64) -> anyhow::Result<bool> {
        self.read_reports();
        let mut taken = self.lanes[lane].delivery.confirmed();
        let mut last_move = Instant::now();
        while self.lanes[lane].delivery.unconfirmed() > unreported {
            std::thread::sleep(Duration::from_micros(200));
            self.keep_alive()?;
            self.read_reports();
            let now = self.lanes[lane].delivery.confirmed();
            if now != taken {
                taken = now;
                last_move = Instant::now();
            } else if last_move.elapsed() >= self.wait {
                return Ok(false);
            }
        }
        Ok(true)
    }

    /// Waits until every node that reported on lane `lane` has processed every packet sent
    /// on it; false if their reports stood still for the wait ([`Ros2PacketSink::set_wait`]).
    fn wait_for_processing(&mut self, lane: usize) -> anyhow::Result<bool> {
        let mut last = None;
        let mut last_move = Instant::now();
        loop {
            self.keep_alive()?;
            self.read_reports();
            let (processed, done) = self.lanes[lane].delivery.processing();
            if done {
                return Ok(true);
            }
            if last.as_ref() != Some(&processed) {
                last = Some(processed);
                last_move = Instant::now();
            } else if last_move.elapsed() >= self.wait {
                return Ok(false);
            }
            std::thread::sleep(Duration::from_micros(500));
        }
    }

    /// One line on why the nodes of lane `lane` have not processed everything.
    fn shortfall(&mut self, lane: usize) -> String {
        let (wait, partitioned) = (self.wait, self.map.is_some());
        self.read_reports();
        let l = &mut self.lanes[lane];
        l.matched_readers();
        let on = if partitioned {
            format!(" on {}", l.topic)
        } else {
            String::new()
        };
        l.delivery.shortfall(&l.matched, wait, &on, INTAKE_TOPIC)
    }

    /// One line on every node that refused packets or dropped them as data it had, if any.
    fn refusals(&self) -> Option<String> {
        let lines: Vec<String> = self
            .lanes
            .iter()
            .flat_map(|l| {
                let on = if self.map.is_some() {
                    format!(" on {}", l.topic)
                } else {
                    String::new()
                };
                l.delivery
                    .refusals()
                    .into_iter()
                    .map(move |r| format!("{r}{on}"))
            })
            .collect();
        (!lines.is_empty()).then(|| refusal_line(&lines))
    }

    /// Subscribers of every lane that never reported what they took (not rockwatch nodes).
    fn silent_subscribers(&mut self) -> usize {
        self.lanes
            .iter_mut()
            .map(|l| {
                l.matched_readers();
                l.delivery.silent(&l.matched)
            })
            .sum()
    }
}

impl PacketSink for Ros2PacketSink {
    /// Every lane's topic has a reader (with partitions: every partition's node is there).
    /// A participant that dies meanwhile is rebuilt (and the wait goes on).
    fn wait_for_subscriber(&mut self, timeout: Duration) -> anyhow::Result<bool> {
        let deadline = Instant::now() + timeout;
        loop {
            if self.lanes.iter_mut().all(|l| l.matched_readers() > 0) {
                return Ok(true);
            }
            if Instant::now() >= deadline {
                return Ok(false);
            }
            self.keep_alive()?;
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    /// The participant's liveness: a sender that waits for data (acquire) still notices
    /// its participant's death, and rebuilds it, while it has nothing to send.
    fn tick(&mut self) -> anyhow::Result<()> {
        self.keep_alive()
    }

    fn send(&mut self, packet: &AccelPacket) -> anyhow::Result<()> {
        self.keep_alive()?;
        let lane = self.lane_of(packet.station.as_str());
        self.read_reports();
        let window = self.lanes[lane].delivery.window(CREDIT_WINDOW);
        if !self.wait_for_intake(lane, window - 1)? {
            bail!("{}", self.shortfall(lane));
        }
        let m = msg::AccelPacket::from(packet);
        let l = &mut self.lanes[lane];
        if l.stations.len() < NAMED_STATIONS && !l.stations.contains(packet.station.as_str()) {
            l.stations.insert(packet.station.to_string());
        }
        if l.recent.len() == CREDIT_WINDOW as usize {
            l.recent.pop_front();
        }
        l.recent.push_back(m.clone());
        l.write(m, self.wait)?;
        l.delivery.sent += 1;
        Ok(())
    }

    /// `/diagnostics` on this sender's participant, never waiting ([`sender_status_qos`]).
    fn status(&mut self, report: StatusReport) -> anyhow::Result<()> {
        let writer = match self.diagnostics.take() {
            Some(writer) => writer,
            None => DiagnosticsWriter::open(&mut self._session, sender_status_qos())?,
        };
        let published = writer.publish(DiagnosticArray::from(report));
        self.diagnostics = Some(writer);
        published
    }

    /// Waits until every node that reports has processed every packet; fails naming each
    /// node that did not, that refused or dropped packets, or that ignored some (a station it does not
    /// monitor: nothing the replay sent about it was processed).
    fn finish(&mut self, timeout: Duration) -> anyhow::Result<bool> {
        self.wait = timeout;
        for lane in 0..self.lanes.len() {
            if self.lanes[lane].delivery.sent > 0 && !self.wait_for_processing(lane)? {
                bail!("{}", self.shortfall(lane));
            }
        }
        self.read_reports();
        if let Some(refusals) = self.refusals() {
            bail!("{refusals}");
        }
        let ignored: u64 = self.lanes.iter().map(|l| l.delivery.ignored()).sum();
        if ignored > 0 {
            bail!("{}", self.ignored_line(ignored));
        }
        let silent = self.silent_subscribers();
        if silent > 0 {
            tracing::warn!(
                "{silent} subscriber(s) of the replay's topic never reported on {INTAKE_TOPIC} what they took (not rockwatch nodes, e.g. `ros2 topic echo` or a recorder): not checked"
            );
        }
        Ok(true)
    }
}
