//! The server's station list (`INFO STATIONS`) and the expansion of wildcard stream patterns
//! into concrete stations, so that every station — also one selected by `BK.*..HN?` — is
//! requested with its own `STATION` command and can resume from its own sequence number.
//!
//! Answers: SeedLink 3 servers (ringserver, SeisComP seedlink, seedlink-rs-server) send XML,
//! `<seedlink …><station name="STA" network="NET" …/>…</seedlink>`; SeedLink 4 servers may send
//! the same XML or JSON, `{"station": [{"id": "NET_STA", …}, …]}` (ringserver 4), also accepted
//! with `"network"` and `"station"`/`"name"` keys. Both are read tolerantly; anything else is
//! an [`InfoError`].
//!
//! `INFO STREAMS` ([`parse_streams`]) gives each stream of the ring with the time span of its
//! data: ringserver's v3 XML `<station name= network=><stream location= seedname=
//! begin_time= end_time=/></station>`, its v4 JSON `{"station": [{"id": "NET_STA", "stream":
//! [{"id": "LOC_B_S_SS", "start_time": …, "end_time": …}]}]}` (SeisComP writes times as
//! `YYYY/MM/DD hh:mm:ss.ffff`, ringserver as ISO 8601; both are read). A client without a
//! resume point starts a backfill window before a stream's `end_time`.

use std::collections::BTreeSet;

use super::select::StreamPattern;

/// Most stations taken from one answer (a bound on work and memory).
pub const MAX_STATIONS: usize = 100_000;

/// Most streams taken from one `INFO STREAMS` answer (a bound on work and memory).
pub const MAX_STREAMS: usize = 1_000_000;

/// Why an INFO answer could not be read.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("INFO {level} answer: {problem}")]
pub struct InfoError {
    /// `STATIONS` or `STREAMS`.
    pub level: &'static str,
    pub problem: String,
}

fn stations_error(problem: impl Into<String>) -> InfoError {
    InfoError {
        level: "STATIONS",
        problem: problem.into(),
    }
}

fn streams_error(problem: impl Into<String>) -> InfoError {
    InfoError {
        level: "STREAMS",
        problem: problem.into(),
    }
}

/// A network or station code as SeedLink carries it: 1 to 8 letters or digits.
fn is_code(s: &str) -> bool {
    !s.is_empty() && s.len() <= 8 && s.chars().all(|c| c.is_ascii_alphanumeric())
}

/// The payload of INFO packets without its NUL padding and surrounding blanks.
fn info_text(text: &str) -> &str {
    text.trim_matches(|c: char| c == '\0' || c.is_whitespace())
}

/// The text an INFO packet carries. SeedLink 3 servers wrap it in a MiniSEED 2 record
/// (ringserver and SeisComP: sequence digits, quality `D`, station `INFO`, channel `INF` or
/// `ERR`, blockette 1000 with text encoding; the text at the header's data offset, as many
/// bytes as its sample count — at most 456 per record); some (seedlink-rs-server) send the
/// bare text, NUL-padded. A payload that is not such a record is returned whole.
#[must_use]
pub fn info_packet_text(payload: &[u8]) -> &[u8] {
    let be16 = |at: usize| -> Option<usize> {
        Some(usize::from(u16::from_be_bytes([
            *payload.get(at)?,
            *payload.get(at + 1)?,
        ])))
    };
    let is_record = payload.len() >= 56
        && payload[..6].iter().all(u8::is_ascii_digit)
        && matches!(payload[6], b'D' | b'R' | b'Q' | b'M')
        && &payload[8..12] == b"INFO";
    if !is_record {
        return payload;
    }
    match (be16(44), be16(30)) {
        (Some(offset), Some(n)) if offset >= 48 && offset + n <= payload.len() => {
            &payload[offset..offset + n]
        }
        _ => payload,
    }
}

/// One stream of an `INFO STREAMS` answer and the time span of its data in the ring.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct StreamSpan {
    pub network: String,
    pub station: String,
    /// Location code (may be empty).
    pub location: String,
    /// SEED channel code (`HNZ`; a v4 `H_N_Z` is collapsed to it).
    pub channel: String,
    /// Start of the oldest data of the stream in the ring (ns since the epoch, UTC), if the
    /// server says (ringserver does; seedlink-rs-server gives sequence numbers only).
    pub begin_ns: Option<i64>,
    /// End of the newest data of the stream in the ring (ns since the epoch, UTC), if said.
    pub end_ns: Option<i64>,
}

