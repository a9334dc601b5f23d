//! The intake report protocol, transport-independent (ROS 2: `/pbr/intake`,
//! `pbr_msgs/IntakeReport`; iceoryx2: the `<accel service>/intake` service): each node tells
//! each sender of packets what it made of that sender's packets ([`WriterCounts`], node side),
//! and a sender follows what every node made of its own writer ([`IntakeWatch`], sender side).
//! A replay so knows that every node processed everything it sent — or exactly which node did
//! not, and how much — and paces itself within the window each node grants it, so that no
//! node's input buffer (shared by every sender on ROS 2, one per sender on iceoryx2) ever
//! overflows.
//!
//! Counts are per writer (a DDS writer GUID, an iceoryx2 publisher id: 16 bytes) and per node
//! (a random id drawn when the node process starts, so it survives a rebuild of the node's DDS
//! participant; a restarted node is a new node).

use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::sync::Arc;
use std::time::{Duration, Instant};

use rockwatch_core::engine::{Source, SourceCounts, SourceTally, MAX_SOURCES};

/// Most writers a node keeps counts for; beyond, the least recently heard is forgotten.
pub const MAX_WRITERS: usize = MAX_SOURCES;

/// A writer's count is reported once it has grown by this many messages …
pub const REPORT_EVERY: u64 = 128;

/// … or this long after it last changed (taken, processed, refused or dropped), whichever comes
/// first.
pub const REPORT_PERIOD: Duration = Duration::from_millis(10);

/// Every writer heard from within [`REPORT_RECENT`] is reported again this often (for a sender
/// whose report subscription matched late, or was rebuilt).
pub const REPORT_REFRESH: Duration = Duration::from_secs(1);

/// See [`REPORT_REFRESH`]; also: the writers a node shares its input buffer among.
pub const REPORT_RECENT: Duration = Duration::from_secs(10);

/// The smallest window a node grants a writer (packets sent but not yet reported taken): the
/// node's buffer divided among its writers may be less than one packet each, and a writer
/// must still make progress (then the buffer may overflow: `[ros2] input_depth` should be at
/// least twice the number of concurrent senders).
pub const MIN_WINDOW: u64 = 1;

/// The window of a writer before any node has reported on it: one packet, whose report
/// (within [`REPORT_PERIOD`] of its intake) grants the real one. However many senders start
/// at once, none can overflow a node's buffer before it has heard from the node.
pub const INITIAL_WINDOW: u64 = 1;

/// What one node reports about one writer.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct IntakeCount {
    /// The reporting node: a random id of its process.
    pub node_id: [u8; 16],
    /// The node's name, for people: `<fully qualified name> (pid <pid>)`.
    pub node: String,
    /// The node's reader of the writer's packets (a DDS reader GUID, an iceoryx2 subscriber
    /// id): which of the writer's matched readers this node is.
    pub reader: [u8; 16],
    /// The writer.
    pub writer: [u8; 16],
    /// Messages taken from the writer since the node first heard from it.
    pub taken: u64,
    /// Of `taken`, packets of a station the node does not monitor (the engine ignores them).
    pub ignored: u64,
    /// Of `taken`, packets the engine has processed (every verdict, `ignored` included).
    pub processed: u64,
    /// Of `processed`, packets refused whole (malformed, implausible, stamped ahead of the
    /// node's clock; each logged by the node, naming its station).
    pub refused: u64,
    /// Accepted packets whose samples were dropped, wholly or in part, because their station
    /// had processed them or later data already (duplicate, late or overlapping data; the node
    /// logs each span, naming the station). New samples of a packet that overlaps in part are
    /// processed; the packet counts here for its old ones.
    pub dropped: u64,
    /// Packets the writer may have sent beyond `taken`: the node's input buffer shared among
    /// the writers it heard from within [`REPORT_RECENT`] (at least [`MIN_WINDOW`]).
    pub window: u64,
}

