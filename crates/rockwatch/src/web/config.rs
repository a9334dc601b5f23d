//! The listeners' sections of the configuration, `[web]` and `[metrics]` (one rule for both,
//! [`listener_token`]):
//!
//! ```toml
//! [web]
//! listen = "127.0.0.1:8080"        # off when absent; loopback unless token_file is set
//! token_file = "/etc/rockwatch/web.token"   # a bearer token, required off loopback
//! tiles = "https://tile.openstreetmap.org/{z}/{x}/{y}.png"   # optional map background
//! tiles_attribution = "© OpenStreetMap contributors"
//! ```
//!
//! A `listen` address that is not loopback (every address it resolves to must be in
//! 127.0.0.0/8 or `::1`) is refused at load without `token_file`: the dashboard and its API
//! show every rock's position and state. With a token every request must carry
//! `Authorization: Bearer <token>` (compared in constant time), else 401. `[metrics]`
//! (`listen`, `token_file`: the node's and `rockwatch acquire`'s `/metrics`-only listener)
//! follows the same rule.

use std::net::{SocketAddr, ToSocketAddrs};
use std::path::{Path, PathBuf};

use super::tiles::{MapTiles, TilesConfigError};

/// Longest token file read (bytes).
pub const MAX_TOKEN_BYTES: u64 = 4096;

/// Shortest token accepted (bytes, after trimming whitespace).
pub const MIN_TOKEN_BYTES: usize = 16;

/// The `[web]` section.
#[derive(Debug, Clone, Default, PartialEq, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WebConfig {
    /// Address of the dashboard (`host:port`); none (off) by default.
    #[serde(default)]
    pub listen: Option<String>,
    /// File holding the bearer token every request must carry (one line; relative to the
    /// configuration file). Required when `listen` is not a loopback address.
    #[serde(default)]
    pub token_file: Option<PathBuf>,
    /// A slippy-map tile URL template for the map's background (`{z}`, `{x}`, `{y}`; http or
    /// https), fetched by the operator's browser; none (no tiles, the page fully offline) by
    /// default. Checked by [`WebConfig::tiles`].
    #[serde(default)]
    pub tiles: Option<String>,
    /// The tiles' attribution, shown under the map (e.g. `© OpenStreetMap contributors`).
    #[serde(default)]
    pub tiles_attribution: Option<String>,
}

impl WebConfig {
    /// Resolves `token_file` against the configuration file's folder `base`.
    pub fn resolve(&mut self, base: &Path) {
        self.token_file = self.token_file.take().map(|f| base.join(f));
    }

    /// Checks the section: the tile keys ([`WebConfig::tiles`]); `listen` parses as
    /// `host:port`, and an address that is not loopback has a `token_file` (which must hold a
    /// token of at least [`MIN_TOKEN_BYTES`]). The error names the key.
    pub fn validate(&self) -> Result<(), WebConfigError> {
        self.tiles()?;
        self.token()?;
        Ok(())
    }

    /// The token, if `token_file` is set (read now), after the listener's checks
    /// ([`listener_token`]).
    pub fn token(&self) -> Result<Option<String>, ListenerError> {
        listener_token("[web]", self.listen.as_deref(), self.token_file.as_deref())
    }

    /// The map's tiles, if `tiles` is set, after the checks of [`MapTiles::from_config`].
    pub fn tiles(&self) -> Result<Option<MapTiles>, TilesConfigError> {
        MapTiles::from_config(
            self.listen.is_some(),
            self.tiles.as_deref(),
            self.tiles_attribution.as_deref(),
        )
    }
}

/// The `[metrics]` section of the node configuration.
#[derive(Debug, Clone, Default, PartialEq, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MetricsConfig {
    /// Address of the endpoint (`host:port`); none by default.
    #[serde(default)]
    pub listen: Option<String>,
    /// File holding the bearer token every request must carry (one line; relative to the
    /// configuration file). Required when `listen` is not a loopback address.
    #[serde(default)]
    pub token_file: Option<PathBuf>,
}

impl MetricsConfig {
    /// Resolves `token_file` against the configuration file's folder `base`.
    pub fn resolve(&mut self, base: &Path) {
        self.token_file = self.token_file.take().map(|f| base.join(f));
    }

    /// Checks the section (the rule of [`listener_token`]) and reads the
    /// token, if `token_file` is set. The error names the key.
    pub fn token(&self) -> Result<Option<String>, ListenerError> {
        listener_token(
            "[metrics]",
            self.listen.as_deref(),
            self.token_file.as_deref(),
        )
    }
}

/// Why the `[web]` section is refused (the message names the key).
#[derive(Debug, thiserror::Error)]
pub enum WebConfigError {
    #[error(transparent)]
    Tiles(#[from] TilesConfigError),
    #[error(transparent)]
    Listener(#[from] ListenerError),
}

/// Why a listener's keys (`{section} listen`, `{section} token_file`) are refused.
#[derive(Debug, thiserror::Error)]
pub enum ListenerError {
    #[error("{section} token_file is set but {section} listen is not")]
    TokenWithoutListen { section: &'static str },
    #[error("{section} listen = {listen:?}: not a host:port address ({error})")]
    NotAnAddress {
        section: &'static str,
        listen: String,
        error: std::io::Error,
    },
    #[error("{section} listen = {listen:?}: resolves to no address")]
    NoAddress {
        section: &'static str,
        listen: String,
    },
    #[error(
        "{section} listen = {listen:?} is not a loopback address: it would be open to the \
         network; set {section} token_file (a bearer token checked on every request) or \
         listen on 127.0.0.1"
    )]
    NotLoopback {
        section: &'static str,
        listen: String,
    },
    #[error(transparent)]
    Token(#[from] TokenFileError),
}

/// Why a token file is refused; `key` names where it was given (`[web] token_file`,
/// `--token-file`).
#[derive(Debug, thiserror::Error)]
pub enum TokenFileError {
    #[error("{key} = {file:?}: {error}")]
    Unreadable {
        key: String,
        file: String,
        error: std::io::Error,
    },
    #[error(
        "{key} = {file:?}: the token must be one word of at least {MIN_TOKEN_BYTES} characters"
    )]
    NotAToken { key: String, file: String },
}