/// A time of an INFO answer: ISO 8601 (`2004-03-01T12:00:00.000000Z`, ringserver) or
/// `YYYY/MM/DD hh:mm:ss.ffff` (SeisComP). `None` when absent or unreadable; the server's
/// sentinel for "none" (a year before 1900 or after 2100) counts as absent.
fn info_time_ns(text: Option<&str>) -> Option<i64> {
    let text = text?.trim();
    let iso = match text.get(..10) {
        Some(date) if date.contains('/') => format!("{}{}", date.replace('/', "-"), &text[10..]),
        _ => text.to_string(),
    };
    let t = crate::utc::parse_utc_ns(&iso)?;
    // 1900-01-01 .. 2100-01-01, the span the MiniSEED reader accepts.
    (-2_208_988_800_000_000_000..4_102_444_800_000_000_000)
        .contains(&t)
        .then(|| i64::try_from(t).ok())
        .flatten()
}

/// The streams of an `INFO STREAMS` answer (XML or JSON, see the module doc), in the order
/// given. Streams whose codes are not SeedLink codes are skipped; a stream without readable
/// times is kept with `None` (the caller decides). Anything that is not such an answer is an
/// [`InfoError`].
pub fn parse_streams(text: &str) -> Result<Vec<StreamSpan>, InfoError> {
    let text = info_text(text);
    let mut out = Vec::new();
    let mut add =
        |net: &str, sta: &str, loc: &str, cha: &str, begin: Option<&str>, end: Option<&str>| {
            let loc_ok = loc.len() <= 2 && loc.chars().all(|c| c.is_ascii_alphanumeric());
            let cha_ok = cha.len() == 3 && cha.chars().all(|c| c.is_ascii_alphanumeric());
            if is_code(net) && is_code(sta) && loc_ok && cha_ok {
                if out.len() >= MAX_STREAMS {
                    return Err(streams_error(format!("more than {MAX_STREAMS} streams")));
                }
                out.push(StreamSpan {
                    network: net.to_string(),
                    station: sta.to_string(),
                    location: loc.to_string(),
                    channel: cha.to_string(),
                    begin_ns: info_time_ns(begin),
                    end_ns: info_time_ns(end),
                });
            }
            Ok(())
        };
    if text.starts_with('{') {
        let v: serde_json::Value =
            serde_json::from_str(text).map_err(|e| streams_error(format!("not JSON: {e}")))?;
        let list = v
            .get("station")
            .and_then(serde_json::Value::as_array)
            .ok_or_else(|| streams_error("JSON without a \"station\" list"))?;
        let str_of = |o: &serde_json::Value, k: &str| -> Option<String> {
            o.get(k)
                .and_then(serde_json::Value::as_str)
                .map(str::to_string)
        };
        for s in list {
            let Some((net, sta)) = str_of(s, "id").and_then(|id| {
                id.split_once('_')
                    .map(|(n, st)| (n.to_string(), st.to_string()))
            }) else {
                continue;
            };
            for st in s
                .get("stream")
                .and_then(serde_json::Value::as_array)
                .into_iter()
                .flatten()
            {
                // `LOC_B_S_SS` (FDSN source id without network and station) or `LOC_CHA`.
                let Some(id) = str_of(st, "id") else { continue };
                let Some((loc, rest)) = id.split_once('_') else {
                    continue;
                };
                let cha: String = rest.split('_').collect();
                let (begin, end) = (str_of(st, "start_time"), str_of(st, "end_time"));
                add(&net, &sta, loc, &cha, begin.as_deref(), end.as_deref())?;
            }
        }
    } else {
        let doc =
            roxmltree::Document::parse(text).map_err(|e| streams_error(format!("not XML: {e}")))?;
        if !doc.root_element().has_tag_name("seedlink") {
            return Err(streams_error("XML without a <seedlink> root"));
        }
        for station in doc.descendants().filter(|n| n.has_tag_name("station")) {
            let (Some(net), Some(sta)) = (station.attribute("network"), station.attribute("name"))
            else {
                continue;
            };
            for st in station.children().filter(|n| n.has_tag_name("stream")) {
                let (Some(loc), Some(cha)) = (st.attribute("location"), st.attribute("seedname"))
                else {
                    continue;
                };
                add(
                    net,
                    sta,
                    loc,
                    cha,
                    st.attribute("begin_time"),
                    st.attribute("end_time"),
                )?;
            }
        }
    }
    Ok(out)
}

