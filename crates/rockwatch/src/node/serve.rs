//! The live node: ONE event loop thread (the caller's) multiplexes every input with a mio
//! `Poll` and publishes on the same thread.
//!
//! Sources: the ROS 2 subscriptions (`/pbr/accel`, the Imu topics), the ROS 2 service
//! `/pbr/reset` (operator resets, applied between packets), the iceoryx2 `pbr/accel`
//! listener, and a `mio::Waker` through which other threads hand work in (ROS 2 parameter
//! changes from the spinner thread; with several engine shards, the workers' outputs). The
//! poll timeout ([`TICK`]) bounds how late the stop flag (SIGINT/SIGTERM), the
//! held-packet flush and the iceoryx2 dead-node check are seen; there is no busy polling.
//!
//! With one engine shard (the default) the engine runs inline, so a packet goes subscriber →
//! engine → journal → publishers without a thread hand-off; an alert is journaled and
//! published on iceoryx2 the moment the engine raises it (mid-packet), the ROS 2 (and extra)
//! publications of a turn go out together at its end. Readiness is edge-triggered: a
//! ready source is drained until empty into its inbox ([`INBOX_BOUND`]); the inboxes are then
//! processed round robin for at most [`TURN_BUDGET`] or [`DRAIN_BOUND`] packets before the
//! loop polls and takes again, so a flood on one input cannot starve the others and no
//! transport holds much unread data.

use std::collections::VecDeque;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::Receiver;
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::Context;
use mio::{Events, Poll, Token, Waker};

use super::delivery::{publish_resets, republish_journaled, Outlet};
use super::{
    Control, ControlSender, InputTotals, NodeOptions, NodeRuntime, Publisher, Reloaded,
    TransportStatus, Wake, FAULT_STALL_ON_RELOAD_ENV,
};
use crate::iox::{IoxAlertPublisher, IoxInput, IoxInputStats, IoxStatsHandle};
use crate::logging::RateLimitedLog;
use crate::logging::{take_rosout, RosoutRecord};
use crate::ports::Received;
use crate::ros2::msg::ResetPbrResponse;
use crate::ros2::{
    IntakeCounters, NetworkPlan, ParamValues, Ros2Node, Ros2Publisher, Ros2Tokens, Scene, Watchdog,
};
use crate::sd_notify::SystemdNotifier;
use crate::web::WebServer;
use rockwatch_core::engine::{AccelPacket, PbrId, PbrSummary, Source};

/// Longest sleep of the event loop: the stop flag, the held-packet flush and the iceoryx2
/// dead-node check are looked at least this often.
pub const TICK: Duration = Duration::from_millis(50);

/// Most packets processed per turn of the event loop (round robin over the sources).
pub const DRAIN_BOUND: usize = 256;

/// Longest a turn of the event loop processes packets (plus one packet's time) before it
/// polls again and takes what arrived meanwhile, so the transports hold little unread data
/// (RustDDS discards the unread samples of a writer that has left).
pub const TURN_BUDGET: Duration = Duration::from_micros(200);

/// Most packets taken from one source and waiting to be processed; beyond, the rest stays in
/// the transport (DDS history, iceoryx2 subscriber buffer).
pub const INBOX_BOUND: usize = 4096;

/// Most samples (per component) waiting in one source's inbox, give or take one chunk of
/// [`ROS2_CHUNK`] packets: a peer sending huge packets cannot make the node hold more than
/// ≈ 50 MB per source (a DDS message may carry up to `MAX_SAMPLES_PER_PACKET` samples).
pub const INBOX_SAMPLES: usize = 1 << 22;

/// Packets taken from a ROS 2 input between two looks at its inbox's sample bound.
const ROS2_CHUNK: usize = 64;

const WAKE: Token = Token(0);
const IOX: Token = Token(1);
/// The ROS 2 service `pbr/reset`.
const RESET: Token = Token(2);
/// The six ROS 2 parameter services.
const PARAMS: Token = Token(3);
/// ROS 2 input `i` is `Token(ROS2_FIRST + i)`.
const ROS2_FIRST: usize = 4;
/// The ROS 2 sources' tokens, for the [`Watchdog`]'s rebuilt participant.
const ROS2_TOKENS: Ros2Tokens = Ros2Tokens {
    inputs_first: ROS2_FIRST,
    reset: RESET,
    params: PARAMS,
};

