//! The server's station list (`INFO STATIONS`) and the expansion of wildcard stream patterns
//! into concrete stations, so that every station — also one selected by `BK.*..HN?` — is
//! requested with its own `STATION` command and can resume from its own sequence number.
//!
//! Answers: SeedLink 3 servers (ringserver, SeisComP seedlink, seedlink-rs-server) send XML,
//! `<seedlink …><station name="STA" network="NET" …/>…</seedlink>`; SeedLink 4 servers may send
//! the same XML or JSON, `{"station": [{"id": "NET_STA", …}, …]}` (ringserver 4), also accepted
//! with `"network"` and `"station"`/`"name"` keys. Both are read tolerantly; anything else is
//! an [`InfoError`].

use std::collections::BTreeSet;

use super::select::StreamPattern;

/// Most stations taken from one answer (a bound on work and memory).
pub const MAX_STATIONS: usize = 100_000;

/// Why an INFO STATIONS answer could not be read.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("INFO STATIONS answer: {0}")]
pub struct InfoError(pub String);

/// The (network, station) codes of an `INFO STATIONS` answer, sorted, without duplicates.
/// `text` is the concatenated payload of the INFO packets (NUL padding allowed).
pub fn parse_stations(text: &str) -> Result<Vec<(String, String)>, InfoError> {
    let text = text.trim_matches(|c: char| c == '\0' || c.is_whitespace());
    let mut out = BTreeSet::new();
    let mut add = |net: &str, sta: &str| -> Result<(), InfoError> {
        let ok =
            |s: &str| !s.is_empty() && s.len() <= 8 && s.chars().all(|c| c.is_ascii_alphanumeric());
        if ok(net) && ok(sta) {
            if out.len() >= MAX_STATIONS {
                return Err(InfoError(format!("more than {MAX_STATIONS} stations")));
            }
            out.insert((net.to_string(), sta.to_string()));
        }
        Ok(())
    };
    if text.starts_with('{') {
        let v: serde_json::Value =
            serde_json::from_str(text).map_err(|e| InfoError(format!("not JSON: {e}")))?;
        let list = v
            .get("station")
            .or_else(|| v.get("stations"))
            .and_then(serde_json::Value::as_array)
            .ok_or_else(|| InfoError("JSON without a \"station\" list".into()))?;
        for s in list {
            let id = s.get("id").and_then(serde_json::Value::as_str);
            let net = s.get("network").and_then(serde_json::Value::as_str);
            let sta = s
                .get("station")
                .or_else(|| s.get("name"))
                .and_then(serde_json::Value::as_str);
            match (id.and_then(|i| i.split_once('_')), net, sta) {
                (Some((n, st)), _, _) | (None, Some(n), Some(st)) => add(n, st)?,
                _ => {}
            }
        }
    } else {
        let doc =
            roxmltree::Document::parse(text).map_err(|e| InfoError(format!("not XML: {e}")))?;
        for node in doc.descendants().filter(|n| n.has_tag_name("station")) {
            if let (Some(net), Some(sta)) = (node.attribute("network"), node.attribute("name")) {
                add(net, sta)?;
            }
        }
    }
    Ok(out.into_iter().collect())
}

/// Whether a pattern names its station exactly (no wildcard in network or station).
#[must_use]
pub fn is_concrete(p: &StreamPattern) -> bool {
    p.exact_station().is_some()
}

/// The patterns with every wildcard station replaced by one pattern per matching station of
/// `stations` (same location and channel patterns). Concrete patterns are kept as they are; a
/// wildcard matching no station is dropped (it is reported by the caller).
#[must_use]
pub fn expand(patterns: &[StreamPattern], stations: &[(String, String)]) -> Vec<StreamPattern> {
    let mut out: Vec<StreamPattern> = Vec::new();
    for p in patterns {
        if is_concrete(p) {
            if !out.contains(p) {
                out.push(p.clone());
            }
            continue;
        }
        for (net, sta) in stations {
            if p.matches_station(net, sta) {
                let concrete = StreamPattern {
                    network: net.clone(),
                    station: sta.clone(),
                    location: p.location.clone(),
                    channel: p.channel.clone(),
                };
                if !out.contains(&concrete) {
                    out.push(concrete);
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn xml_and_json_station_lists_are_read() {
        // seedlink-rs-server / ringserver v3 form (NUL-padded 512-byte INFO packets).
        let xml = "<?xml version=\"1.0\"?>\n<seedlink software=\"x\">\n  <station name=\"CMB\" network=\"BK\" description=\"\" begin_seq=\"000001\" end_seq=\"000010\"/>\n  <station name=\"RRS\" network=\"CI\"/>\n  <station name=\"CMB\" network=\"BK\"/>\n</seedlink>\n\0\0\0";
        assert_eq!(
            parse_stations(xml).unwrap(),
            vec![("BK".into(), "CMB".into()), ("CI".into(), "RRS".into())]
        );
        let json = r#"{"software":"ringserver","station":[{"id":"BK_CMB","start_seq":1},{"network":"CI","station":"RRS"},{"id":"bad id with spaces_X"}]}"#;
        assert_eq!(
            parse_stations(json).unwrap(),
            vec![("BK".into(), "CMB".into()), ("CI".into(), "RRS".into())]
        );
        assert!(parse_stations("ERROR").is_err());
        assert!(parse_stations("{\"x\":1}").is_err());
    }

    #[test]
    fn wildcards_expand_to_the_matching_stations() {
        let p = |s: &str| StreamPattern::parse(s).unwrap();
        let stations = vec![
            ("BK".to_string(), "CMB".to_string()),
            ("BK".to_string(), "PKD".to_string()),
            ("CI".to_string(), "RRS".to_string()),
        ];
        let out = expand(
            &[p("CI.RRS..HN?"), p("BK.*..HN?"), p("XX.*..HN?")],
            &stations,
        );
        let ids: Vec<String> = out
            .iter()
            .map(|q| format!("{}.{}.{}.{}", q.network, q.station, q.location, q.channel))
            .collect();
        assert_eq!(ids, ["CI.RRS..HN?", "BK.CMB..HN?", "BK.PKD..HN?"]);
        // A wildcard that also matches an explicit pattern's station does not repeat it.
        let out = expand(&[p("CI.RRS..HN?"), p("*.R*..HN?")], &stations);
        assert_eq!(out.len(), 1);
    }
}