/// The (network, station) codes of an `INFO STATIONS` answer, sorted, without duplicates.
/// `text` is the concatenated payload of the INFO packets (NUL padding allowed).
pub fn parse_stations(text: &str) -> Result<Vec<(String, String)>, InfoError> {
    let text = info_text(text);
    let mut out = BTreeSet::new();
    let mut add = |net: &str, sta: &str| -> Result<(), InfoError> {
        if is_code(net) && is_code(sta) {
            if out.len() >= MAX_STATIONS {
                return Err(stations_error(format!("more than {MAX_STATIONS} stations")));
            }
            out.insert((net.to_string(), sta.to_string()));
        }
        Ok(())
    };
    if text.starts_with('{') {
        let v: serde_json::Value =
            serde_json::from_str(text).map_err(|e| stations_error(format!("not JSON: {e}")))?;
        let list = v
            .get("station")
            .or_else(|| v.get("stations"))
            .and_then(serde_json::Value::as_array)
            .ok_or_else(|| stations_error("JSON without a \"station\" list"))?;
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
        let doc = roxmltree::Document::parse(text)
            .map_err(|e| stations_error(format!("not XML: {e}")))?;
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
    fn stream_spans_are_read_from_ringserver_xml_and_json() {
        // ringserver 4's v3 answer (its JSON converted to XML, infoxml.c), NUL-padded.
        let xml = "<?xml version=\"1.0\"?>\n<seedlink software=\"ringserver/4.5.3\" started=\"2026-11-29T10:00:00Z\"><station name=\"STN\" network=\"XX\" description=\"\" begin_seq=\"1\" end_seq=\"104\" stream_check=\"enabled\"><stream location=\"\" seedname=\"HN1\" type=\"D\" begin_time=\"2002-07-21T05:46:55.794233Z\" end_time=\"2002-07-21T05:47:30.000000Z\"/><stream location=\"00\" seedname=\"HN2\" type=\"D\" begin_time=\"2002/07/21 05:46:55.7942\" end_time=\"2002/07/21 05:47:31.5000\"/><stream location=\"\" seedname=\"HN3\" type=\"D\"/></station></seedlink>\0\0";
        let got = parse_streams(xml).unwrap();
        assert_eq!(got.len(), 3);
        assert_eq!(
            (
                got[0].network.as_str(),
                got[0].station.as_str(),
                got[0].location.as_str(),
                got[0].channel.as_str()
            ),
            ("XX", "STN", "", "HN1")
        );
        let t = |s: &str| i64::try_from(crate::utc::parse_utc_ns(s).unwrap()).unwrap();
        assert_eq!(got[0].end_ns, Some(t("2002-07-21T05:47:30Z")));
        assert_eq!(got[0].begin_ns, Some(t("2002-07-21T05:46:55.794233Z")));
        // SeisComP's form of a time.
        assert_eq!(got[1].location, "00");
        assert_eq!(got[1].end_ns, Some(t("2002-07-21T05:47:31.5Z")));
        // seedlink-rs-server gives sequence numbers only: the stream is kept without times.
        assert_eq!((got[2].begin_ns, got[2].end_ns), (None, None));
        // ringserver 4's v4 JSON: `LOC_B_S_SS` stream ids.
        let json = r#"{"software":"ringserver","station":[{"id":"XX_STN","stream":[{"id":"_H_N_1","format":"2","subformat":"D","start_time":"2002-07-21T05:46:55.794233Z","end_time":"2002-07-21T05:47:30Z"},{"id":"00_HNZ","end_time":"1000-01-01T00:00:00Z"}]},{"id":"bad"}]}"#;
        let got = parse_streams(json).unwrap();
        assert_eq!(got.len(), 2);
        assert_eq!(got[0].channel, "HN1");
        assert_eq!(got[0].end_ns, Some(t("2002-07-21T05:47:30Z")));
        // A time outside 1900..2100 is no time.
        assert_eq!((got[1].location.as_str(), got[1].end_ns), ("00", None));
        assert!(parse_streams("ERROR").is_err());
        assert!(parse_streams("{\"x\":1}")
            .unwrap_err()
            .to_string()
            .starts_with("INFO STREAMS answer"));
        assert!(parse_streams("<html/>").is_err());
    }

    #[test]
    fn info_text_is_taken_out_of_ringservers_miniseed_records() {
        // ringserver's HandleInfo_v3: a 48-byte fixed header, blockette 1000 at 48, the XML
        // from byte 56, its length as the sample count, NUL padding to 512 bytes.
        let xml = b"<seedlink started=\"2026-11-29T10:00:00Z\"/>";
        let mut record = vec![0u8; 512];
        record[..6].copy_from_slice(b"000001");
        record[6] = b'D';
        record[7] = b' ';
        record[8..13].copy_from_slice(b"INFO ");
        record[15..18].copy_from_slice(b"INF");
        record[18..20].copy_from_slice(b"XX");
        record[30..32].copy_from_slice(&(xml.len() as u16).to_be_bytes());
        record[44..46].copy_from_slice(&56u16.to_be_bytes());
        record[46..48].copy_from_slice(&48u16.to_be_bytes());
        record[56..56 + xml.len()].copy_from_slice(xml);
        assert_eq!(info_packet_text(&record), xml);
        // Bare text (seedlink-rs-server) is returned as it is.
        let mut bare = b"<?xml version=\"1.0\"?><seedlink/>".to_vec();
        bare.resize(512, 0);
        assert_eq!(info_packet_text(&bare), &bare[..]);
        // A header whose sample count runs past the record is not trusted.
        record[30..32].copy_from_slice(&500u16.to_be_bytes());
        assert_eq!(info_packet_text(&record).len(), 512);
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