/// What [`serve`] hands back at the end.
#[derive(Debug, Clone)]
pub struct ServeReport {
    pub summaries: Vec<PbrSummary>,
    pub ros2_packets: u64,
    pub ros2_decode_errors: u64,
    /// What the engine made of the input of every transport.
    pub input: InputTotals,
    /// iceoryx2 intake, when that transport ran.
    pub iox: Option<IoxInputStats>,
    /// What the runtime did, the state directory's health included.
    pub stats: super::NodeStats,
    /// Times the ROS 2 participant was found dead and rebuilt.
    pub ros2_rebuilds: u64,
    /// `/pbr/accel` messages delivered again after a rebuild and skipped.
    pub ros2_redelivered: u64,
}

/// A thread-safe view of a running node's intake counters (tests, benchmarks).
#[derive(Debug, Clone)]
pub struct Probe {
    ros2: Arc<IntakeCounters>,
    iox: Option<IoxStatsHandle>,
}

impl Probe {
    /// Messages taken from the ROS 2 inputs so far.
    #[must_use]
    pub fn ros2_packets(&self) -> u64 {
        self.ros2.packets.load(Ordering::Relaxed)
    }

    /// Undecodable ROS 2 messages so far.
    #[must_use]
    pub fn ros2_decode_errors(&self) -> u64 {
        self.ros2.decode_errors.load(Ordering::Relaxed)
    }

    /// The iceoryx2 input's counters, when that transport runs.
    #[must_use]
    pub fn iox(&self) -> Option<IoxInputStats> {
        self.iox.as_ref().map(IoxStatsHandle::stats)
    }
}

/// The node, started and subscribed but not yet running its loop. Create it and call
/// [`Reactor::run`] on the same thread (the iceoryx2 ports are bound to it).
pub struct Reactor {
    runtime: NodeRuntime,
    poll: Poll,
    /// Kept alive for the workers' and the parameter services' wake-ups.
    _waker: Arc<Waker>,
    controls: Receiver<Control>,
    ros2: Ros2Node,
    ros2_publisher: Ros2Publisher,
    iox: Option<(IoxInput, IoxAlertPublisher)>,
    /// How often the status goes to `/diagnostics` and the web server.
    status_period: Duration,
    /// The web dashboard (`[web]`) and/or `/metrics` (`[metrics]`): one server, one thread.
    web: Option<WebServer>,
}

/// What supervises a running node from outside: reload requests (SIGHUP) with the way to
/// read the configuration again, and systemd's notifications.
#[derive(Default)]
pub struct Supervision<'a> {
    /// Set by the signal thread on SIGHUP; the event loop clears it and reloads between
    /// packets.
    pub reload_requested: Option<&'a AtomicBool>,
    /// Reads the configuration files again (the node's configuration and catalogue).
    pub reload: Option<&'a mut dyn FnMut() -> anyhow::Result<Reloaded>>,
    /// `$NOTIFY_SOCKET`: READY, WATCHDOG (while the loop is healthy), RELOADING, STOPPING.
    pub systemd: Option<SystemdNotifier>,
}

/// Runs the node until `stop` is set: [`Reactor::start`], then [`Reactor::run`] with the
/// `extra` publishers.
pub fn serve(
    options: &NodeOptions,
    plan: &NetworkPlan,
    stop: &AtomicBool,
    extra: &mut [&mut dyn Publisher],
) -> anyhow::Result<ServeReport> {
    Reactor::start(options, plan)?.run(stop, extra)
}

/// [`serve`] under `supervision` (reloads, systemd): what `rockwatch node` runs.
pub fn serve_supervised(
    options: &NodeOptions,
    plan: &NetworkPlan,
    stop: &AtomicBool,
    extra: &mut [&mut dyn Publisher],
    supervision: Supervision<'_>,
) -> anyhow::Result<ServeReport> {
    Reactor::start(options, plan)?.run_supervised(stop, extra, supervision)
}

