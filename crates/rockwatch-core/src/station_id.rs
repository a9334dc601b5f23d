//! SEED station identifiers, shared by the catalogue, the engine and the transports.

use std::fmt;

/// A SEED station identifier `NET.STA.LOC` (validated: network 1–2, station 1–5, location 0–2
/// characters, upper-case ASCII letters and digits).
#[derive(
    Debug, Clone, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Serialize, serde::Deserialize,
)]
#[serde(try_from = "String", into = "String")]
pub struct StationId {
    code: String,
    network_len: usize,
    station_len: usize,
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
        let parts: Vec<&str> = text.split('.').collect();
        let [net, sta, loc] = parts[..] else {
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
            code: text.to_owned(),
            network_len: net.len(),
            station_len: sta.len(),
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
        &self.code[..self.network_len]
    }

    /// The station code (1–5 characters).
    #[must_use]
    pub fn station(&self) -> &str {
        let start = self.network_len + 1;
        &self.code[start..start + self.station_len]
    }

    /// The location code (0–2 characters).
    #[must_use]
    pub fn location(&self) -> &str {
        &self.code[self.network_len + self.station_len + 2..]
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
        value.code
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
    fn serde_validates() {
        let id: StationId = serde_json::from_str("\"CI.RRS.00\"").unwrap();
        assert_eq!(serde_json::to_string(&id).unwrap(), "\"CI.RRS.00\"");
        assert!(serde_json::from_str::<StationId>("\"bad\"").is_err());
    }
}
