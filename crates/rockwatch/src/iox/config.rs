//! The `[iceoryx2]` section of the node configuration and the iceoryx2 configuration file
//! every endpoint loads.

use std::path::{Path, PathBuf};

use anyhow::{anyhow, Context};
use iceoryx2::config::Config;
use iceoryx2::prelude::*;

/// The `[iceoryx2]` section of the node configuration.
#[derive(Debug, Clone, PartialEq, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct IoxConfig {
    /// The iceoryx2 configuration file (required by every endpoint; relative paths are
    /// relative to the node configuration file).
    pub config_file: Option<PathBuf>,
    /// Input service name (publish-subscribe and event).
    pub accel_service: String,
    /// Output service name (publish-subscribe and event).
    pub alerts_service: String,
    /// Packets a subscriber buffers per publisher; beyond that the oldest is overwritten
    /// (safe overflow: a slow node never blocks a station) and the loss shows as a sequence gap.
    pub subscriber_buffer: usize,
    /// Most publishers (stations) on `pbr/accel`.
    pub max_publishers: usize,
    /// Alerts kept for subscribers that join late (`pbr/alerts` history).
    pub alert_history: usize,
    /// Dead iceoryx2 nodes (e.g. a `kill -9`ed station) are cleaned at start-up and then
    /// this often (s).
    pub dead_node_check_s: f64,
}

impl Default for IoxConfig {
    fn default() -> Self {
        IoxConfig {
            config_file: None,
            accel_service: "pbr/accel".into(),
            alerts_service: "pbr/alerts".into(),
            subscriber_buffer: 1024,
            max_publishers: 64,
            alert_history: 128,
            dead_node_check_s: 1.0,
        }
    }
}

impl IoxConfig {
    /// The settings of `config_file` (an error if none is set or it cannot be read: iceoryx2
    /// defaults are never used silently).
    pub fn load_iceoryx2_config(&self) -> anyhow::Result<Config> {
        let path = self.config_file.as_deref().context(
            "no iceoryx2 configuration file: set [iceoryx2] config_file (e.g. config/iceoryx2.toml)",
        )?;
        load_config_file(path)
    }
}

/// Top-level tables of an iceoryx2 configuration file (iceoryx2 0.10.0's `Config`).
const ICEORYX2_TABLES: [&str; 2] = ["global", "defaults"];

/// Refuses a file of another kind: iceoryx2 fills every missing key with its default, so a
/// node or catalogue TOML would otherwise load as "iceoryx2's defaults" without a word. An
/// iceoryx2 configuration has a `[global]` table and no top-level key but `global` and
/// `defaults`.
fn check_kind(content: &str) -> Result<(), String> {
    let table: toml::Table = content
        .parse()
        .map_err(|e: toml::de::Error| format!("not a TOML file: {}", e.message()))?;
    if let Some(key) = table
        .keys()
        .find(|k| !ICEORYX2_TABLES.contains(&k.as_str()))
    {
        return Err(format!(
            "not an iceoryx2 configuration: top-level key `{key}` (an iceoryx2 configuration \
             has only [global] and [defaults]; is this a node or catalogue file?)"
        ));
    }
    if !table.contains_key("global") {
        return Err("not an iceoryx2 configuration: no [global] table".into());
    }
    Ok(())
}

/// Reads an iceoryx2 configuration file; the error names the file.
pub fn load_config_file(path: &Path) -> anyhow::Result<Config> {
    // Read it ourselves first for a clear error (iceoryx2 reports only an error code).
    let content = rockwatch_core::bounded_read::read_to_string_bounded(
        path,
        rockwatch_core::bounded_read::MAX_CONFIG_FILE_BYTES,
    )
    .with_context(|| format!("{}: cannot read the iceoryx2 configuration", path.display()))?;
    check_kind(&content).map_err(|e| anyhow!("{}: {e}", path.display()))?;
    let text = path
        .to_str()
        .with_context(|| format!("{}: path is not UTF-8", path.display()))?;
    let file_path =
        FilePath::new(text.as_bytes()).map_err(|e| anyhow!("{}: {e:?}", path.display()))?;
    Config::from_file(&file_path).map_err(|e| {
        anyhow!(
            "{}: not a valid iceoryx2 configuration: {e:?}",
            path.display()
        )
    })
}