impl Reactor {
    /// Starts the runtime (catalogue, state directory, engine) and the transports: ROS 2
    /// always, iceoryx2 when the configuration names its iceoryx2 config file (every process
    /// of a deployment must load the same one explicitly). Returns once every input is
    /// subscribed.
    pub fn start(options: &NodeOptions, plan: &NetworkPlan) -> anyhow::Result<Reactor> {
        let poll = Poll::new().context("cannot create the node's event loop (mio Poll)")?;
        let waker = Arc::new(
            Waker::new(poll.registry(), WAKE).context("cannot create the event loop's waker")?,
        );
        let wake: Wake = {
            let waker = Arc::clone(&waker);
            Arc::new(move || {
                // Fails only if the eventfd is gone, i.e. the loop has ended.
                let _ = waker.wake();
            })
        };
        let (catalogue, owned, foreign) = options.load_catalogue()?;
        let config = &options.config;
        // The 3-D view of the node's own rocks and stations (pbr/markers, /tf_static).
        let scene = {
            let owned_ids: std::collections::HashSet<&str> =
                owned.iter().map(|s| s.id.as_str()).collect();
            let own: Vec<&rockwatch_core::catalogue::Pbr> = catalogue
                .pbrs()
                .iter()
                .filter(|p| owned_ids.contains(p.id().as_str()))
                .collect();
            let stations = config
                .owned_stations()
                .map_err(|e| anyhow::anyhow!("configuration: {e}"))?;
            let partition = config
                .partitioning()
                .map_err(|e| anyhow::anyhow!("configuration: {e}"))?
                .map(|(p, _)| p);
            match partition {
                None => Scene::new(&own, &stations, config.ros2.map_origin)?,
                // Every node of the service must put `map` at the same place: without
                // [ros2] map_origin, the mean of the whole catalogue, not of its own rocks.
                Some(partition) => {
                    let origin = config.ros2.map_origin.or_else(|| {
                        let all: Vec<&rockwatch_core::catalogue::Pbr> =
                            catalogue.pbrs().iter().collect();
                        Scene::mean_origin(&all)
                    });
                    Scene::new(&own, &stations, origin)?.in_partition(partition)
                }
            }
        };
        drop(catalogue);
        let mut runtime = NodeRuntime::start_with_blocks(options, owned, wake.clone())?;
        runtime.foreign_pbr_ids = foreign;
        let (control_sender, controls) = ControlSender::channel(wake);

        let params = ParamValues {
            engine: config.engine,
            catalogue: options.catalogue_path()?.display().to_string(),
            state_dir: options
                .state_dir_path()
                .map(|d| d.display().to_string())
                .unwrap_or_default(),
            use_sim_time: config.ros2.use_sim_time,
        };
        if config.ros2.use_sim_time {
            tracing::info!(
                "use_sim_time = true: accepted; the node's outputs are stamped with data time \
                 (sample times) either way, and /clock is not read"
            );
        }
        let partition = config
            .partitioning()
            .map_err(|e| anyhow::anyhow!("configuration: {e}"))?
            .map(|(p, _)| p);
        let (mut ros2, mut ros2_publisher) = Ros2Node::start(
            &config.ros2,
            plan,
            params,
            control_sender,
            partition,
            runtime.source_tally(),
        )?;
        let mut scene = scene;
        scene.set_fallen(&|id| runtime.overturned(id) == Some(true));
        ros2_publisher.show(scene);
        ros2.register(poll.registry(), ROS2_FIRST)
            .context("cannot register the ROS 2 subscriptions with the event loop")?;
        ros2.register_reset(poll.registry(), RESET)
            .context("cannot register the ROS 2 reset service with the event loop")?;
        ros2.register_parameters(poll.registry(), PARAMS)
            .context("cannot register the ROS 2 parameter services with the event loop")?;
        let iox = match &config.iceoryx2.config_file {
            Some(_) => {
                let mut input = IoxInput::open(&config.iceoryx2, runtime.source_tally())?;
                poll.registry()
                    .register(&mut input, IOX, mio::Interest::READABLE)
                    .context("cannot register the iceoryx2 listener with the event loop")?;
                let publisher = IoxAlertPublisher::new(&config.iceoryx2)?;
                Some((input, publisher))
            }
            None => None,
        };
        // The node's own log records at or above `[status] rosout_level` also go to /rosout.
        crate::logging::enable_rosout(config.status.rosout()?);
        let web = WebServer::start(&config.web, &config.metrics)?;
        Ok(Reactor {
            runtime,
            poll,
            _waker: waker,
            controls,
            ros2,
            ros2_publisher,
            iox,
            status_period: Duration::from_secs_f64(config.status.diagnostics_period_s),
            web,
        })
    }