#[derive(Debug, Clone, Copy)]
struct Count {
    slot: Source,
    /// The tally of `slot` when it was given to this writer (a slot is reused after a writer
    /// is forgotten).
    tally_base: SourceCounts,
    taken: u64,
    /// Of `taken`, packets of a station the node does not monitor.
    ignored: u64,
    /// Highest sequence number taken.
    last_sn: i64,
    /// Taken, and the tally since `tally_base`, at the last report.
    reported: (u64, SourceCounts),
    last_report: Instant,
    last_heard: Instant,
}

/// Node side: what the node made of each writer's packets (bounded by [`MAX_WRITERS`]) and
/// which reports are due.
#[derive(Debug)]
pub struct WriterCounts {
    counts: HashMap<[u8; 16], Count>,
    /// Slots never used yet: `next..MAX_WRITERS`.
    next: usize,
    tally: Arc<SourceTally>,
    node_id: [u8; 16],
    node: String,
    /// The node's input buffer (packets), shared among recent writers unless `per_writer`.
    depth: u64,
    /// Each writer has a buffer of `depth` of its own (iceoryx2: one per connection).
    per_writer: bool,
    /// A count grew by [`REPORT_EVERY`] since its report: report without waiting.
    urgent: bool,
    /// Something is not reported yet: a message taken since the last scan, or one taken and
    /// not yet processed then ([`WriterCounts::pending`]).
    pending: bool,
    last_scan: Instant,
    last_refresh: Instant,
    /// Writers forgotten to stay within [`MAX_WRITERS`].
    pub forgotten: u64,
}

/// What became of a message taken ([`WriterCounts::taken`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Taken {
    /// New: hand it to the engine with its writer's slot.
    New(Source),
    /// Its sequence number is not above the writer's highest so far (a reliable writer
    /// delivers in order: a redelivery to a rebuilt reader): skip it.
    Redelivered,
}

impl WriterCounts {
    /// Counts of node `node` (`node_id`: its process's id, [`node_id`]) whose engine counts
    /// verdicts in `tally`, with an input buffer of `depth` packets shared by all writers.
    #[must_use]
    pub fn new(node_id: [u8; 16], node: String, tally: Arc<SourceTally>, depth: u64) -> Self {
        let now = Instant::now();
        WriterCounts {
            counts: HashMap::new(),
            next: 0,
            tally,
            node_id,
            node,
            depth,
            per_writer: false,
            urgent: false,
            pending: false,
            last_scan: now - REPORT_PERIOD,
            last_refresh: now,
            forgotten: 0,
        }
    }

    /// Each writer has an input buffer of `depth` packets of its own (not shared): its window
    /// is half of it, however many writers there are.
    #[must_use]
    pub fn per_writer_buffer(mut self) -> Self {
        self.per_writer = true;
        self
    }

    /// A message of sequence number `sn` taken from `writer`, of a station the node
    /// `monitored` or not (then counted as ignored too).
    pub fn taken(&mut self, writer: [u8; 16], sn: i64, monitored: bool) -> Taken {
        let now = Instant::now();
        if !self.counts.contains_key(&writer) {
            let slot = self.slot();
            let tally_base = self.tally.of(slot);
            self.counts.insert(
                writer,
                Count {
                    slot,
                    tally_base,
                    taken: 0,
                    ignored: 0,
                    last_sn: i64::MIN,
                    reported: (0, SourceCounts::default()),
                    last_report: now - REPORT_PERIOD,
                    last_heard: now,
                },
            );
        }
        let Some(count) = self.counts.get_mut(&writer) else {
            return Taken::Redelivered; // unreachable: inserted above
        };
        count.last_heard = now;
        if sn <= count.last_sn {
            return Taken::Redelivered;
        }
        count.last_sn = sn;
        count.taken += 1;
        count.ignored += u64::from(!monitored);
        self.pending = true;
        self.urgent |= count.taken - count.reported.0 >= REPORT_EVERY;
        Taken::New(count.slot)
    }

