//! The `[[notify]]` entries of the node configuration: one alert receiver each.

use rockwatch_core::engine::{Alert, AlertLevel};

use crate::log_text::printable;

/// How a receiver is reached.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum NotifyKind {
    /// Run `command` (no shell) with the alert JSON on stdin; exit status 0 acknowledges.
    Exec,
    /// HTTP POST of the alert JSON to `url`; a 2xx status acknowledges.
    Webhook,
}

/// One `[[notify]]` entry: where alerts go and which ones.
#[derive(Debug, Clone, PartialEq, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NotifyConfig {
    pub kind: NotifyKind,
    /// `webhook`: `http://` or `https://` URL.
    #[serde(default)]
    pub url: Option<String>,
    /// `exec`: program and arguments (run directly, not through a shell).
    #[serde(default)]
    pub command: Vec<String>,
    /// Longest one delivery attempt may take (s): an `exec` command still running is killed,
    /// an HTTP request abandoned; the attempt counts as failed and is retried. Default 10.
    #[serde(default = "default_timeout_s")]
    pub timeout_s: f64,
    /// Alert levels delivered; default: all.
    #[serde(default)]
    pub levels: Option<Vec<AlertLevel>>,
    /// Ids of the blocks whose alerts are delivered; default: all.
    #[serde(default)]
    pub pbrs: Option<Vec<String>>,
    /// Wait before the first retry of a failed delivery (s); doubled at each failure up to
    /// `retry_max_s`. Default 1.
    #[serde(default = "default_retry_initial_s")]
    pub retry_initial_s: f64,
    /// Longest wait between two retries (s). Default 300.
    #[serde(default = "default_retry_max_s")]
    pub retry_max_s: f64,
    /// Alerts queued in memory for the receiver's thread; beyond, an alert waits in the spool
    /// only (counted as an overflow) and is delivered from there. Default 1024.
    #[serde(default = "default_queue")]
    pub queue: usize,
}

fn default_timeout_s() -> f64 {
    10.0
}
fn default_retry_initial_s() -> f64 {
    1.0
}
fn default_retry_max_s() -> f64 {
    300.0
}
fn default_queue() -> usize {
    1024
}

/// Longest `timeout_s` (s).
pub const MAX_TIMEOUT_S: f64 = 3600.0;
/// Longest `retry_max_s` (s).
pub const MAX_RETRY_S: f64 = 86_400.0;
/// Largest `queue`.
pub const MAX_QUEUE: usize = 1 << 20;

/// A `[[notify]]` entry that is invalid: which key and why.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct NotifyConfigError(pub String);

impl From<String> for NotifyConfigError {
    fn from(reason: String) -> Self {
        NotifyConfigError(reason)
    }
}

impl From<&str> for NotifyConfigError {
    fn from(reason: &str) -> Self {
        NotifyConfigError(reason.to_owned())
    }
}

impl NotifyConfig {
    /// Checks the entry; the error says which key is wrong and why.
    pub fn validate(&self) -> Result<(), NotifyConfigError> {
        match self.kind {
            NotifyKind::Webhook => {
                let url = self
                    .url
                    .as_deref()
                    .ok_or("kind = \"webhook\" needs a url")?;
                if !(url.starts_with("http://") || url.starts_with("https://")) {
                    return Err(NotifyConfigError::from(format!(
                        "url {url:?}: must start with http:// or https://"
                    )));
                }
                if !self.command.is_empty() {
                    return Err(NotifyConfigError::from(
                        "command is for kind = \"exec\"; a webhook has a url",
                    ));
                }
            }
            NotifyKind::Exec => {
                if self.command.first().is_none_or(String::is_empty) {
                    return Err(NotifyConfigError::from(
                        "kind = \"exec\" needs command = [\"program\", …]",
                    ));
                }
                if self.url.is_some() {
                    return Err(NotifyConfigError::from(
                        "url is for kind = \"webhook\"; exec has a command",
                    ));
                }
            }
        }
        let in_range = |v: f64, max: f64| v.is_finite() && v > 0.0 && v <= max;
        if !in_range(self.timeout_s, MAX_TIMEOUT_S) {
            return Err(NotifyConfigError::from(format!(
                "timeout_s = {}: out of range (0, {MAX_TIMEOUT_S}]",
                self.timeout_s
            )));
        }
        if !in_range(self.retry_max_s, MAX_RETRY_S) {
            return Err(NotifyConfigError::from(format!(
                "retry_max_s = {}: out of range (0, {MAX_RETRY_S}]",
                self.retry_max_s
            )));
        }
        if !in_range(self.retry_initial_s, self.retry_max_s) {
            return Err(NotifyConfigError::from(format!(
                "retry_initial_s = {}: out of range (0, retry_max_s = {}]",
                self.retry_initial_s, self.retry_max_s
            )));
        }
        if !(1..=MAX_QUEUE).contains(&self.queue) {
            return Err(NotifyConfigError::from(format!(
                "queue = {}: out of range 1 to {MAX_QUEUE}",
                self.queue
            )));
        }
        if self.levels.as_ref().is_some_and(Vec::is_empty) {
            return Err(NotifyConfigError::from(
                "levels = []: would deliver nothing (leave it out for all)",
            ));
        }
        if self.pbrs.as_ref().is_some_and(Vec::is_empty) {
            return Err(NotifyConfigError::from(
                "pbrs = []: would deliver nothing (leave it out for all)",
            ));
        }
        Ok(())
    }