    /// The instant the node's arrival stamps (`Alert::arrival_ns`) count from.
    #[must_use]
    pub fn epoch(&self) -> std::time::Instant {
        self.runtime.epoch()
    }

    /// The intake counters, readable from other threads while the node runs.
    #[must_use]
    pub fn probe(&self) -> Probe {
        Probe {
            ros2: Arc::clone(&self.ros2.counters),
            iox: self.iox.as_ref().map(|(input, _)| input.stats_handle()),
        }
    }

    /// Runs the event loop until `stop` is set (seen within `TICK`, 50 ms), publishing to the
    /// node's publishers — the iceoryx2 alert publisher at once, ROS 2 and `extra` at the end
    /// of each turn (see `Outlet`) — then takes what the inputs still hold, shuts the engine
    /// down (held packets released, remaining outputs published, journal synced) and reports.
    pub fn run(
        self,
        stop: &AtomicBool,
        extra: &mut [&mut dyn Publisher],
    ) -> anyhow::Result<ServeReport> {
        self.run_supervised(stop, extra, Supervision::default())
    }

    /// [`Reactor::run`] under `supervision`: a reload request is taken between packets
    /// (see [`apply_reload`]); systemd hears READY once the loop runs, WATCHDOG on the
    /// loop's turns while the ROS 2 transport is up, and STOPPING at the end.
    pub fn run_supervised(
        self,
        stop: &AtomicBool,
        extra: &mut [&mut dyn Publisher],
        mut supervision: Supervision<'_>,
    ) -> anyhow::Result<ServeReport> {
        let Reactor {
            mut runtime,
            mut poll,
            _waker,
            controls,
            mut ros2,
            ros2_publisher,
            iox,
            status_period,
            web,
        } = self;
        let (mut iox_input, mut iox_publisher) = match iox {
            Some((input, publisher)) => (Some(input), Some(publisher)),
            None => (None, None),
        };
        // The web side takes alerts and resets without ever making the loop wait.
        let mut web_feed = web.as_ref().map(WebServer::alert_feed);
        let mut later: Vec<&mut dyn Publisher> = Vec::with_capacity(extra.len());
        for p in extra.iter_mut() {
            later.push(&mut **p);
        }
        let mut out = Outlet {
            immediate: iox_publisher.as_mut().map(|p| p as &mut dyn Publisher),
            ros2: ros2_publisher,
            later,
            history: web_feed.as_mut().map(|f| f as &mut dyn Publisher),
            queue: Vec::new(),
            published: Vec::new(),
            errors: 0,
            log: RateLimitedLog::new(),
        };
        // The dashboard shows the traces the event reports are made of (one copy, fed by
        // the runtime).
        if web.as_ref().is_some_and(|w| w.web_address().is_some()) {
            runtime.enable_traces();
        }

        republish_journaled(&mut runtime, &mut out);
        if let Some(systemd) = &mut supervision.systemd {
            systemd.ready(&format!("monitoring {} blocks", runtime.pbr_ids().len()));
        }

        // One inbox per source: index 0 is iceoryx2, 1 + i ROS 2 input i.
        let mut inboxes: Vec<Inbox> = (0..1 + ros2.inputs()).map(|_| Inbox::new()).collect();
        let mut events = Events::with_capacity(64);
        // Requests of pbr/reset and of the parameter services may be waiting (edge-triggered,
        // like the inputs).
        let mut resets_due = true;
        let mut params_due = true;
        let mut watchdog = Watchdog::new();
        // Station health is judged every TICK, the status published every status period.
        let (mut last_health, mut last_status) = (None::<Instant>, Instant::now());
        let mut rosout: Vec<RosoutRecord> = Vec::new();
        while !stop.load(Ordering::Relaxed) {
            let pending =
                resets_due || params_due || inboxes.iter().any(|i| i.due || !i.queue.is_empty());
            let timeout = if pending {
                Duration::ZERO
            } else if ros2.intake_pending()
                || iox_input.as_ref().is_some_and(IoxInput::intake_pending)
            {
                // A sender waits for the report (its window).
                crate::intake::REPORT_PERIOD
            } else if ros2.pending_replies() > 0 {
                crate::ros2::RESET_MATCH_GRACE // a reset response waits for its client
            } else {
                TICK
            };
            match poll.poll(&mut events, Some(timeout)) {
                Ok(()) => {}
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
                Err(e) => return Err(e).context("the node's event loop failed (poll)"),
            }
            if events.is_empty() && !pending {
                // Idle tick: look at every source once (a safety net, cheap when empty).
                inboxes.iter_mut().for_each(|i| i.due = true);
                resets_due = true;
                params_due = true;
            }
            for event in &events {
                let source = match event.token() {
                    WAKE => continue,
                    RESET => {
                        resets_due = true;
                        continue;
                    }
                    PARAMS => {
                        params_due = true;
                        continue;
                    }
                    IOX => 0,
                    Token(t) => 1 + t.wrapping_sub(ROS2_FIRST),
                };
                if let Some(inbox) = inboxes.get_mut(source) {
                    inbox.due = true;
                }
            }
            // A reload (SIGHUP), parameter changes, then operator resets apply before the
            // packets of this turn.
            if supervision
                .reload_requested
                .is_some_and(|r| r.swap(false, Ordering::Relaxed))
            {
                apply_reload(&mut runtime, &mut ros2, &mut supervision);
            }
            if params_due {
                params_due = ros2.serve_parameters();
            }
            apply_controls(&controls, &mut runtime);
            if resets_due {
                resets_due = ros2.serve_resets(&mut |pbr_id| reset_response(&mut runtime, pbr_id));
                publish_resets(&mut runtime, &mut out);
            }
            ros2.send_due_replies();
            turn(
                &mut inboxes,
                &mut iox_input,
                &mut ros2,
                &mut runtime,
                &mut out,
                &controls,
            )?;
            runtime.flush_if_due(&mut |p| out.publish(p));
            if last_health.is_none_or(|t| t.elapsed() >= TICK) {
                last_health = Some(Instant::now());
                runtime.check_health(&mut |p| out.publish(p));
            }
            out.settle(&mut runtime);
            // The 3-D view's markers, when a state changed it (rate-limited).
            out.ros2.tick();
            if last_status.elapsed() >= status_period {
                last_status = Instant::now();
                let status = runtime.status(TransportStatus {
                    ros2_up: watchdog.is_up(),
                    ros2_rebuilds: watchdog.rebuilds(),
                    iceoryx2: iox_input.is_some(),
                });
                ros2.publish_status(&status);
                out.ros2.observe_station_health(&status.stations);
                if let Some(w) = &web {
                    w.update_status(status);
                    if let Some(traces) = runtime.traces_snapshot(w.wanted_stations()) {
                        w.update_traces(traces);
                    }
                }
            }
            take_rosout(&mut rosout);
            if !rosout.is_empty() {
                ros2.publish_rosout(&mut rosout);
            }
            ros2.publish_intake_reports(false);
            if let Some(input) = &mut iox_input {
                input.publish_intake_reports(false);
                input.maintain();
            }
            if watchdog.due() {
                if let Some(thread) = ros2.ended_thread() {
                    // Take what the dead participant's readers still hold, then replace it.
                    drain_inputs(
                        &mut inboxes,
                        &mut iox_input,
                        &mut ros2,
                        &mut runtime,
                        &mut out,
                        &controls,
                    )?;
                    if watchdog.rebuild(
                        &thread,
                        &mut ros2,
                        &mut out.ros2,
                        poll.registry(),
                        ROS2_TOKENS,
                    )? {
                        inboxes.iter_mut().for_each(|i| i.due = true);
                        resets_due = true;
                        params_due = true;
                    }
                }
            }
            // The loop has turned and the ROS 2 transport is up: tell systemd's watchdog.
            if watchdog.is_up() {
                if let Some(systemd) = &mut supervision.systemd {
                    systemd.ping_if_due();
                }
            }
        }
        if let Some(systemd) = &mut supervision.systemd {
            systemd.stopping();
        }

        // Stop: take what the inputs still hold (bounded) and process every packet taken,
        // then shut the engine down.
        drain_inputs(
            &mut inboxes,
            &mut iox_input,
            &mut ros2,
            &mut runtime,
            &mut out,
            &controls,
        )?;
        // Requests waiting at the stop are answered (a bounded number; the responses go out
        // now, held ones too).
        ros2.serve_resets(&mut |pbr_id| reset_response(&mut runtime, pbr_id));
        publish_resets(&mut runtime, &mut out);
        ros2.flush_replies();
        ros2.publish_intake_reports(true);
        if let Some(input) = &mut iox_input {
            input.publish_intake_reports(true);
        }
        take_rosout(&mut rosout);
        ros2.publish_rosout(&mut rosout);
        let iox_stats = iox_input.as_ref().map(IoxInput::stats);
        let stopped = runtime.stop(&mut |p| out.publish(p));
        out.flush();
        out.ros2.tick();
        if let Some(input) = &mut iox_input {
            let _ = poll.registry().deregister(input);
        }
        Ok(ServeReport {
            summaries: stopped.summaries(),
            input: stopped.input_totals(),
            ros2_packets: ros2.counters.packets.load(Ordering::Relaxed),
            ros2_decode_errors: ros2.counters.decode_errors.load(Ordering::Relaxed),
            iox: iox_stats,
            stats: stopped.stats,
            ros2_rebuilds: watchdog.rebuilds(),
            ros2_redelivered: ros2.counters.redelivered.load(Ordering::Relaxed),
        })
    }
}

