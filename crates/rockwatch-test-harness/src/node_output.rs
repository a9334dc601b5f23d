//! Reading what the node prints and serves: the counts of its closing summary, JSON lines,
//! the Prometheus text format of `/metrics`.

use std::collections::{BTreeMap, BTreeSet};

/// The number `label` is preceded by in the node's closing summary (`rockwatch: stopped:` or
/// `rockwatch: engine input:`) line that contains it.
pub fn count_before(stderr: &str, label: &str) -> u64 {
    let line = stderr
        .lines()
        .filter(|l| {
            l.starts_with("rockwatch: stopped:") || l.starts_with("rockwatch: engine input:")
        })
        .find(|l| l.contains(label))
        .unwrap_or_else(|| panic!("no summary with {label:?} in\n{stderr}"));
    let before = &line[..line.find(label).unwrap()];
    before
        .split(|c: char| !c.is_ascii_digit())
        .rfind(|s| !s.is_empty())
        .unwrap_or_else(|| panic!("no count before {label:?}: {line}"))
        .parse()
        .unwrap()
}

/// The JSON objects of the lines of `stdout` that start with `prefix`.
pub fn json_lines(stdout: &str, prefix: &str) -> Vec<serde_json::Value> {
    stdout
        .lines()
        .filter_map(|l| l.strip_prefix(prefix))
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("{e}: {l}")))
        .collect()
}

/// One metric sample of the Prometheus text format: name, labels, value.
pub type Sample = (String, BTreeMap<String, String>, f64);

/// Parses the Prometheus text exposition format (0.0.4): `# HELP`/`# TYPE` lines, then
/// `name{label="value",…} number` samples; a sample's family must have been typed first.
pub fn parse_prometheus(text: &str) -> Result<Vec<Sample>, String> {
    let mut typed = BTreeSet::new();
    let mut samples = Vec::new();
    for line in text.lines() {
        if let Some(rest) = line.strip_prefix("# TYPE ") {
            let (name, kind) = rest.split_once(' ').ok_or(line)?;
            if !["counter", "gauge"].contains(&kind) {
                return Err(format!("unknown type: {line}"));
            }
            typed.insert(name.to_string());
            continue;
        }
        if line.starts_with("# HELP ") || line.is_empty() {
            continue;
        }
        let (head, value) = line.rsplit_once(' ').ok_or(line)?;
        let value: f64 = value.parse().map_err(|_| format!("bad value: {line}"))?;
        let (name, labels) = match head.split_once('{') {
            None => (head.to_string(), BTreeMap::new()),
            Some((name, rest)) => {
                let body = rest.strip_suffix('}').ok_or(line)?;
                let mut labels = BTreeMap::new();
                for pair in body.split("\",").filter(|p| !p.is_empty()) {
                    let (k, v) = pair.split_once("=\"").ok_or(line)?;
                    labels.insert(k.to_string(), v.trim_end_matches('"').to_string());
                }
                (name.to_string(), labels)
            }
        };
        if !typed.contains(&name) {
            return Err(format!("sample before its # TYPE: {line}"));
        }
        samples.push((name, labels, value));
    }
    Ok(samples)
}

/// The value of the sample `name` labelled `station="<station>"`, if any.
pub fn station_value(samples: &[Sample], name: &str, station: &str) -> Option<f64> {
    samples
        .iter()
        .find(|(n, l, _)| n == name && l.get("station").map(String::as_str) == Some(station))
        .map(|s| s.2)
}

/// The value of the sample `name` whose labels include every pair of `labels`, if any.
pub fn labelled_value(samples: &[Sample], name: &str, labels: &[(&str, &str)]) -> Option<f64> {
    samples
        .iter()
        .find(|(n, l, _)| {
            n == name
                && labels
                    .iter()
                    .all(|(k, v)| l.get(*k).map(String::as_str) == Some(*v))
        })
        .map(|s| s.2)
}
