//! SEED station identifiers, shared by the catalogue, the engine and the transports.

use std::borrow::Borrow;
use std::cmp::Ordering;
use std::fmt;
use std::hash::{Hash, Hasher};
use std::sync::Arc;

/// A SEED station identifier `NET.STA.LOC` (validated: network 1–2, station 1–5, location 0–2
/// characters, upper-case ASCII letters and digits).
///
/// Parsed once where it enters (a transport's edge, a configuration or catalogue file) and
/// carried typed from there: a clone shares the text (O(1), no allocation). Compared, ordered
/// and hashed as its text, so a map keyed by `StationId` is looked up with a `&str` too.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
#[serde(try_from = "String", into = "String")]
pub struct StationId {
    code: Arc<str>,
    /// Lengths of the network and station codes (≤ 2 and ≤ 5 bytes).
    network_len: u8,
    station_len: u8,
}

impl PartialEq for StationId {
    fn eq(&self, other: &Self) -> bool {
        self.code == other.code
    }
}

impl Eq for StationId {}

impl PartialOrd for StationId {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for StationId {
    fn cmp(&self, other: &Self) -> Ordering {
        self.code.cmp(&other.code)
    }
}

/// As its text (consistent with [`Borrow<str>`]).
impl Hash for StationId {
    fn hash<H: Hasher>(&self, state: &mut H) {
        self.as_str().hash(state);
    }
}

impl Borrow<str> for StationId {
    fn borrow(&self) -> &str {
        &self.code
    }
}

impl PartialEq<str> for StationId {
    fn eq(&self, other: &str) -> bool {
        &*self.code == other
    }
}

impl PartialEq<&str> for StationId {
    fn eq(&self, other: &&str) -> bool {
        &*self.code == *other
    }
}

/// Why a text is not a station identifier (the message does not name the field).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum StationIdError {
    /// Not three dot-separated codes.
    #[error(
        "{text:?} is not NET.STA.LOC (network, station and location codes separated by \
         two dots, e.g. \"CI.RRS.00\"; an empty location is written \"CI.RRS.\")"
    )]
    NotThreeCodes { text: String },
    /// One code has the wrong length or a character outside A–Z, 0–9.
    #[error("{text:?}: {code_name} code {code:?} must be {min_len}–{max_len} upper-case letters or digits")]
    BadCode {
        text: String,
        /// `network`, `station` or `location`.
        code_name: &'static str,
        code: String,
        min_len: usize,
        max_len: usize,
    },
}

impl StationId {
    /// Parses `NET.STA.LOC`; the error says what is wrong (without the field name).
    pub fn parse(text: &str) -> Result<StationId, StationIdError> {
        let mut parts = text.split('.');
        let (Some(net), Some(sta), Some(loc), None) =
            (parts.next(), parts.next(), parts.next(), parts.next())
        else {
            return Err(StationIdError::NotThreeCodes {
                text: text.to_owned(),
            });
        };
        for (what, code, lengths) in [
            ("network", net, 1..=2),
            ("station", sta, 1..=5),
            ("location", loc, 0..=2),
        ] {
            let charset_ok = code
                .chars()
                .all(|c| c.is_ascii_uppercase() || c.is_ascii_digit());
            if !charset_ok || !lengths.contains(&code.len()) {
                return Err(StationIdError::BadCode {
                    text: text.to_owned(),
                    code_name: what,
                    code: code.to_owned(),
                    min_len: *lengths.start(),
                    max_len: *lengths.end(),
                });
            }
        }
        Ok(StationId {
            code: Arc::from(text),
            // At most 2 and 5 (checked above).
            network_len: net.len() as u8,
            station_len: sta.len() as u8,
        })
    }

    /// The whole identifier, `NET.STA.LOC`.
    #[must_use]
    pub fn as_str(&self) -> &str {
        &self.code
    }

    /// The network code (1–2 characters).
    #[must_use]
    pub fn network(&self) -> &str {
        &self.code[..usize::from(self.network_len)]
    }

    /// The station code (1–5 characters).
    #[must_use]
    pub fn station(&self) -> &str {
        let start = usize::from(self.network_len) + 1;
        &self.code[start..start + usize::from(self.station_len)]
    }

    /// The location code (0–2 characters).
    #[must_use]
    pub fn location(&self) -> &str {
        &self.code[usize::from(self.network_len) + usize::from(self.station_len) + 2..]
    }
}

impl fmt::Display for StationId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.code)
    }
}

impl TryFrom<String> for StationId {
    type Error = StationIdError;
    fn try_from(value: String) -> Result<Self, Self::Error> {
        StationId::parse(&value)
    }
}

impl From<StationId> for String {
    fn from(value: StationId) -> Self {
        value.code.to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn station_ids_follow_seed_lengths_and_charset() {
        assert!(StationId::parse("CI.RRS.00").is_ok());
        assert!(StationId::parse("BK.CMB.").is_ok());
        for bad in [
            "CI.RRS",
            "CIX.RRS.00",
            "CI.TOOLONG.00",
            "CI.R-S.00",
            "ci.rrs.00",
            "CI..00",
        ] {
            assert!(StationId::parse(bad).is_err(), "{bad}");
        }
        let id = StationId::parse("CI.RRS.00").unwrap();
        assert_eq!(
            (id.network(), id.station(), id.location()),
            ("CI", "RRS", "00")
        );
    }

    #[test]
    fn a_clone_shares_the_text_and_compares_as_it() {
        let id = StationId::parse("CI.RRS.00").unwrap();
        let copy = id.clone();
        assert!(
            std::ptr::eq(id.as_str(), copy.as_str()),
            "a clone copied the text"
        );
        assert_eq!(id, "CI.RRS.00");
        let map = std::collections::HashMap::from([(id, 1)]);
        assert_eq!(map.get("CI.RRS.00"), Some(&1));
    }

    #[test]
    fn serde_validates() {
        let id: StationId = serde_json::from_str("\"CI.RRS.00\"").unwrap();
        assert_eq!(serde_json::to_string(&id).unwrap(), "\"CI.RRS.00\"");
        assert!(serde_json::from_str::<StationId>("\"bad\"").is_err());
    }
}
