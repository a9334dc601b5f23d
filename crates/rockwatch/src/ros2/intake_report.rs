//! The intake report protocol of `/pbr/intake` (`pbr_msgs/IntakeReport`): the node tells each
//! sender of `/pbr/accel` how many of its messages it has taken, and how many of those it
//! ignored (a station it does not monitor) ([`WriterCounts`], node side),
//! and a sender reads what the node took of its own writer ([`IntakeWatch`], sender side), so a
//! replay knows that everything it sent was processed — or exactly how much was not — and
//! paces itself so that the node's reader (keep last `input_depth`) never overwrites a sample
//! it has acknowledged but not yet handed over.

use std::collections::HashMap;
use std::time::{Duration, Instant};

use ros2_client::Gid;

use super::msg::IntakeReport;

/// Most writers the node keeps counts for; beyond, the least recently heard is forgotten.
pub const MAX_WRITERS: usize = 1024;

/// A writer's count is published once it has grown by this many messages …
pub const REPORT_EVERY: u64 = 128;

/// … or this long after it last was, whichever comes first.
pub const REPORT_PERIOD: Duration = Duration::from_millis(10);

/// Every writer heard from within [`REPORT_RECENT`] is reported again this often (for a sender
/// whose report subscription matched late, or was rebuilt).
pub const REPORT_REFRESH: Duration = Duration::from_secs(1);

/// See [`REPORT_REFRESH`].
pub const REPORT_RECENT: Duration = Duration::from_secs(10);

#[derive(Debug, Clone, Copy)]
struct Count {
    taken: u64,
    /// Of `taken`, packets of a station the node does not monitor.
    ignored: u64,
    /// Highest DDS sequence number taken.
    last_sn: i64,
    reported: u64,
    last_report: Instant,
    last_heard: Instant,
}

/// Node side: messages taken per writer of `/pbr/accel` (bounded by [`MAX_WRITERS`]) and which
/// reports are due.
#[derive(Debug)]
pub struct WriterCounts {
    counts: HashMap<[u8; 16], Count>,
    /// Writers whose count changed since their last report.
    dirty: Vec<[u8; 16]>,
    last_refresh: Instant,
    /// Writers forgotten to stay within [`MAX_WRITERS`].
    pub forgotten: u64,
}

impl Default for WriterCounts {
    fn default() -> Self {
        WriterCounts {
            counts: HashMap::new(),
            dirty: Vec::new(),
            last_refresh: Instant::now(),
            forgotten: 0,
        }
    }
}

impl WriterCounts {
    /// A message of DDS sequence number `sn` taken from `writer`, of a station the node
    /// `monitored` or not (then counted as ignored too): counted and true if it is new, false
    /// if its sequence number is not above the writer's highest so far (a reliable writer
    /// delivers in order: a redelivery to a rebuilt reader, to be skipped).
    pub fn taken(&mut self, writer: Gid, sn: i64, monitored: bool) -> bool {
        let gid = writer.to_bytes16();
        let now = Instant::now();
        if !self.counts.contains_key(&gid) && self.counts.len() >= MAX_WRITERS {
            if let Some(oldest) = self
                .counts
                .iter()
                .min_by_key(|(_, c)| c.last_heard)
                .map(|(g, _)| *g)
            {
                self.counts.remove(&oldest);
                self.dirty.retain(|g| *g != oldest);
                self.forgotten += 1;
            }
        }
        let count = self.counts.entry(gid).or_insert(Count {
            taken: 0,
            ignored: 0,
            last_sn: i64::MIN,
            reported: 0,
            last_report: now - REPORT_PERIOD,
            last_heard: now,
        });
        count.last_heard = now;
        if sn <= count.last_sn {
            return false;
        }
        count.last_sn = sn;
        if count.taken == count.reported {
            self.dirty.push(gid);
        }
        count.taken += 1;
        count.ignored += u64::from(!monitored);
        true
    }

    /// Messages taken from `writer` so far (0 if unknown or forgotten).
    #[must_use]
    pub fn of(&self, writer: Gid) -> u64 {
        self.counts.get(&writer.to_bytes16()).map_or(0, |c| c.taken)
    }

    /// Hands `publish` the reports due now: each changed count [`REPORT_EVERY`] messages or
    /// [`REPORT_PERIOD`] after its last report (`force`: every changed count now), and every
    /// [`REPORT_REFRESH`] every count heard from within [`REPORT_RECENT`].
    pub fn due(&mut self, force: bool, publish: &mut impl FnMut(IntakeReport)) {
        let now = Instant::now();
        let counts = &mut self.counts;
        self.dirty.retain(|gid| {
            let Some(c) = counts.get_mut(gid) else {
                return false;
            };
            let due = force
                || c.taken - c.reported >= REPORT_EVERY
                || now.duration_since(c.last_report) >= REPORT_PERIOD;
            if due {
                publish(IntakeReport {
                    writer_gid: *gid,
                    taken: c.taken,
                    ignored: c.ignored,
                });
                c.reported = c.taken;
                c.last_report = now;
            }
            !due
        });
        if now.duration_since(self.last_refresh) >= REPORT_REFRESH {
            self.last_refresh = now;
            for (gid, c) in counts.iter_mut() {
                if now.duration_since(c.last_heard) < REPORT_RECENT {
                    publish(IntakeReport {
                        writer_gid: *gid,
                        taken: c.taken,
                        ignored: c.ignored,
                    });
                    c.reported = c.taken;
                    c.last_report = now;
                }
            }
        }
    }
}