/// A reload request (SIGHUP), between packets: reads the configuration and catalogue again
/// (`supervision.reload`) and hands them to [`NodeRuntime::reload`] — blocks in both keep
/// their state, new ones start at rest, removed ones are dropped; the ROS 2 parameters show
/// the new thresholds. A configuration that cannot be read or is invalid is refused with one
/// log line, and the running one is kept. systemd hears RELOADING, then READY.
fn apply_reload(runtime: &mut NodeRuntime, ros2: &mut Ros2Node, supervision: &mut Supervision<'_>) {
    if let Some(systemd) = &mut supervision.systemd {
        systemd.reloading();
    }
    if let Some(stall) = std::env::var(FAULT_STALL_ON_RELOAD_ENV)
        .ok()
        .and_then(|v| v.parse::<f64>().ok())
        .filter(|s| s.is_finite() && *s >= 0.0)
    {
        std::thread::sleep(Duration::from_secs_f64(stall));
    }
    let result = match &mut supervision.reload {
        Some(load) => load().and_then(|reloaded| {
            let engine = reloaded.engine;
            runtime.reload(reloaded).map(|report| (report, engine))
        }),
        None => Err(anyhow::anyhow!(
            "this node has no configuration to read again"
        )),
    };
    match result {
        Ok((outcome, engine)) => {
            ros2.set_engine_parameters(&engine);
            // Each changed setting, old → new (one record each: fields setting, old, new).
            for c in &outcome.changes {
                tracing::info!(
                    setting = c.setting.as_str(),
                    old = c.old.as_str(),
                    new = c.new.as_str(),
                    "reload: {} {} → {}",
                    c.setting,
                    c.old,
                    c.new
                );
            }
            let report = &outcome.blocks;
            let list = |ids: &[PbrId]| {
                if ids.is_empty() {
                    String::new()
                } else {
                    let ids: Vec<&str> = ids.iter().map(PbrId::as_str).collect();
                    format!(" ({})", ids.join(", "))
                }
            };
            tracing::info!(
                settings_changed = outcome.changes.len(),
                blocks_kept = report.kept.len(),
                blocks_added = report.added.len(),
                blocks_replaced = report.replaced.len(),
                blocks_dropped = report.dropped.len(),
                "reloaded: {} settings changed; {} blocks kept with their state, {} new at rest{}, {} changed and at rest again{}, {} dropped{}",
                outcome.changes.len(),
                report.kept.len(),
                report.added.len(),
                list(&report.added),
                report.replaced.len(),
                list(&report.replaced),
                report.dropped.len(),
                list(&report.dropped)
            );
        }
        Err(e) => {
            tracing::error!("reload refused, the running configuration is kept: {e:#}")
        }
    }
    if let Some(systemd) = &mut supervision.systemd {
        systemd.ready(&format!("monitoring {} blocks", runtime.pbr_ids().len()));
    }
}

