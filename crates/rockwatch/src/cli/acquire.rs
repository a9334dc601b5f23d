//! `rockwatch acquire`: the station acquisition process (SeedLink → packets → the node).

use std::path::PathBuf;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use anyhow::{bail, Context as _};
use rockwatch::acquire::{acquire_prometheus, acquire_summary, AcquireConfig, PacketPublisher};
use rockwatch::iox::IoxPacketSink;
use rockwatch::metrics::MetricsServer;
use rockwatch::ports::PacketSink;
use rockwatch::ros2::{network_plan_from_env, Ros2PacketSink};
use rockwatch::sd_notify::SystemdNotifier;
use rockwatch::seedlink::{LinkCounters, RecordSink, SeedLinkClient, Taken};
use rockwatch::signals::stop_on_signals;
use rockwatch_core::inventory::Inventory;

/// Output transport of `rockwatch acquire`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Output {
    /// iceoryx2 (zero-copy, same host): the `pbr/accel` service of the `[iceoryx2]` section.
    Iceoryx2,
    /// ROS 2: pbr_msgs/AccelPacket on /pbr/accel (the `[ros2]` section).
    Ros2,
}

/// Acquire stations from a SeedLink server and publish them to the node.
///
/// Connects to the `[seedlink]` server (v4 when offered, else v3), selects the configured
/// streams, decodes the MiniSEED records, calibrates (counts → m/s²) and rotates them to
/// east/north/up with the `[inventory]` StationXML, aligns the components on each station's
/// sample grid and publishes the packets (iceoryx2 by default, or ROS 2). Reconnects after
/// failures; resumes each station after the last record published, from the state directory
/// (nothing lost or published twice across restarts, within the server's ring). Waits for the
/// node's subscription before connecting. SIGINT/SIGTERM stop it cleanly; counters are printed
/// on exit. With `--to ros2` it publishes its status every second on /diagnostics
/// (`rockwatch acquire: link`, `… publication`, `… station NET.STA.LOC`; docs/seedlink.md).
/// Under systemd (`Type=notify`) it reports READY once the node has subscribed and
/// pings the watchdog (`WatchdogSec=`) from its receive loop while connected to the server. Configuration: config/acquire.toml documents every key; docs/seedlink.md the
/// protocol and resume semantics.
#[derive(Debug, clap::Args)]
pub struct AcquireArgs {
    /// Acquisition configuration (TOML): [seedlink], [inventory], [assembly], [iceoryx2],
    /// [ros2], state_dir.
    #[arg(long, value_name = "FILE")]
    config: PathBuf,
    /// Directory of the SeedLink resume state (overrides the configuration's state_dir).
    /// Without either, nothing is resumed after a restart.
    #[arg(long = "state-dir", value_name = "DIR")]
    state_dir: Option<PathBuf>,
    /// Where the packets go.
    #[arg(long, value_enum, default_value_t = Output::Iceoryx2)]
    to: Output,
}

/// How often `[metrics]` gets acquire's counters, and `/diagnostics` its status (s).
const METRICS_PERIOD: Duration = Duration::from_secs(1);

/// The publisher, pinging systemd's watchdog on the receive loop's ticks (about every
/// 100 ms while connected): a loop that stops turning stops the pings (not while the link is
/// down: a server down longer than `WatchdogSec` restarts acquire). Once per
/// [`METRICS_PERIOD`], connected or not, it hands `[metrics]` the counters and, with
/// `status_server` (`--to ros2`), the sink the status (`/diagnostics`).
struct Watched<'a, 's> {
    inner: PacketPublisher<'s>,
    systemd: Option<&'a mut SystemdNotifier>,
    metrics: Option<MetricsServer>,
    /// The SeedLink server, named in the status; `None`: no status is published.
    status_server: Option<String>,
    last_report: Instant,
    link_up: bool,
}

impl RecordSink for Watched<'_, '_> {
    fn record(&mut self, record: &rockwatch_core::record::mseed::Channel) -> Taken {
        self.inner.record(record)
    }

    fn published_until_ns(&self, station: &str) -> Option<i64> {
        self.inner.published_until_ns(station)
    }