    /// A free slot: one never used, else the least recently heard writer's (forgotten now:
    /// every slot then belongs to a writer).
    fn slot(&mut self) -> Source {
        if let Some(slot) = Source::new(self.next) {
            self.next += 1;
            return slot;
        }
        let (gid, slot) = self
            .counts
            .iter()
            .min_by_key(|(_, c)| c.last_heard)
            .map(|(g, c)| (*g, c.slot))
            .unwrap_or_else(|| unreachable!("all {MAX_WRITERS} slots belong to writers"));
        self.counts.remove(&gid);
        self.forgotten += 1;
        slot
    }

    /// Whether a report will be due without any new message (one taken since the last report,
    /// or taken and not yet processed): an event loop then looks again within
    /// [`REPORT_PERIOD`] instead of sleeping.
    #[must_use]
    pub fn pending(&self) -> bool {
        self.pending
    }

    /// Messages taken from `writer` so far (0 if unknown or forgotten).
    #[must_use]
    pub fn of(&self, writer: [u8; 16]) -> u64 {
        self.counts.get(&writer).map_or(0, |c| c.taken)
    }

    /// Hands `publish` the reports due now, as read by `reader` (the node's reader of the
    /// writers' packets): a count that changed (taken, processed, refused, dropped) [`REPORT_EVERY`]
    /// messages or [`REPORT_PERIOD`] after its last report (`force`: now), and, every
    /// [`REPORT_REFRESH`], every count heard from within [`REPORT_RECENT`]. Cheap when nothing
    /// is due (one look at the clock): call it after every turn of the event loop.
    pub fn due(&mut self, force: bool, reader: [u8; 16], publish: &mut impl FnMut(IntakeCount)) {
        let now = Instant::now();
        if !(force || self.urgent || now.duration_since(self.last_scan) >= REPORT_PERIOD) {
            return;
        }
        self.last_scan = now;
        self.urgent = false;
        let refresh = now.duration_since(self.last_refresh) >= REPORT_REFRESH;
        if refresh {
            self.last_refresh = now;
        }
        let recent = self
            .counts
            .values()
            .filter(|c| now.duration_since(c.last_heard) < REPORT_RECENT)
            .count() as u64;
        let sharing = if self.per_writer { 1 } else { recent.max(1) };
        let window = (self.depth / (2 * sharing)).max(MIN_WINDOW);
        let mut pending = false;
        for (gid, c) in &mut self.counts {
            if now.duration_since(c.last_heard) >= REPORT_RECENT
                && c.reported.0 == c.taken
                && !force
            {
                continue;
            }
            let now_counts = (c.taken, self.tally.of(c.slot).since(c.tally_base));
            let changed = now_counts != c.reported;
            pending |= now_counts.1.processed < c.taken;
            let due = refresh && now.duration_since(c.last_heard) < REPORT_RECENT
                || changed
                    && (force
                        || c.taken - c.reported.0 >= REPORT_EVERY
                        || now.duration_since(c.last_report) >= REPORT_PERIOD);
            if !due {
                pending |= changed;
                continue;
            }
            publish(IntakeCount {
                node_id: self.node_id,
                node: self.node.clone(),
                reader,
                writer: *gid,
                taken: c.taken,
                ignored: c.ignored,
                processed: now_counts.1.processed,
                refused: now_counts.1.refused,
                dropped: now_counts.1.dropped,
                window,
            });
            c.reported = now_counts;
            c.last_report = now;
        }
        self.pending = pending;
    }
}

/// A random id for this node process (the `node_id` of its reports): its pid, the time and
/// the address of a local, through the standard library's randomly keyed hasher.
#[must_use]
pub fn node_id() -> [u8; 16] {
    use std::hash::{BuildHasher, Hasher};
    let state = std::collections::hash_map::RandomState::new();
    let mut halves = [0u64; 2];
    for (i, half) in halves.iter_mut().enumerate() {
        let mut h = state.build_hasher();
        h.write_usize(i);
        h.write_u32(std::process::id());
        let t = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_nanos());
        h.write_u128(t);
        h.write_usize(std::ptr::from_ref(&t) as usize);
        *half = h.finish();
    }
    let mut id = [0u8; 16];
    id[..8].copy_from_slice(&halves[0].to_le_bytes());
    id[8..].copy_from_slice(&halves[1].to_le_bytes());
    id
}