/// Takes what every input holds (up to its inbox's bound) and processes every packet taken.
fn drain_inputs(
    inboxes: &mut [Inbox],
    iox_input: &mut Option<IoxInput>,
    ros2: &mut Ros2Node,
    runtime: &mut NodeRuntime,
    out: &mut Outlet<'_>,
    controls: &Receiver<Control>,
) -> anyhow::Result<()> {
    inboxes.iter_mut().for_each(|i| i.due = true);
    loop {
        turn(inboxes, iox_input, ros2, runtime, out, controls)?;
        if inboxes.iter().all(|i| i.queue.is_empty()) {
            return Ok(());
        }
        // Process what was taken; take nothing new.
        inboxes.iter_mut().for_each(|i| i.due = false);
    }
}

/// One turn of the event loop after the poll: take what the ready (`due`) sources hold into
/// their inboxes (fast: no engine work yet), then run the engine on the inboxes' packets for
/// at most [`TURN_BUDGET`] / [`DRAIN_BOUND`] packets, then publish what the engine workers
/// produced.
fn turn(
    inboxes: &mut [Inbox],
    iox_input: &mut Option<IoxInput>,
    ros2: &mut Ros2Node,
    runtime: &mut NodeRuntime,
    out: &mut Outlet<'_>,
    controls: &Receiver<Control>,
) -> anyhow::Result<()> {
    for (source, inbox) in inboxes.iter_mut().enumerate() {
        if !inbox.due {
            continue;
        }
        let clock = &*runtime;
        inbox.due = match (source, &mut *iox_input) {
            // iceoryx2 packets are bounded by the service's slice length: bound by count.
            (0, Some(input)) => {
                let room = INBOX_BOUND.saturating_sub(inbox.queue.len());
                input.drain(
                    room,
                    &|station| clock.monitors(station),
                    &mut |p, source| inbox.push(p, clock.now_ns(), source),
                )
            }
            (0, None) => false,
            // A DDS message may hold up to MAX_SAMPLES_PER_PACKET samples: take in chunks
            // while the inbox is under both bounds.
            (s, _) => {
                let mut more = true;
                while more && !inbox.full() {
                    let room = INBOX_BOUND
                        .saturating_sub(inbox.queue.len())
                        .min(ROS2_CHUNK);
                    more = ros2.drain(
                        s - 1,
                        room,
                        &|station| clock.monitors(station),
                        &mut |p, source| inbox.push(p, clock.now_ns(), source),
                    );
                }
                more
            }
        };
    }
    // Round robin over the sources, one packet each, until the inboxes are empty, or
    // DRAIN_BOUND packets or TURN_BUDGET have gone by (then poll again, taking new data).
    let deadline = Instant::now() + TURN_BUDGET;
    let mut processed = 0;
    loop {
        let mut any = false;
        for inbox in inboxes.iter_mut() {
            if let Some((received, arrival_ns, source)) = inbox.pop() {
                any = true;
                processed += 1;
                // A parameter change queued before this packet was taken applies to it.
                apply_controls(controls, runtime);
                match received {
                    Ok(packet) => {
                        runtime.submit_arrived(packet, arrival_ns, source, &mut |p| out.publish(p));
                    }
                    Err(refused) => runtime.refuse_malformed(&refused, source),
                }
            }
        }
        if !any || processed >= DRAIN_BOUND || Instant::now() >= deadline {
            break;
        }
    }
    runtime.poll(&mut |p| out.publish(p));
    out.settle(runtime);
    Ok(())
}