    fn tick(&mut self, link: &LinkCounters) {
        self.inner.tick(link);
        if let (Some(systemd), true) = (&mut self.systemd, self.link_up) {
            systemd.ping_if_due();
        }
        if self.last_report.elapsed() >= METRICS_PERIOD {
            self.last_report = Instant::now();
            if let Some(metrics) = &self.metrics {
                let (published, assembled) = self.inner.counters();
                metrics.update(acquire_prometheus(link, &published, &assembled));
            }
            if let Some(server) = &self.status_server {
                self.inner.publish_status(link, server);
            }
        }
    }

    fn link(&mut self, up: bool) {
        self.link_up = up;
        self.inner.link(up);
    }
}

pub fn run(args: AcquireArgs) -> anyhow::Result<()> {
    // First, before any thread starts: the stop signals go to one thread, never to DDS's.
    let stop = stop_on_signals()?;
    let mut systemd = SystemdNotifier::from_env()?;
    let mut config = AcquireConfig::load(&args.config)?;
    super::apply_ros_naming(&mut config.ros2);
    let state_dir = args.state_dir.clone().or_else(|| config.state_dir.clone());
    if let Some(dir) = &state_dir {
        std::fs::create_dir_all(dir)
            .with_context(|| format!("cannot create the state directory {}", dir.display()))?;
    }
    let inventory = Inventory::read_all(&config.inventory.stationxml)?;
    let metrics = match &config.metrics.listen {
        Some(listen) => Some(MetricsServer::start(listen, config.metrics.token()?)?),
        None => None,
    };
    let mut client = SeedLinkClient::new(config.seedlink.clone(), state_dir.as_deref())?;
    let mut sink: Box<dyn PacketSink> = match args.to {
        Output::Iceoryx2 => {
            if config.iceoryx2.config_file.is_none() {
                bail!(
                    "--to iceoryx2 needs the iceoryx2 config file every process loads: give \
                     [iceoryx2] config_file in {} (e.g. \"iceoryx2.toml\")",
                    args.config.display()
                );
            }
            Box::new(IoxPacketSink::new(&config.iceoryx2)?)
        }
        Output::Ros2 => {
            let plan = network_plan_from_env(&config.ros2, rockwatch::ros2::STATION_ENCLAVE)?;
            let map = config.partition_map().map_err(anyhow::Error::msg)?;
            Box::new(Ros2PacketSink::open_partitioned(
                &plan,
                config.ros2.naming()?,
                map,
            )?)
        }
    };
    tracing::info!(
        "acquire: {} streams from {}; waiting for the node's subscription",
        config.seedlink.streams.len(),
        config.seedlink.server
    );
    while !sink.wait_for_subscriber(Duration::from_millis(500))? {
        if stop.load(Ordering::Relaxed) {
            return Ok(());
        }
    }
    if let Some(systemd) = &mut systemd {
        systemd.ready(&format!(
            "{} streams from {}",
            config.seedlink.streams.len(),
            config.seedlink.server
        ));
    }
    let mut publisher = Watched {
        inner: PacketPublisher::new(
            inventory,
            config.assembly_config(),
            config.clipping.clone(),
            sink.as_mut(),
        ),
        systemd: systemd.as_mut(),
        metrics,
        status_server: (args.to == Output::Ros2).then(|| config.seedlink.server.clone()),
        last_report: Instant::now(),
        link_up: false,
    };
    let result = client.run(&stop, &mut publisher);
    if let Some(systemd) = publisher.systemd.take() {
        systemd.stopping();
    }
    if let Some(metrics) = &publisher.metrics {
        let (published, assembled) = publisher.inner.counters();
        metrics.update(acquire_prometheus(
            &client.counters(),
            &published,
            &assembled,
        ));
    }
    let (published, assembled) = publisher.inner.counters();
    tracing::info!(
        "{}",
        acquire_summary(&client.counters(), &published, &assembled)
    );
    result?;
    if !sink.finish(Duration::from_secs(5))? {
        tracing::warn!("acquire: the node did not acknowledge every packet within 5 s");
    }
    Ok(())
}