/// What one node reported of one writer.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Intake {
    pub taken: u64,
    pub ignored: u64,
    pub processed: u64,
    pub refused: u64,
    pub dropped: u64,
    /// The window the node grants (0: not said).
    pub window: u64,
}

impl Intake {
    fn merge(&mut self, report: &IntakeCount) {
        // Reports may arrive out of order: counts only grow; the window is the latest.
        if report.taken >= self.taken {
            self.window = report.window;
        }
        self.taken = self.taken.max(report.taken);
        self.ignored = self.ignored.max(report.ignored);
        self.processed = self.processed.max(report.processed);
        self.refused = self.refused.max(report.refused);
        self.dropped = self.dropped.max(report.dropped);
    }
}

/// What one node made of a sender's writer (and of its previous writer).
#[derive(Debug, Clone, Default)]
pub struct NodeIntake {
    /// The node's name ([`IntakeCount::node`]).
    pub node: String,
    /// The node's reader of the writer, as of its last report.
    pub reader: [u8; 16],
    /// Of the current writer.
    pub now: Intake,
    /// Of the previous writer (after [`IntakeWatch::switch`]), and whether a report about it
    /// came since the switch.
    pub previous: Option<(Intake, bool)>,
    /// Ignored, refused and dropped packets of the writers before the previous one.
    carried: Intake,
}

impl NodeIntake {
    /// Packets ignored (a station the node does not monitor) over every writer followed.
    #[must_use]
    pub fn ignored_total(&self) -> u64 {
        self.carried.ignored + self.previous.map_or(0, |(p, _)| p.ignored) + self.now.ignored
    }

    /// Packets refused over every writer followed.
    #[must_use]
    pub fn refused_total(&self) -> u64 {
        self.carried.refused + self.previous.map_or(0, |(p, _)| p.refused) + self.now.refused
    }

    /// Packets whose samples were dropped as already processed, over every writer followed.
    #[must_use]
    pub fn dropped_total(&self) -> u64 {
        self.carried.dropped + self.previous.map_or(0, |(p, _)| p.dropped) + self.now.dropped
    }
}

/// Sender side: what every node has made of one writer, from their reports (and of the
/// sender's previous writer, whose participant died: [`IntakeWatch::switch`]). The sender
/// reads the reports from one subscription and [offers](IntakeWatch::offer) each to the
/// watch of every writer it has.
#[derive(Debug)]
pub struct IntakeWatch {
    writer: [u8; 16],
    previous: Option<[u8; 16]>,
    nodes: BTreeMap<[u8; 16], NodeIntake>,
    /// Reports about the current writer received.
    pub heard: u64,
}

impl IntakeWatch {
    #[must_use]
    pub fn new(writer: [u8; 16]) -> IntakeWatch {
        IntakeWatch {
            writer,
            previous: None,
            nodes: BTreeMap::new(),
            heard: 0,
        }
    }

    /// Takes `report` into account if it is about the writer or the previous one.
    pub fn offer(&mut self, report: &IntakeCount) {
        let current = report.writer == self.writer;
        if !current && self.previous != Some(report.writer) {
            return;
        }
        let node = self.nodes.entry(report.node_id).or_default();
        if node.node.is_empty() {
            node.node.clone_from(&report.node);
        }
        if current {
            self.heard += 1;
            node.reader = report.reader;
            node.now.merge(report);
        } else {
            let (intake, heard) = node.previous.get_or_insert((Intake::default(), false));
            intake.merge(report);
            *heard = true;
        }
    }