/// Packets taken from one source (or their refusals, in their order) and not yet processed,
/// with their arrival stamps ([`NodeRuntime::now_ns`] when taken).
struct Inbox {
    queue: VecDeque<(Received, i64, Option<Source>)>,
    /// Samples (per component) of the packets in `queue`.
    samples: usize,
    /// Ready (or stopped at the bound last turn): take from the source on this turn.
    due: bool,
}

impl Inbox {
    fn new() -> Inbox {
        Inbox {
            queue: VecDeque::new(),
            samples: 0,
            due: true,
        }
    }

    fn push(&mut self, received: Received, arrival_ns: i64, source: Option<Source>) {
        self.samples += received.as_ref().map_or(0, AccelPacket::len);
        self.queue.push_back((received, arrival_ns, source));
    }

    fn pop(&mut self) -> Option<(Received, i64, Option<Source>)> {
        let taken = self.queue.pop_front()?;
        self.samples -= taken.0.as_ref().map_or(0, AccelPacket::len);
        Some(taken)
    }

    /// At [`INBOX_BOUND`] packets or [`INBOX_SAMPLES`] samples: take nothing more.
    fn full(&self) -> bool {
        self.queue.len() >= INBOX_BOUND || self.samples >= INBOX_SAMPLES
    }
}

