//! FDSN StationXML 1.0–1.2 → channel epochs (roxmltree; elements are matched by namespace URI
//! and local name, never by prefix). Tolerates what real web services write: several `<Type>`
//! elements, foreign-namespace elements and attributes, XML comments inside text, blanks
//! around numbers, exponent or leading-dot numbers, ISO-8859-1 documents, missing optional
//! fields (left `None`). Refused: a document that is not XML, whose root is not
//! `FDSNStationXML` in the FDSN namespace, or a `<Channel>` without its `code`.

use super::{ChannelEpoch, InventoryError, Sensitivity};
use crate::utc::parse_utc_ns;
use roxmltree::{Document, Node, ParsingOptions};

/// The FDSN StationXML namespace (all schema versions 1.x).
const FDSN_NS: &str = "http://www.fdsn.org/xml/station/1";

/// Largest document accepted (bytes): a whole network at level=response is a few tens of
/// MiB; anything far larger is a mistake, and parsing work stays bounded.
const MAX_DOCUMENT_BYTES: usize = 512 << 20;

pub(super) fn parse(source: &str, bytes: &[u8]) -> Result<Vec<ChannelEpoch>, InventoryError> {
    let fail = |problem: String| InventoryError {
        document: source.to_string(),
        problem,
    };
    if bytes.len() > MAX_DOCUMENT_BYTES {
        return Err(fail(format!(
            "{} bytes is more than the {MAX_DOCUMENT_BYTES} accepted",
            bytes.len()
        )));
    }
    let text = decode(bytes).map_err(fail)?;
    let options = ParsingOptions {
        allow_dtd: false,
        ..ParsingOptions::default()
    };
    let doc = Document::parse_with_options(&text, options)
        .map_err(|e| fail(format!("not well-formed XML: {e}")))?;
    let root = doc.root_element();
    if root.tag_name().name() != "FDSNStationXML" || root.tag_name().namespace() != Some(FDSN_NS) {
        return Err(fail(format!(
            "not FDSN StationXML: root element {:?} in namespace {:?} (expected FDSNStationXML in {FDSN_NS})",
            root.tag_name().name(),
            root.tag_name().namespace().unwrap_or("none")
        )));
    }
    let mut channels = Vec::new();
    for network in children(root, "Network") {
        let net = attribute(network, "code");
        for station in children(network, "Station") {
            let sta = attribute(station, "code");
            for channel in children(station, "Channel") {
                let Some(cha) = channel.attribute("code") else {
                    return Err(fail(format!(
                        "a Channel of station {net}.{sta} has no code (line {})",
                        doc.text_pos_at(channel.range().start).row
                    )));
                };
                channels.push(channel_epoch(source, &net, &sta, cha.trim(), channel));
            }
        }
    }
    Ok(channels)
}

/// The document as text: UTF-8, or ISO-8859-1 (Latin-1, one byte per code point) when the XML
/// declaration says so.
fn decode(bytes: &[u8]) -> Result<String, String> {
    let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    let head = String::from_utf8_lossy(&bytes[..bytes.len().min(200)]).to_ascii_lowercase();
    let declared = head
        .strip_prefix("<?xml")
        .and_then(|d| d.split("?>").next())
        .and_then(|d| d.split("encoding").nth(1))
        .map(|e| e.trim_start_matches([' ', '=', '"', '\'']).to_string())
        .unwrap_or_default();
    if declared.starts_with("iso-8859-1") || declared.starts_with("latin1") {
        return Ok(bytes.iter().map(|&b| char::from(b)).collect());
    }
    String::from_utf8(bytes.to_vec())
        .map_err(|e| format!("not UTF-8 (and no ISO-8859-1 declaration): {e}"))
}

fn channel_epoch(source: &str, net: &str, sta: &str, cha: &str, node: Node) -> ChannelEpoch {
    let number = |name: &'static str| child(node, name).and_then(|n| text(n).parse::<f64>().ok());
    let sensitivity = child(node, "Response")
        .and_then(|r| child(r, "InstrumentSensitivity"))
        .and_then(|s| {
            let value = text(child(s, "Value")?).parse::<f64>().ok()?;
            let units =
                |name: &'static str| child(s, name).and_then(|u| child(u, "Name")).map(text);
            Some(Sensitivity {
                value,
                frequency_hz: child(s, "Frequency").and_then(|f| text(f).parse().ok()),
                input_units: units("InputUnits")?,
                output_units: units("OutputUnits"),
            })
        });
    ChannelEpoch {
        source: source.to_string(),
        network: net.to_string(),
        station: sta.to_string(),
        location: attribute(node, "locationCode"),
        channel: cha.to_string(),
        start_ns: node.attribute("startDate").and_then(parse_utc_ns),
        end_ns: node.attribute("endDate").and_then(parse_utc_ns),
        sample_rate_hz: number("SampleRate"),
        azimuth_deg: number("Azimuth"),
        dip_deg: number("Dip"),
        sensitivity,
    }
}

/// The FDSN-namespace children of `node` named `name`.
fn children<'a, 'i>(node: Node<'a, 'i>, name: &'static str) -> impl Iterator<Item = Node<'a, 'i>> {
    node.children()
        .filter(move |c| c.tag_name().name() == name && c.tag_name().namespace() == Some(FDSN_NS))
}

fn child<'a, 'i>(node: Node<'a, 'i>, name: &'static str) -> Option<Node<'a, 'i>> {
    children(node, name).next()
}

/// An attribute without namespace, trimmed; empty if absent.
fn attribute(node: Node, name: &str) -> String {
    node.attribute(name).unwrap_or("").trim().to_string()
}

/// The element's text, comments skipped (`<Name>COUNTS<!-- x --></Name>` is `COUNTS`),
/// trimmed.
fn text(node: Node) -> String {
    let joined: String = node
        .children()
        .filter(Node::is_text)
        .filter_map(|t| t.text())
        .collect();
    joined.trim().to_string()
}