    /// Every node that reported on the writer (or the previous one), by id.
    pub fn nodes(&self) -> impl Iterator<Item = &NodeIntake> {
        self.nodes.values()
    }

    /// Packets of the current writer taken by the node that took fewest (None: no report yet).
    #[must_use]
    pub fn least_taken(&self) -> Option<u64> {
        self.nodes.values().map(|n| n.now.taken).min()
    }

    /// The window every node grants: the smallest reported (None: no node said one).
    #[must_use]
    pub fn window(&self) -> Option<u64> {
        self.nodes
            .values()
            .map(|n| n.now.window)
            .filter(|w| *w > 0)
            .min()
    }

    /// Follows `writer` (a new participant's) from now on; the writer followed so far becomes
    /// the previous one: each node's count of it is kept ([`NodeIntake::previous`]).
    pub fn switch(&mut self, writer: [u8; 16]) {
        self.previous = Some(self.writer);
        self.writer = writer;
        self.heard = 0;
        for node in self.nodes.values_mut() {
            if let Some((before, _)) = node.previous {
                node.carried.ignored += before.ignored;
                node.carried.refused += before.refused;
                node.carried.dropped += before.dropped;
            }
            node.previous = Some((node.now, false));
            node.now = Intake::default();
        }
    }

    /// Follows `writer` instead of the current writer, which sent nothing (a new participant
    /// that died before sending): the previous writer stays the previous one.
    pub fn retarget(&mut self, writer: [u8; 16]) {
        self.writer = writer;
        self.heard = 0;
        for node in self.nodes.values_mut() {
            node.now = Intake::default();
        }
    }

    /// Whether every node has reported on the previous writer since the switch (the nodes
    /// repeat every count of the last 10 s each second, so one comes soon after a switch).
    #[must_use]
    pub fn previous_heard(&self) -> bool {
        self.nodes
            .values()
            .all(|n| n.previous.is_none_or(|(_, heard)| heard))
    }

    /// Packets of the previous writer taken by the node that took fewest.
    #[must_use]
    pub fn previous_least_taken(&self) -> u64 {
        self.nodes
            .values()
            .filter_map(|n| n.previous.map(|(i, _)| i.taken))
            .min()
            .unwrap_or(0)
    }
}

/// Sender side, one writer: packets sent, what every node made of them ([`IntakeWatch`]), and
/// the lines that say what is missing. The transports' senders (ROS 2 and iceoryx2 replay
/// sinks) wait on it and report from it.
#[derive(Debug)]
pub struct Delivery {
    pub watch: IntakeWatch,
    /// Distinct packets sent (each sent again after a rebuild counted once).
    pub sent: u64,
    /// Packets of the writers before the current one that every node took: the current
    /// writer's k-th message is packet `base + k - 1`.
    pub base: u64,
    /// Packets sent again to a new writer after a rebuild: a node that had taken them from
    /// the dead writer drops them as duplicates, up to this many drops are expected.
    pub resent: u64,
}

impl Delivery {
    #[must_use]
    pub fn new(writer: [u8; 16]) -> Delivery {
        Delivery {
            watch: IntakeWatch::new(writer),
            sent: 0,
            base: 0,
            resent: 0,
        }
    }

    /// Packets the node furthest behind has reported taken (0 before any report).
    #[must_use]
    pub fn confirmed(&self) -> u64 {
        (self.base + self.watch.least_taken().unwrap_or(0)).min(self.sent)
    }

    /// Packets `node` has reported processed.
    #[must_use]
    pub fn processed(&self, node: &NodeIntake) -> u64 {
        (self.base + node.now.processed).min(self.sent)
    }

    /// Packets sent that the node furthest behind has not reported taken.
    #[must_use]
    pub fn unconfirmed(&self) -> u64 {
        self.sent - self.confirmed()
    }

    /// The window every node grants, at most `cap` ([`INITIAL_WINDOW`] before any report).
    #[must_use]
    pub fn window(&self, cap: u64) -> u64 {
        self.watch.window().unwrap_or(INITIAL_WINDOW).min(cap)
    }