/// What the node reported of one writer: messages taken, and of those ignored.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Intake {
    pub taken: u64,
    pub ignored: u64,
}

impl Intake {
    fn merge(&mut self, report: &IntakeReport) {
        self.taken = self.taken.max(report.taken);
        self.ignored = self.ignored.max(report.ignored);
    }
}

/// Sender side: what the node has taken of one writer, from the reports on `/pbr/intake`
/// (and of the sender's previous writer, whose participant died: [`IntakeWatch::switch`]).
/// The sender reads the reports from one subscription per participant and [offers]
/// (IntakeWatch::offer) each to the watch of every writer: two readers of `/pbr/intake` in one
/// secured RustDDS 0.15.1 participant do not both receive (its key exchange remembers the
/// remote writer it sent keys to, not the local reader they were for).
#[derive(Debug)]
pub struct IntakeWatch {
    writer: [u8; 16],
    intake: Intake,
    /// Reports about this writer received.
    pub heard: u64,
    /// The previous writer, what the node took of it, and whether a report about it came
    /// since the switch.
    previous: Option<([u8; 16], Intake, bool)>,
}

impl IntakeWatch {
    #[must_use]
    pub fn new(writer: Gid) -> IntakeWatch {
        IntakeWatch {
            writer: writer.to_bytes16(),
            intake: Intake::default(),
            heard: 0,
            previous: None,
        }
    }

    /// Takes `report` into account if it is about the writer or the previous one.
    pub fn offer(&mut self, report: &IntakeReport) {
        if report.writer_gid == self.writer {
            self.heard += 1;
            self.intake.merge(report);
        } else if let Some((gid, intake, heard)) = &mut self.previous {
            if report.writer_gid == *gid {
                intake.merge(report);
                *heard = true;
            }
        }
    }

    /// What the node has reported taken (and ignored) of the writer.
    #[must_use]
    pub fn intake(&self) -> Intake {
        self.intake
    }

    /// Follows `writer` (a new participant's) from now on; the writer followed so far
    /// becomes the previous one ([`IntakeWatch::previous`]).
    pub fn switch(&mut self, writer: Gid) {
        self.previous = Some((self.writer, self.intake, false));
        self.writer = writer.to_bytes16();
        self.intake = Intake::default();
        self.heard = 0;
    }

    /// What the node has taken of the previous writer, and whether a report about it has come
    /// since the switch (the node repeats every count of the last 10 s each second, so one
    /// comes soon after a switch if the node is there).
    #[must_use]
    pub fn previous(&self) -> Option<(Intake, bool)> {
        self.previous.map(|(_, intake, heard)| (intake, heard))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn gid(n: u8) -> Gid {
        Gid::from([n; 16])
    }

    #[test]
    fn counts_are_reported_when_grown_and_bounded_in_writers() {
        let mut counts = WriterCounts::default();
        let mut got = Vec::new();
        for sn in 1..=REPORT_EVERY as i64 {
            // Every fourth packet of a station the node does not monitor.
            assert!(counts.taken(gid(1), sn, sn % 4 != 0));
        }
        // A redelivery (sequence number not above the highest) is skipped, not counted.
        assert!(!counts.taken(gid(1), 5, false));
        // A new count is due at once (its period has passed), then after REPORT_EVERY more.
        counts.due(false, &mut |r| got.push(r));
        assert_eq!(got.len(), 1);
        assert_eq!(got[0].taken, REPORT_EVERY);
        assert_eq!(got[0].ignored, REPORT_EVERY / 4);
        assert!(counts.taken(gid(1), REPORT_EVERY as i64 + 1, true));
        counts.due(false, &mut |r| got.push(r));
        assert_eq!(got.len(), 1, "one more message, within the period: not due");
        counts.due(true, &mut |r| got.push(r));
        assert_eq!(got.last().unwrap().taken, REPORT_EVERY + 1);
        // Bounded: the least recently heard writer is forgotten.
        for n in 0..MAX_WRITERS + 5 {
            let mut bytes = [7u8; 16];
            bytes[..8].copy_from_slice(&(n as u64).to_le_bytes());
            counts.taken(Gid::from(bytes), 1, true);
        }
        assert_eq!(counts.counts.len(), MAX_WRITERS);
        assert_eq!(counts.forgotten, 6);
        assert_eq!(counts.of(gid(1)), 0);
    }

    #[test]
    fn a_watch_follows_its_writer_and_after_a_switch_its_previous_one() {
        let report = |n: u8, taken: u64, ignored: u64| IntakeReport {
            writer_gid: [n; 16],
            taken,
            ignored,
        };
        let mut watch = IntakeWatch::new(gid(1));
        watch.offer(&report(2, 50, 0)); // another sender's writer
        watch.offer(&report(1, 10, 1));
        watch.offer(&report(1, 7, 0)); // an older report, delivered late
        assert_eq!(
            watch.intake(),
            Intake {
                taken: 10,
                ignored: 1
            }
        );
        assert_eq!(watch.heard, 2);
        watch.switch(gid(3));
        assert_eq!(
            watch.previous(),
            Some((
                Intake {
                    taken: 10,
                    ignored: 1
                },
                false
            ))
        );
        watch.offer(&report(1, 12, 1));
        watch.offer(&report(3, 4, 0));
        assert_eq!(
            watch.previous(),
            Some((
                Intake {
                    taken: 12,
                    ignored: 1
                },
                true
            ))
        );
        assert_eq!(
            watch.intake(),
            Intake {
                taken: 4,
                ignored: 0
            }
        );
    }
}
