//! Stream selections (`NET.STA.LOC.CHA` with `?` and `*` wildcards, as in the acquisition
//! configuration) and the SeedLink commands that request them.
//!
//! Per station pattern (`NET.STA`), the client sends `STATION` (v3: `STATION STA NET`; v4:
//! `STATION NET_STA`), one `SELECT` per location/channel pattern that the protocol can
//! express, then `DATA`. What the server sends is always checked again against the full
//! patterns ([`StreamPattern::matches`]), so a server that selects more than asked (v3 cannot
//! express `*` inside a code) costs bandwidth, never wrong data.
//!
//! SELECT syntax: v3 `[LL]CCC` with `?` wildcards (no `*`); an empty location is left out
//! (any location, checked on arrival). v4 `LOC_B_S_SS` with `?` and `*` (libslink's v3→v4
//! conversion): location `*` for any, empty for the empty location code.

use super::Protocol;

/// One `NET.STA.LOC.CHA` pattern; `?` matches one character, `*` any run.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct StreamPattern {
    pub network: String,
    pub station: String,
    pub location: String,
    pub channel: String,
}

/// A pattern that is not `NET.STA.LOC.CHA`.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("stream {0:?} is not NET.STA.LOC.CHA (e.g. \"CI.RRS..HN?\"; ? and * are wildcards)")]
pub struct PatternError(pub String);

impl StreamPattern {
    /// Parses `NET.STA.LOC.CHA` (LOC may be empty; codes are ASCII letters, digits, `?`, `*`,
    /// `-`).
    pub fn parse(text: &str) -> Result<StreamPattern, PatternError> {
        let parts: Vec<&str> = text.trim().split('.').collect();
        let ok = |s: &str, empty_ok: bool| {
            (empty_ok || !s.is_empty())
                && s.len() <= 16
                && s.bytes()
                    .all(|b| b.is_ascii_alphanumeric() || matches!(b, b'?' | b'*' | b'-'))
        };
        match parts.as_slice() {
            [n, s, l, c] if ok(n, false) && ok(s, false) && ok(l, true) && ok(c, false) => {
                Ok(StreamPattern {
                    network: n.to_string(),
                    station: s.to_string(),
                    location: l.to_string(),
                    channel: c.to_string(),
                })
            }
            _ => Err(PatternError(text.to_string())),
        }
    }

    /// Whether the stream `net.sta.loc.cha` is selected.
    #[must_use]
    pub fn matches(&self, net: &str, sta: &str, loc: &str, cha: &str) -> bool {
        glob(&self.network, net)
            && glob(&self.station, sta)
            && glob(&self.location, loc)
            && glob(&self.channel, cha)
    }

    /// Whether station `NET.STA` matches the pattern's network and station parts.
    #[must_use]
    pub fn matches_station(&self, net: &str, sta: &str) -> bool {
        glob(&self.network, net) && glob(&self.station, sta)
    }

    /// The `STATION` command for this pattern's station (CRLF-terminated).
    #[must_use]
    pub fn station_command(&self, protocol: Protocol) -> String {
        match protocol {
            Protocol::V3 => format!("STATION {} {}\r\n", self.station, self.network),
            Protocol::V4 => format!("STATION {}_{}\r\n", self.network, self.station),
        }
    }

    /// The `SELECT` command for this pattern's location and channel, or `None` when the
    /// whole station is wanted (channel `*`) or the protocol cannot express the pattern.
    #[must_use]
    pub fn select_command(&self, protocol: Protocol) -> Option<String> {
        if self.channel == "*" {
            return None;
        }
        match protocol {
            Protocol::V3 => {
                let three = self.channel.len() == 3 && !self.channel.contains('*');
                let loc = &self.location;
                let loc_ok = loc.is_empty() || (loc.len() == 2 && !loc.contains('*'));
                (three && loc_ok).then(|| format!("SELECT {loc}{}\r\n", self.channel))
            }
            Protocol::V4 => {
                let mut cha = self.channel.chars();
                let (b, s, ss) = match (cha.next(), cha.next(), cha.next(), cha.next()) {
                    (Some(b), Some(s), Some(ss), None) if !self.channel.contains('*') => {
                        (b.to_string(), s.to_string(), ss.to_string())
                    }
                    _ => return None,
                };
                Some(format!("SELECT {}_{b}_{s}_{ss}\r\n", self.location))
            }
        }
    }