/// Serves one `/pbr/reset` request: [`NodeRuntime::operator_reset`] (an overturned block is
/// reset, journaled first; a standing one left alone; an unknown id refused) and its response.
/// A failed journal is reported to the client (success false) and logged; the node goes on.
/// None (no response) for a block of another partition: its own node answers.
fn reset_response(runtime: &mut NodeRuntime, pbr_id: &str) -> Option<ResetPbrResponse> {
    if runtime.is_foreign(pbr_id) {
        return None;
    }
    Some(match runtime.operator_reset(pbr_id) {
        Ok(outcome) => ResetPbrResponse {
            success: outcome.success(),
            message: outcome.message(pbr_id),
        },
        Err(e) => ResetPbrResponse {
            success: false,
            message: format!("block {pbr_id} not reset: the state directory failed: {e:#}"),
        },
    })
}

/// Applies every queued settings change.
fn apply_controls(controls: &Receiver<Control>, runtime: &mut NodeRuntime) {
    while let Ok(control) = controls.try_recv() {
        runtime.apply(control);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn packet(samples: usize) -> AccelPacket {
        AccelPacket {
            station: rockwatch_core::engine::StationId::parse("XX.BIG.00").unwrap(),
            start_time_ns: 0,
            sample_rate_hz: 100.0,
            sequence: 0,
            east: vec![0.0; samples],
            north: vec![0.0; samples],
            up: Vec::new(),
            unit: Default::default(),
        }
    }

    #[test]
    fn an_inbox_is_full_at_its_packet_or_its_sample_bound() {
        let mut inbox = Inbox::new();
        // Huge packets: the sample bound is reached long before the packet bound.
        let big = rockwatch_core::engine::packet::MAX_SAMPLES_PER_PACKET;
        let n = INBOX_SAMPLES.div_ceil(big);
        for i in 0..n {
            assert!(!inbox.full(), "full after {i} packets");
            inbox.push(Ok(packet(big)), 0, None);
        }
        assert!(inbox.full() && inbox.queue.len() < INBOX_BOUND);
        // Taking a packet out frees its samples.
        inbox.pop().unwrap().0.unwrap();
        assert_eq!(inbox.samples, (n - 1) * big);
        assert!(!inbox.full());
        // Small packets: the packet bound.
        let mut inbox = Inbox::new();
        (0..INBOX_BOUND).for_each(|_| inbox.push(Ok(packet(10)), 0, None));
        assert!(inbox.full() && inbox.samples < INBOX_SAMPLES);
    }
}
