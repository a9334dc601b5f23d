//! `rockwatch acquire`, the station acquisition process: SeedLink records
//! ([`crate::seedlink::SeedLinkClient`]) → decoded by the project's MiniSEED reader →
//! calibrated, rotated and aligned with StationXML ([`rockwatch_core::assembly`]) →
//! [`AccelPacket`](rockwatch_core::engine::AccelPacket)s published to the node through a
//! [`PacketSink`] (iceoryx2 or ROS 2). Configuration: `config/acquire.toml` (every key).

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::time::Instant;

use rockwatch_core::assembly::{Assembler, AssemblyConfig, AssemblyCounters};
use rockwatch_core::inventory::Inventory;
use rockwatch_core::record::mseed::{Channel, NS_PER_S};

use crate::iox::IoxConfig;
use crate::log_text::{printable, STATION_CHARS};
use crate::ports::PacketSink;
use crate::ros2::Ros2Config;
use crate::seedlink::{RecordSink, SeedLinkConfig};

/// The acquisition configuration file.
#[derive(Debug, Clone, PartialEq, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AcquireConfig {
    pub seedlink: SeedLinkConfig,
    pub inventory: InventorySection,
    #[serde(default)]
    pub assembly: AssemblySection,
    /// Where the SeedLink resume state is kept (overridden by `--state-dir`).
    #[serde(default)]
    pub state_dir: Option<PathBuf>,
    /// ROS 2 output (`--to ros2`): the node's `[ros2]` section.
    #[serde(default)]
    pub ros2: Ros2Config,
    /// iceoryx2 output (`--to iceoryx2`, the default): the node's `[iceoryx2]` section.
    #[serde(default)]
    pub iceoryx2: IoxConfig,
    /// ROS 2 output to a scaled-out service of this many partitioned nodes
    /// (docs/capacity.md): each station's packets go to its partition's topic
    /// `/pbr/accel/p<i>of<N>`. None: `/pbr/accel`.
    #[serde(default)]
    pub partitions: Option<u32>,
    /// Stations assigned to a partition explicitly, as in the nodes' configurations.
    #[serde(default)]
    pub partition_assign: BTreeMap<String, u32>,
}

/// `[inventory]`.
#[derive(Debug, Clone, PartialEq, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InventorySection {
    /// StationXML files (relative to the configuration file).
    pub stationxml: Vec<PathBuf>,
}

/// `[assembly]`.
#[derive(Debug, Clone, Copy, PartialEq, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct AssemblySection {
    /// Seconds a span waits for a missing component before it is published without it.
    pub max_wait_s: f64,
    /// Most samples per published packet.
    pub max_packet_samples: usize,
    /// Most seconds of data held per component waiting for the others.
    pub max_buffer_s: f64,
}

impl Default for AssemblySection {
    fn default() -> Self {
        let d = AssemblyConfig::default();
        AssemblySection {
            max_wait_s: d.max_wait_ns as f64 / NS_PER_S as f64,
            max_packet_samples: d.max_packet_samples,
            max_buffer_s: d.max_buffer_s,
        }
    }
}

impl AcquireConfig {
    /// Reads and checks `path`; relative paths are taken from the file's directory; errors
    /// name the file (and the line, for TOML syntax).
    pub fn load(path: &Path) -> Result<AcquireConfig, String> {
        let fail = |e: String| format!("{}: {e}", path.display());
        let text = std::fs::read_to_string(path).map_err(|e| fail(e.to_string()))?;
        let mut config: AcquireConfig = toml::from_str(&text)
            .map_err(|e| fail(rockwatch_core::catalogue::toml_error_line(&text, &e)))?;
        let base = path.parent().unwrap_or(Path::new("."));
        for file in &mut config.inventory.stationxml {
            *file = base.join(&*file);
        }
        config.state_dir = config.state_dir.map(|d| base.join(d));
        config.iceoryx2.config_file = config.iceoryx2.config_file.map(|f| base.join(f));
        config.seedlink.patterns().map_err(fail)?;
        config.partition_map().map_err(fail)?;
        if config.inventory.stationxml.is_empty() {
            return Err(fail(
                "inventory.stationxml is empty: list the StationXML files".into(),
            ));
        }
        let a = config.assembly;
        let ok = a.max_wait_s.is_finite()
            && (0.0..=3600.0).contains(&a.max_wait_s)
            && (1..=rockwatch_core::engine::packet::MAX_SAMPLES_PER_PACKET)
                .contains(&a.max_packet_samples)
            && a.max_buffer_s.is_finite()
            && (1.0..=86_400.0).contains(&a.max_buffer_s);
        if !ok {
            return Err(fail(format!(
                "[assembly] out of range: max_wait_s 0–3600, max_packet_samples 1–100000, max_buffer_s 1–86400 (got {a:?})"
            )));
        }
        Ok(config)
    }

    /// The partition map of the ROS 2 output (`partitions`, `[partition_assign]`), if any.
    pub fn partition_map(&self) -> Result<Option<rockwatch_core::partition::PartitionMap>, String> {
        match self.partitions {
            Some(n) => crate::node_config::partition_map(n, &self.partition_assign).map(Some),
            None if self.partition_assign.is_empty() => Ok(None),
            None => Err("[partition_assign] needs `partitions = N`".into()),
        }
    }