/// The rule of every listener the node opens (`[web]`, `[metrics]`): `listen` parses as
/// `host:port`; an address that is not loopback (every address it resolves to in 127.0.0.0/8
/// or `::1`) needs `token_file`, whose token every request must then carry. Returns that
/// token (read now); errors name `section`'s keys.
pub fn listener_token(
    section: &'static str,
    listen: Option<&str>,
    token_file: Option<&Path>,
) -> Result<Option<String>, ListenerError> {
    let Some(listen) = listen else {
        if token_file.is_some() {
            return Err(ListenerError::TokenWithoutListen { section });
        }
        return Ok(None);
    };
    let addresses = resolve(section, listen)?;
    let loopback = addresses.iter().all(|a| a.ip().is_loopback());
    match token_file {
        Some(file) => Ok(Some(load_token(&format!("{section} token_file"), file)?)),
        None if loopback => Ok(None),
        None => Err(ListenerError::NotLoopback {
            section,
            listen: listen.to_owned(),
        }),
    }
}

/// Every address `listen` (`host:port`) stands for.
fn resolve(section: &'static str, listen: &str) -> Result<Vec<SocketAddr>, ListenerError> {
    let addresses: Vec<SocketAddr> = listen
        .to_socket_addrs()
        .map_err(|error| ListenerError::NotAnAddress {
            section,
            listen: listen.to_owned(),
            error,
        })?
        .collect();
    if addresses.is_empty() {
        return Err(ListenerError::NoAddress {
            section,
            listen: listen.to_owned(),
        });
    }
    Ok(addresses)
}

/// Reads a token file: its content trimmed; an error names `key` (`[web] token_file`,
/// `--token-file`).
pub fn load_token(key: &str, file: &Path) -> Result<String, TokenFileError> {
    let text = rockwatch_core::bounded_read::read_to_string_bounded(file, MAX_TOKEN_BYTES)
        .map_err(|error| TokenFileError::Unreadable {
            key: key.to_owned(),
            file: file.display().to_string(),
            error,
        })?;
    let token = text.trim();
    if token.len() < MIN_TOKEN_BYTES || token.chars().any(|c| c.is_whitespace()) {
        return Err(TokenFileError::NotAToken {
            key: key.to_owned(),
            file: file.display().to_string(),
        });
    }
    Ok(token.to_string())
}

/// Compares `given` with `expected` in time independent of where they differ (the length of
/// `expected` is not secret).
#[must_use]
pub fn token_matches(given: &[u8], expected: &[u8]) -> bool {
    if given.len() != expected.len() {
        return false;
    }
    given
        .iter()
        .zip(expected)
        .fold(0u8, |acc, (a, b)| acc | (a ^ b))
        == 0
}

#[cfg(test)]
mod tests {
    use super::*;

    fn config(listen: &str, token_file: Option<PathBuf>) -> WebConfig {
        WebConfig {
            listen: Some(listen.into()),
            token_file,
            ..WebConfig::default()
        }
    }

    #[test]
    fn loopback_is_accepted_without_a_token_and_another_address_is_refused() {
        assert!(config("127.0.0.1:8080", None).validate().is_ok());
        assert!(config("[::1]:0", None).validate().is_ok());
        assert!(config("localhost:0", None).validate().is_ok());
        let e = config("0.0.0.0:8080", None).validate().unwrap_err();
        assert!(matches!(
            e,
            WebConfigError::Listener(ListenerError::NotLoopback { .. })
        ));
        let e = e.to_string();
        assert!(
            e.contains("not a loopback address") && e.contains("token_file"),
            "{e}"
        );
        let e = config("nonsense", None).validate().unwrap_err();
        assert!(matches!(
            e,
            WebConfigError::Listener(ListenerError::NotAnAddress { .. })
        ));
        assert!(e.to_string().contains("[web] listen"), "{e}");
        assert!(WebConfig::default().validate().is_ok());
    }

    #[test]
    fn a_token_file_must_hold_a_long_enough_token() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("token");
        std::fs::write(&file, "short\n").unwrap();
        let e = config("0.0.0.0:0", Some(file.clone()))
            .validate()
            .unwrap_err();
        assert!(matches!(
            e,
            WebConfigError::Listener(ListenerError::Token(TokenFileError::NotAToken { .. }))
        ));
        assert!(e.to_string().contains("at least"), "{e}");
        std::fs::write(&file, "0123456789abcdef0123\n").unwrap();
        let c = config("0.0.0.0:0", Some(file));
        assert!(c.validate().is_ok());
        assert_eq!(c.token().unwrap().as_deref(), Some("0123456789abcdef0123"));
        let e = config("0.0.0.0:0", Some(dir.path().join("missing")))
            .validate()
            .unwrap_err();
        assert!(matches!(
            e,
            WebConfigError::Listener(ListenerError::Token(TokenFileError::Unreadable { .. }))
        ));
        assert!(e.to_string().contains("[web] token_file"), "{e}");
    }

    #[test]
    fn tokens_compare_whole() {
        assert!(token_matches(b"abcdef", b"abcdef"));
        assert!(!token_matches(b"abcdeg", b"abcdef"));
        assert!(!token_matches(b"abcde", b"abcdef"));
        assert!(!token_matches(b"", b"abcdef"));
    }
}
