//! Stations are independent, so the engine scales by sharding them over worker threads: each
//! worker owns a plain [`Engine`] for its stations (chosen by a hash of the station id), fed
//! through a bounded channel. There is no shared lock on the hot path, and each station's
//! outputs stay in order and deterministic (outputs of different stations interleave).

use std::sync::mpsc::{self, Receiver, Sender, SyncSender};
use std::sync::Arc;
use std::thread::JoinHandle;

use super::{
    AccelPacket, AlertConfig, Engine, EngineConfig, EngineError, JournalRecord, Output, PbrSpec,
    Source, SourceTally, StationConfig,
};

/// Messages to a worker.
enum Command {
    Packet(AccelPacket, i64, Option<Source>),
    Flush(i64),
    CheckHealth(i64),
    ReportHealth,
    SetAlerts(AlertConfig),
    SetStateInterval(f64),
    Reset(String),
    Stop,
}

/// A cloneable, thread-safe handle for feeding a [`ShardedEngine`] from transport threads.
/// After the engine shuts down, its methods do nothing.
#[derive(Clone)]
pub struct EngineHandle {
    senders: std::sync::Arc<[SyncSender<Command>]>,
}

impl EngineHandle {
    fn send(&self, shard: usize, command: Command) {
        // Fails only after shutdown, when nothing is to be done with the command any more.
        let _ = self.senders[shard].send(command);
    }

    fn broadcast(&self, command: impl Fn() -> Command) {
        (0..self.senders.len()).for_each(|s| self.send(s, command()));
    }

    /// Queues a packet for its station's shard (waits if that shard's queue is full).
    pub fn submit(&self, packet: AccelPacket, arrival_ns: i64) {
        self.submit_from(packet, arrival_ns, None);
    }

    /// As [`EngineHandle::submit`], for a packet of `source`: its verdict is counted in the
    /// engine's [`SourceTally`] ([`ShardedEngine::source_tally`]) once a worker has processed it.
    pub fn submit_from(&self, packet: AccelPacket, arrival_ns: i64, source: Option<Source>) {
        let shard = shard_of(packet.station.as_str(), self.senders.len());
        self.send(shard, Command::Packet(packet, arrival_ns, source));
    }

    /// Releases packets held for reordering on every shard.
    pub fn flush(&self, arrival_ns: i64) {
        self.broadcast(|| Command::Flush(arrival_ns));
    }

    /// New alert thresholds on every shard (effective for the next packet).
    pub fn set_alert_config(&self, alerts: AlertConfig) {
        self.broadcast(|| Command::SetAlerts(alerts));
    }

    /// [`Engine::check_health`] at `now_ns` on every shard.
    pub fn check_health(&self, now_ns: i64) {
        self.broadcast(|| Command::CheckHealth(now_ns));
    }

    /// [`Engine::report_health`] on every shard: one `Output::HealthReport` from each.
    pub fn report_health(&self) {
        self.broadcast(|| Command::ReportHealth);
    }

    /// New state publication interval (s of data) on every shard; ignored unless > 0.
    pub fn set_state_interval_s(&self, state_interval_s: f64) {
        self.broadcast(|| Command::SetStateInterval(state_interval_s));
    }

    /// Operator reset of a block on every shard (only its own shard knows it).
    pub fn reset_pbr(&self, pbr_id: &str) {
        self.broadcast(|| Command::Reset(pbr_id.to_string()));
    }
}

/// Packets a worker's queue holds before `submit` waits (back-pressure on the transport).
const QUEUE_PACKETS: usize = 4096;

/// Called by a worker after it has queued outputs (e.g. to wake an event loop).
pub type Wake = Arc<dyn Fn() + Send + Sync>;

/// A pool of engine shards on worker threads.
pub struct ShardedEngine {
    handle: EngineHandle,
    /// Every shard's monitored stations ([`Engine::monitors`]).
    monitored: std::collections::HashSet<String>,
    outputs: Receiver<Vec<Output>>,
    workers: Vec<JoinHandle<Engine>>,
    /// What the workers made of each source's packets.
    tally: Arc<SourceTally>,
}

/// The shard of a station: FNV-1a of its id (stable across runs and platforms).
fn shard_of(station: &str, shards: usize) -> usize {
    (crate::catalogue::default_seed(station) % shards as u64) as usize
}

impl ShardedEngine {
    /// Starts `shards` workers (≥ 1), each restored from `journal`.
    pub fn start(
        config: EngineConfig,
        stations: &[StationConfig],
        pbrs: &[PbrSpec],
        journal: &[JournalRecord],
        shards: usize,
    ) -> Result<ShardedEngine, EngineError> {
        Self::start_with_wake(config, stations, pbrs, journal, shards, Arc::new(|| {}))
    }