    /// Whether this receiver takes `alert` (its level and block pass the filters).
    #[must_use]
    pub fn accepts(&self, alert: &Alert) -> bool {
        self.levels
            .as_ref()
            .is_none_or(|l| l.contains(&alert.level))
            && self
                .pbrs
                .as_ref()
                .is_none_or(|p| p.iter().any(|id| alert.pbr_id == id.as_str()))
    }

    /// The receiver for people: `webhook URL` or `exec PROGRAM` (printable, bounded).
    #[must_use]
    pub fn name(&self) -> String {
        match self.kind {
            NotifyKind::Webhook => format!(
                "webhook {}",
                printable(self.url.as_deref().unwrap_or(""), 200)
            ),
            NotifyKind::Exec => format!(
                "exec {}",
                printable(self.command.first().map_or("", String::as_str), 200)
            ),
        }
    }

    /// File name of the receiver's spool in `<state_dir>/notify/`: kind and a checksum of its
    /// target (url, or command and arguments), so a receiver keeps its spool across restarts
    /// and reorderings of the configuration, and a changed target starts a new one.
    #[must_use]
    pub fn spool_file_name(&self) -> String {
        let (kind, target) = match self.kind {
            NotifyKind::Webhook => ("webhook", self.url.clone().unwrap_or_default()),
            NotifyKind::Exec => ("exec", self.command.join("\0")),
        };
        format!("{kind}-{:08x}.spool", crc32fast::hash(target.as_bytes()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<NotifyConfig, String> {
        let c: NotifyConfig = toml::from_str(text).map_err(|e| e.to_string())?;
        c.validate().map(|()| c).map_err(|e| e.to_string())
    }

    #[test]
    fn entries_are_checked_key_by_key() {
        let c = parse("kind = \"webhook\"\nurl = \"http://127.0.0.1:8080/a\"\n").unwrap();
        assert_eq!(
            (c.timeout_s, c.retry_initial_s, c.retry_max_s),
            (10.0, 1.0, 300.0)
        );
        assert_eq!((c.queue, c.levels, c.pbrs), (1024, None, None));
        for (bad, says) in [
            ("kind = \"webhook\"\n", "needs a url"),
            ("kind = \"webhook\"\nurl = \"ftp://x\"\n", "http://"),
            ("kind = \"exec\"\n", "needs command"),
            ("kind = \"exec\"\ncommand = [\"\"]\n", "needs command"),
            (
                "kind = \"exec\"\ncommand = [\"x\"]\nurl = \"http://a\"\n",
                "url is for",
            ),
            (
                "kind = \"exec\"\ncommand = [\"x\"]\ntimeout_s = 0.0\n",
                "timeout_s",
            ),
            (
                "kind = \"exec\"\ncommand = [\"x\"]\nretry_initial_s = 400.0\n",
                "retry_initial_s",
            ),
            ("kind = \"exec\"\ncommand = [\"x\"]\nqueue = 0\n", "queue"),
            (
                "kind = \"exec\"\ncommand = [\"x\"]\nlevels = []\n",
                "levels",
            ),
            (
                "kind = \"exec\"\ncommand = [\"x\"]\nlevels = [\"fell\"]\n",
                "unknown variant",
            ),
            ("kind = \"pager\"\n", "unknown variant"),
        ] {
            let e = parse(bad).unwrap_err();
            assert!(e.contains(says), "{bad}: {e}");
        }
    }

    #[test]
    fn filters_select_by_level_and_block() {
        let c = parse(
            "kind = \"exec\"\ncommand = [\"x\"]\nlevels = [\"overturned\"]\npbrs = [\"a\", \"b\"]\n",
        )
        .unwrap();
        let alert = |pbr: &str, level| Alert {
            pbr_id: rockwatch_core::engine::PbrId::parse(pbr).unwrap(),
            station: rockwatch_core::engine::StationId::parse("XX.A.00").unwrap(),
            level,
            episode: 1,
            mode: rockwatch_core::dynamics::Mode::Rock,
            theta_over_alpha: 0.0,
            slide_m: 0.0,
            overturn_probability: 0.0,
            pga_mps2: 0.0,
            pgv_mps: 0.0,
            data_time_ns: 0,
            arrival_ns: 0,
            direction_deg: 0.0,
            lat_deg: Default::default(),
            lon_deg: Default::default(),
            pbr_name: Default::default(),
        };
        assert!(c.accepts(&alert("b", AlertLevel::Overturned)));
        assert!(!c.accepts(&alert("c", AlertLevel::Overturned)));
        assert!(!c.accepts(&alert("a", AlertLevel::MotionOnset)));
        let all = parse("kind = \"exec\"\ncommand = [\"x\"]\n").unwrap();
        assert!(all.accepts(&alert("c", AlertLevel::MotionOnset)));
    }
}