    /// `NET_STA` when the station part has no wildcard (a key of resume state).
    #[must_use]
    pub fn exact_station(&self) -> Option<String> {
        let wild = |s: &str| s.contains(['?', '*']);
        (!wild(&self.network) && !wild(&self.station))
            .then(|| format!("{}_{}", self.network, self.station))
    }
}

/// Glob match with `?` (one character) and `*` (any run), ASCII case-insensitive.
fn glob(pattern: &str, text: &str) -> bool {
    let (p, t) = (pattern.as_bytes(), text.as_bytes());
    let (mut pi, mut ti) = (0, 0);
    let mut star: Option<(usize, usize)> = None;
    while ti < t.len() {
        if pi < p.len() && (p[pi] == b'?' || p[pi].eq_ignore_ascii_case(&t[ti])) {
            pi += 1;
            ti += 1;
        } else if pi < p.len() && p[pi] == b'*' {
            star = Some((pi, ti));
            pi += 1;
        } else if let Some((sp, st)) = star {
            pi = sp + 1;
            ti = st + 1;
            star = Some((sp, st + 1));
        } else {
            return false;
        }
    }
    p[pi..].iter().all(|&b| b == b'*')
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pat(s: &str) -> StreamPattern {
        StreamPattern::parse(s).unwrap()
    }

    #[test]
    fn patterns_parse_and_match_with_wildcards() {
        let p = pat("CI.RRS..HN?");
        assert!(p.matches("CI", "RRS", "", "HNZ") && p.matches("ci", "rrs", "", "HN1"));
        assert!(!p.matches("CI", "RRS", "00", "HNZ") && !p.matches("CI", "RRS", "", "BHZ"));
        let p = pat("BK.*.*.HN*");
        assert!(p.matches("BK", "CMB", "00", "HNZ") && p.matches("BK", "X", "", "HN"));
        assert!(!p.matches("CI", "CMB", "00", "HNZ"));
        for bad in [
            "CI.RRS.HN?",
            "CI..00.HNZ",
            "CI.RRS.00.HNZ.D",
            "CI.R S..HNZ",
            "",
        ] {
            assert!(StreamPattern::parse(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn commands_follow_each_protocol_syntax() {
        let p = pat("CI.RRS..HN?");
        assert_eq!(p.station_command(Protocol::V3), "STATION RRS CI\r\n");
        assert_eq!(p.station_command(Protocol::V4), "STATION CI_RRS\r\n");
        assert_eq!(
            p.select_command(Protocol::V3).as_deref(),
            Some("SELECT HN?\r\n")
        );
        assert_eq!(
            p.select_command(Protocol::V4).as_deref(),
            Some("SELECT _H_N_?\r\n")
        );
        let p = pat("CI.RRS.00.HNZ");
        assert_eq!(
            p.select_command(Protocol::V3).as_deref(),
            Some("SELECT 00HNZ\r\n")
        );
        assert_eq!(
            p.select_command(Protocol::V4).as_deref(),
            Some("SELECT 00_H_N_Z\r\n")
        );
        let p = pat("CI.RRS.*.HN?");
        assert_eq!(p.select_command(Protocol::V3), None);
        assert_eq!(
            p.select_command(Protocol::V4).as_deref(),
            Some("SELECT *_H_N_?\r\n")
        );
        assert_eq!(pat("CI.RRS..*").select_command(Protocol::V4), None);
        assert_eq!(pat("CI.RRS..*").exact_station().as_deref(), Some("CI_RRS"));
        assert_eq!(pat("BK.*..HN?").exact_station(), None);
    }
}