    /// Each reporting node's processed count (the progress a wait watches), and whether every
    /// one has processed every packet sent (false with no node at all).
    #[must_use]
    pub fn processing(&self) -> (Vec<u64>, bool) {
        let processed: Vec<u64> = self.watch.nodes().map(|n| self.processed(n)).collect();
        let done = !processed.is_empty() && processed.iter().all(|p| *p >= self.sent);
        (processed, done)
    }

    /// Packets ignored (a station the node does not monitor) by the node that ignored most.
    #[must_use]
    pub fn ignored(&self) -> u64 {
        self.watch
            .nodes()
            .map(NodeIntake::ignored_total)
            .max()
            .unwrap_or(0)
    }

    /// One phrase per node that refused packets or dropped their samples (beyond the
    /// duplicates of packets [sent again](Delivery::resent)).
    #[must_use]
    pub fn refusals(&self) -> Vec<String> {
        let dropped = |n: &NodeIntake| n.dropped_total().saturating_sub(self.resent);
        self.watch
            .nodes()
            .filter(|n| n.refused_total() > 0 || dropped(n) > 0)
            .map(|n| {
                let mut what = Vec::with_capacity(2);
                if n.refused_total() > 0 {
                    what.push(format!("refused {}", n.refused_total()));
                }
                if dropped(n) > 0 {
                    what.push(format!(
                        "dropped the samples (all or some) of {} as already processed",
                        dropped(n)
                    ));
                }
                format!(
                    "{} {} of the {} packets sent",
                    n.node,
                    what.join(" and "),
                    self.sent
                )
            })
            .collect()
    }

    /// One phrase per node that has not processed every packet, with why, `matched` being
    /// the writer's readers now.
    #[must_use]
    pub fn behind(&self, matched: &BTreeSet<[u8; 16]>) -> Vec<String> {
        self.watch
            .nodes()
            .filter(|n| self.processed(n) < self.sent)
            .map(|n| {
                let taken = (self.base + n.now.taken).min(self.sent);
                let processed = self.processed(n);
                let why = if !matched.contains(&n.reader) {
                    "it went away"
                } else if taken < self.sent {
                    "not taken: lost on the way, or the node is stalled"
                } else {
                    "taken, not yet processed"
                };
                format!(
                    "{} took {taken} and processed {processed}, {} not processed ({why})",
                    n.node,
                    self.sent - processed
                )
            })
            .collect()
    }

    /// The line on why not every node processed every packet sent `on` (a topic, or empty),
    /// within `wait`; `matched` are the writer's readers now, `reports` where nodes report.
    #[must_use]
    pub fn shortfall(
        &self,
        matched: &BTreeSet<[u8; 16]>,
        wait: Duration,
        on: &str,
        reports: &str,
    ) -> String {
        let (sent, wait) = (self.sent, wait.as_secs_f64());
        if self.watch.nodes().next().is_none() {
            let why = if matched.is_empty() {
                "no subscriber left"
            } else {
                "subscribed, silent"
            };
            return format!(
                "sent {sent} packets{on}, but no node reported on {reports} what it took within {wait:.0} s ({why}; is the subscriber a rockwatch node of this version?)"
            );
        }
        format!(
            "sent {sent} packets{on}, but not every node processed them within {wait:.0} s: {}",
            self.behind(matched).join("; ")
        )
    }

    /// Readers in `matched` that no node names as its own: subscribers that do not report
    /// (not rockwatch nodes).
    #[must_use]
    pub fn silent(&self, matched: &BTreeSet<[u8; 16]>) -> usize {
        let reporting: BTreeSet<[u8; 16]> = self.watch.nodes().map(|n| n.reader).collect();
        matched.difference(&reporting).count()
    }
}