    /// The assembler settings.
    #[must_use]
    pub fn assembly_config(&self) -> AssemblyConfig {
        AssemblyConfig {
            max_wait_ns: (self.assembly.max_wait_s * 1e9) as i64,
            max_packet_samples: self.assembly.max_packet_samples,
            max_buffer_s: self.assembly.max_buffer_s,
        }
    }
}

/// What the publisher did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
pub struct PublishCounters {
    pub packets_sent: u64,
    pub send_errors: u64,
}

/// The record sink of `acquire`: assembles records into packets and sends them.
pub struct PacketPublisher<'a> {
    assembler: Assembler,
    sink: &'a mut dyn PacketSink,
    clock: Instant,
    counters: PublishCounters,
    /// (stream, problem) already logged.
    logged: BTreeSet<(String, String)>,
}

impl<'a> PacketPublisher<'a> {
    #[must_use]
    pub fn new(inventory: Inventory, config: AssemblyConfig, sink: &'a mut dyn PacketSink) -> Self {
        PacketPublisher {
            assembler: Assembler::new(inventory, config),
            sink,
            clock: Instant::now(),
            counters: PublishCounters::default(),
            logged: BTreeSet::new(),
        }
    }

    #[must_use]
    pub fn counters(&self) -> (PublishCounters, AssemblyCounters) {
        (self.counters, self.assembler.counters())
    }

    fn now_ns(&self) -> i64 {
        i64::try_from(self.clock.elapsed().as_nanos()).unwrap_or(i64::MAX)
    }
}

/// Sends packets, counting and logging (once per kind) failures.
fn send_all<'s>(
    sink: &'s mut dyn PacketSink,
    counters: &'s mut PublishCounters,
) -> impl FnMut(rockwatch_core::engine::AccelPacket) + 's {
    move |packet| match sink.send(&packet) {
        Ok(()) => counters.packets_sent += 1,
        Err(e) => {
            if counters.send_errors == 0 {
                eprintln!("rockwatch: acquire: cannot publish a packet of {}: {e:#} (further failures counted)", printable(&packet.station, STATION_CHARS));
            }
            counters.send_errors += 1;
        }
    }
}

impl RecordSink for PacketPublisher<'_> {
    fn record(&mut self, record: &Channel) -> bool {
        let now = self.now_ns();
        let mut send = send_all(&mut *self.sink, &mut self.counters);
        let result = self.assembler.push(record, now, &mut send);
        drop(send);
        if let Err(issue) = result {
            let id = record.id();
            let problem = issue.to_string();
            if self.logged.len() < 10_000 && self.logged.insert((id.clone(), problem.clone())) {
                eprintln!(
                    "rockwatch: acquire: {}: {} (record dropped; logged once, counted)",
                    printable(&id, STATION_CHARS),
                    printable(&problem, 300)
                );
            }
            return false;
        }
        let station = format!("{}.{}.{}", record.net, record.sta, record.loc);
        let end = record.segments.last().map_or(0, |s| {
            s.start_time_ns + (s.samples.len() as f64 * 1e9 / record.sample_rate_hz).round() as i64
        });
        self.assembler
            .emitted_until_ns(&station)
            .is_none_or(|t| t < end)
    }

    fn published_until_ns(&self, station: &str) -> Option<i64> {
        self.assembler.emitted_until_ns(station)
    }

    fn tick(&mut self) {
        let now = self.now_ns();
        let mut send = send_all(&mut *self.sink, &mut self.counters);
        self.assembler.tick(now, &mut send);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_documented_configuration_loads_with_paths_relative_to_it() {
        let path = Path::new(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../config/acquire.toml"
        ));
        let config = AcquireConfig::load(path).unwrap();
        assert_eq!(config.seedlink.server, "127.0.0.1:18000");
        assert_eq!(config.seedlink.streams, ["CI.RRS..HN?", "BK.*..HN?"]);
        assert!(config.inventory.stationxml[0].ends_with("config/inventory/ci.xml"));
        assert_eq!(config.assembly, AssemblySection::default());
        assert_eq!(config.assembly_config(), AssemblyConfig::default());
        assert!(config
            .iceoryx2
            .config_file
            .unwrap()
            .ends_with("config/iceoryx2.toml"));
    }

    #[test]
    fn bad_values_are_refused_naming_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.toml");
        let base = "[seedlink]\nserver = \"h:1\"\nstreams = [\"XX.S..HN?\"]\n[inventory]\nstationxml = [\"x.xml\"]\n";
        for (extra, needle) in [
            ("[assembly]\nmax_wait_s = -1.0\n", "[assembly] out of range"),
            ("[partition_assign]\n\"XX.S.00\" = 1\n", "needs `partitions"),
            ("", ""),
        ] {
            std::fs::write(&path, format!("{base}{extra}")).unwrap();
            match AcquireConfig::load(&path) {
                Ok(_) => assert!(needle.is_empty()),
                Err(e) => assert!(
                    !needle.is_empty() && e.contains(needle) && e.contains("a.toml"),
                    "{e}"
                ),
            }
        }
        std::fs::write(&path, base.replace("XX.S..HN?", "XX.S.HN?")).unwrap();
        assert!(AcquireConfig::load(&path)
            .unwrap_err()
            .contains("not NET.STA.LOC.CHA"));
        std::fs::write(
            &path,
            base.replace("[seedlink]", "[seedlink]\nprotocol = 5"),
        )
        .unwrap();
        assert!(AcquireConfig::load(&path)
            .unwrap_err()
            .contains("protocol must be"));
    }
}