    /// As [`ShardedEngine::start`]; every worker calls `wake` after queueing a batch of
    /// outputs, so an event loop can sleep until there is something to publish.
    pub fn start_with_wake(
        config: EngineConfig,
        stations: &[StationConfig],
        pbrs: &[PbrSpec],
        journal: &[JournalRecord],
        shards: usize,
        wake: Wake,
    ) -> Result<ShardedEngine, EngineError> {
        let shards = shards.max(1);
        let (out_tx, outputs): (Sender<Vec<Output>>, _) = mpsc::channel();
        let mut senders = Vec::with_capacity(shards);
        let mut workers = Vec::with_capacity(shards);
        let mut monitored = std::collections::HashSet::new();
        let tally = Arc::new(SourceTally::default());
        for shard in 0..shards {
            let mine = |id: &str| shard_of(id, shards) == shard;
            let my_stations: Vec<StationConfig> = stations
                .iter()
                .filter(|s| mine(s.id.as_str()))
                .cloned()
                .collect();
            let my_pbrs: Vec<PbrSpec> = pbrs
                .iter()
                .filter(|p| mine(p.station.as_str()))
                .cloned()
                .collect();
            let mut engine = Engine::new(config, my_stations, &my_pbrs)?;
            engine.restore(journal);
            engine.set_source_tally(Arc::clone(&tally));
            monitored.extend(engine.monitored_stations().map(str::to_owned));
            let (tx, rx) = mpsc::sync_channel::<Command>(QUEUE_PACKETS);
            let out_tx = out_tx.clone();
            let wake = Arc::clone(&wake);
            let handle = std::thread::Builder::new()
                .name(format!("rockwatch-shard-{shard}"))
                .spawn(move || {
                    let mut out = Vec::new();
                    while let Ok(command) = rx.recv() {
                        match command {
                            Command::Packet(p, arrival, source) => {
                                engine.process_from(p, source, arrival, &mut out);
                            }
                            Command::Flush(arrival) => engine.flush(arrival, &mut out),
                            Command::CheckHealth(now) => engine.check_health(now, &mut out),
                            Command::ReportHealth => engine.report_health(&mut out),
                            Command::SetAlerts(a) => engine.set_alert_config(a),
                            Command::SetStateInterval(s) => {
                                engine.set_state_interval_s(s);
                            }
                            Command::Reset(id) => {
                                engine.reset_pbr(&id);
                            }
                            Command::Stop => break,
                        }
                        if !out.is_empty() {
                            if out_tx.send(std::mem::take(&mut out)).is_err() {
                                break; // nobody listens any more
                            }
                            wake();
                        }
                    }
                    engine
                })
                .map_err(EngineError::Worker)?;
            senders.push(tx);
            workers.push(handle);
        }
        Ok(ShardedEngine {
            monitored,
            handle: EngineHandle {
                senders: senders.into(),
            },
            outputs,
            workers,
            tally,
        })
    }

    /// What the workers made of each source's packets ([`EngineHandle::submit_from`]).
    #[must_use]
    pub fn source_tally(&self) -> Arc<SourceTally> {
        Arc::clone(&self.tally)
    }

    /// Number of shards.
    #[must_use]
    pub fn shards(&self) -> usize {
        self.handle.senders.len()
    }

    /// Whether a shard monitors station `station` ([`Engine::monitors`]).
    #[must_use]
    pub fn monitors(&self, station: &str) -> bool {
        self.monitored.contains(station)
    }

    /// A handle for transport threads.
    #[must_use]
    pub fn handle(&self) -> EngineHandle {
        self.handle.clone()
    }

    /// Queues a packet for its station's shard (waits if that shard's queue is full).
    pub fn submit(&self, packet: AccelPacket, arrival_ns: i64) {
        self.handle.submit(packet, arrival_ns);
    }

    /// [`EngineHandle::submit_from`].
    pub fn submit_from(&self, packet: AccelPacket, arrival_ns: i64, source: Option<Source>) {
        self.handle.submit_from(packet, arrival_ns, source);
    }

    /// Releases packets held for reordering on every shard.
    pub fn flush(&self, arrival_ns: i64) {
        self.handle.flush(arrival_ns);
    }

    /// New alert thresholds on every shard (effective for the next packet).
    pub fn set_alert_config(&self, alerts: AlertConfig) {
        self.handle.set_alert_config(alerts);
    }

    /// [`Engine::check_health`] at `now_ns` on every shard (changes come as outputs).
    pub fn check_health(&self, now_ns: i64) {
        self.handle.check_health(now_ns);
    }

    /// [`Engine::report_health`] on every shard: one `Output::HealthReport` each, as outputs.
    pub fn report_health(&self) {
        self.handle.report_health();
    }

    /// New state publication interval (s of data) on every shard; ignored unless > 0.
    pub fn set_state_interval_s(&self, state_interval_s: f64) {
        self.handle.set_state_interval_s(state_interval_s);
    }

    /// Operator reset of a block on every shard (only its own shard knows it).
    pub fn reset_pbr(&self, pbr_id: &str) {
        self.handle.reset_pbr(pbr_id);
    }

    /// Outputs produced so far, without waiting.
    pub fn try_outputs(&self) -> impl Iterator<Item = Output> + '_ {
        self.outputs.try_iter().flatten()
    }

    /// Waits for the next batch of outputs (None once every worker has stopped).
    pub fn recv_outputs(&self) -> Option<Vec<Output>> {
        self.outputs.recv().ok()
    }

    /// Waits up to `timeout` for the next batch of outputs.
    pub fn recv_outputs_timeout(&self, timeout: std::time::Duration) -> Option<Vec<Output>> {
        self.outputs.recv_timeout(timeout).ok()
    }

    /// Stops the workers after they have processed everything queued; returns their engines
    /// (for summaries and counters) and the outputs not yet taken.
    pub fn shutdown(self) -> (Vec<Engine>, Vec<Output>) {
        // Workers process what is queued before the stop; handles held elsewhere go dead.
        self.handle.broadcast(|| Command::Stop);
        let engines: Vec<Engine> = self
            .workers
            .into_iter()
            .filter_map(|w| w.join().ok())
            .collect();
        let rest = self.outputs.try_iter().flatten().collect();
        (engines, rest)
    }
}