/// The error line of a sender whose packets nodes refused or dropped (`lines`: one per node,
/// [`Delivery::refusals`]).
#[must_use]
pub fn refusal_line(lines: &[String]) -> String {
    format!(
        "{} (refused: malformed, implausible, or stamped ahead of the node's clock; dropped: the station had that data, or later data, already — a replay onto a live station, or a stream sent twice; the node's log names each packet or span and its station)",
        lines.join("; ")
    )
}

/// The line on `ignored` of `sent` packets that a node does not monitor the station of (among
/// `stations`, the first five named; `partitioned`: or of another partition's station).
#[must_use]
pub fn ignored_line(
    ignored: u64,
    sent: u64,
    stations: &BTreeSet<&str>,
    partitioned: bool,
) -> String {
    let named: Vec<&str> = stations.iter().take(5).copied().collect();
    let more = stations.len().saturating_sub(named.len());
    format!(
        "the node ignored {ignored} of the {sent} packets sent: it does not monitor their station (neither in its [[station]] nor bound to a block of its catalogue{}); among {}{} (the node's log names the station: unknown_station)",
        if partitioned {
            ", or the station belongs to another partition"
        } else {
            ""
        },
        named.join(", "),
        if more > 0 {
            format!(" and {more} more")
        } else {
            String::new()
        }
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use rockwatch_core::engine::Verdict;

    fn gid(n: u8) -> [u8; 16] {
        [n; 16]
    }

    fn counts(depth: u64) -> (WriterCounts, Arc<SourceTally>) {
        let tally = Arc::new(SourceTally::default());
        (
            WriterCounts::new(gid(9), "/n (pid 1)".into(), Arc::clone(&tally), depth),
            tally,
        )
    }

    #[test]
    fn counts_are_reported_when_grown_with_their_verdicts_and_bounded_in_writers() {
        let (mut counts, tally) = counts(1000);
        let mut got = Vec::new();
        for sn in 1..=REPORT_EVERY as i64 {
            // Every fourth packet of a station the node does not monitor.
            let Taken::New(slot) = counts.taken(gid(1), sn, sn % 4 != 0) else {
                panic!("new message taken as a redelivery")
            };
            let verdict = if sn % 4 == 0 {
                Verdict::Ignored
            } else if sn % 8 == 1 {
                Verdict::Refused
            } else {
                Verdict::Accepted
            };
            tally.count(slot, verdict);
        }
        // A redelivery (sequence number not above the highest) is skipped, not counted.
        assert_eq!(counts.taken(gid(1), 5, false), Taken::Redelivered);
        counts.due(false, gid(7), &mut |r| got.push(r));
        assert_eq!(got.len(), 1);
        assert_eq!(got[0].taken, REPORT_EVERY);
        assert_eq!(got[0].ignored, REPORT_EVERY / 4);
        assert_eq!(got[0].processed, REPORT_EVERY);
        assert_eq!(got[0].refused, REPORT_EVERY / 8);
        assert_eq!((got[0].reader, got[0].node_id), (gid(7), gid(9)));
        assert_eq!(got[0].window, 500, "one writer: half the depth");
        assert!(matches!(
            counts.taken(gid(1), REPORT_EVERY as i64 + 1, true),
            Taken::New(_)
        ));
        counts.due(false, gid(7), &mut |r| got.push(r));
        assert_eq!(got.len(), 1, "one more message, within the period: not due");
        counts.due(true, gid(7), &mut |r| got.push(r));
        assert_eq!(got.last().unwrap().taken, REPORT_EVERY + 1);
        // A second writer halves every writer's window.
        counts.taken(gid(2), 1, true);
        counts.due(true, gid(7), &mut |r| got.push(r));
        assert_eq!(got.last().unwrap().window, 250);
        // Bounded: the least recently heard writer is forgotten and its slot reused.
        for n in 0..MAX_WRITERS + 5 {
            let mut bytes = [7u8; 16];
            bytes[..8].copy_from_slice(&(n as u64).to_le_bytes());
            counts.taken(bytes, 1, true);
        }
        assert_eq!(counts.counts.len(), MAX_WRITERS);
        assert_eq!(counts.forgotten, 7);
        assert_eq!(counts.of(gid(1)), 0);
        // Many writers: never below the smallest window.
        counts.due(true, gid(7), &mut |r| got.push(r));
        // 1024 writers share 1000 packets: less than one each.
        assert_eq!(got.last().unwrap().window, MIN_WINDOW);
    }

    #[test]
    fn a_reused_slot_starts_from_zero() {
        let (mut counts, tally) = counts(100);
        // Fill every slot, refuse a packet of the first writer, then a new writer takes the
        // least recently heard writer's slot.
        let mut first = None;
        for n in 0..MAX_WRITERS {
            let mut bytes = [3u8; 16];
            bytes[..8].copy_from_slice(&(n as u64).to_le_bytes());
            if let Taken::New(slot) = counts.taken(bytes, 1, true) {
                tally.count(slot, Verdict::Refused);
                first.get_or_insert(slot);
            }
            if n == 0 {
                std::thread::sleep(Duration::from_millis(1));
            }
        }
        let Taken::New(slot) = counts.taken(gid(200), 1, true) else {
            panic!()
        };
        assert_eq!(Some(slot), first, "the least recently heard writer's slot");
        tally.count(slot, Verdict::Accepted);
        let mut got = Vec::new();
        counts.due(true, gid(7), &mut |r| got.push(r));
        let mine = got.iter().find(|r| r.writer == gid(200)).unwrap();
        assert_eq!((mine.processed, mine.refused), (1, 0));
    }

    #[test]
    fn a_watch_follows_every_node_of_its_writer_and_after_a_switch_their_previous_counts() {
        let report = |node: u8, writer: u8, taken: u64, window: u64| IntakeCount {
            node_id: [node; 16],
            node: format!("/n{node}"),
            reader: [node + 100; 16],
            writer: [writer; 16],
            taken,
            ignored: 0,
            processed: taken,
            refused: 0,
            dropped: 0,
            window,
        };
        let mut watch = IntakeWatch::new(gid(1));
        assert_eq!(watch.least_taken(), None);
        watch.offer(&report(1, 2, 50, 100)); // another sender's writer
        watch.offer(&report(1, 1, 10, 100));
        watch.offer(&report(1, 1, 7, 90)); // an older report, delivered late
        watch.offer(&report(2, 1, 4, 60)); // a second node, behind
        assert_eq!(watch.least_taken(), Some(4));
        assert_eq!(watch.window(), Some(60));
        assert_eq!(watch.nodes().count(), 2);
        assert_eq!(watch.nodes().next().unwrap().now.window, 100);
        assert_eq!(watch.heard, 3);
        watch.switch(gid(6));
        // That participant died before sending: its successor takes its place, and the
        // previous writer stays writer 1.
        watch.retarget(gid(3));
        assert!(!watch.previous_heard());
        assert_eq!(watch.previous_least_taken(), 4);
        watch.offer(&report(1, 1, 12, 100));
        assert!(!watch.previous_heard(), "node 2 not heard since");
        watch.offer(&report(2, 1, 9, 100));
        assert!(watch.previous_heard());
        assert_eq!(watch.previous_least_taken(), 9);
        watch.offer(&report(2, 3, 4, 100));
        assert_eq!(
            watch.least_taken(),
            Some(0),
            "node 1: nothing of the new writer yet"
        );
        // Refusals and ignored packets add up over every writer, through a second switch.
        let mut refusing = report(2, 3, 6, 100);
        refusing.refused = 2;
        refusing.ignored = 1;
        watch.offer(&refusing);
        watch.switch(gid(4));
        let mut later = report(2, 4, 3, 100);
        later.refused = 1;
        later.dropped = 2;
        watch.offer(&later);
        watch.switch(gid(5));
        let node2 = watch.nodes().nth(1).unwrap();
        assert_eq!(
            (
                node2.refused_total(),
                node2.ignored_total(),
                node2.dropped_total()
            ),
            (3, 1, 2)
        );
    }
}
