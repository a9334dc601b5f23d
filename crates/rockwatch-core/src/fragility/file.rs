//! One IM's fitted fragility as `rockwatch fragility` writes it into fragility.json
//! (`ims.<IM>`, docs/fragility.md §3) and `rockwatch hazard` reads it back
//! (`hazard::fragility_from_json`): one serde type for both, so the writer and the
//! reader cannot drift. The rest of fragility.json (ranking, surface, rock, runs, …) is a
//! report, written by the shell and read by nothing.
//!
//! Numbers that may be undefined are `Option` (JSON `null`). Every field but `median` and
//! `beta` may be missing when read: a fragility written by hand as
//! `{"ims": {"PGV": {"median": θ, "beta": β, "unit": "m/s"}}}` reads.

use serde::{Deserialize, Serialize};

/// `ims.<IM>` of fragility.json: the maximum-likelihood lognormal fit of one IM and what
/// qualifies it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ImFragilityJson {
    /// Median θ (the IM's unit, `unit`).
    pub median: f64,
    /// Logarithmic standard deviation β.
    pub beta: f64,
    /// 95 % bootstrap intervals of θ and β.
    #[serde(default)]
    pub ci95: Ci95Json,
    /// Runs fitted (neither flight nor failed) and overturned runs among them.
    #[serde(default)]
    pub n_runs: usize,
    #[serde(default)]
    pub n_overturned: usize,
    /// The IM's unit (`m/s2`, `m/s`, …; [`crate::ims::Im::unit`]); `im_unit` is read too.
    /// When missing, `hazard` takes the SI unit of PGA, PGV and SA(T).
    #[serde(default, alias = "im_unit")]
    pub unit: Option<String>,
    /// The IM's horizontal-component definition (`component`, `RotD50`, `RotD100`, `GM`).
    #[serde(default)]
    pub horizontal_definition: Option<String>,
    /// The likelihood fitted (`binomial over stripes`, `binomial over (record, scale)
    /// groups`).
    #[serde(default)]
    pub likelihood: Option<String>,
    /// The maximised log-likelihood (natural log).
    #[serde(default)]
    pub log_likelihood: Option<f64>,
    /// The bootstrap's replicates.
    #[serde(default)]
    pub bootstrap: BootstrapJson,
    /// The median of the fit that counts every flight run as an overturn (null without
    /// flight runs).
    #[serde(default)]
    pub median_if_flight_overturned: Option<f64>,
}

/// `ims.<IM>.ci95`: 95 % intervals `[lo, hi]`, null without replicates.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Ci95Json {
    #[serde(default)]
    pub median: Option<[f64; 2]>,
    #[serde(default)]
    pub beta: Option<[f64; 2]>,
}

/// `ims.<IM>.bootstrap`: the replicates asked for, those without a fit, and each fitted
/// replicate's `[θ, β]` in replicate order (missing in files written before they were stored).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct BootstrapJson {
    #[serde(default)]
    pub replicates: usize,
    #[serde(default)]
    pub failed: usize,
    #[serde(default)]
    pub median_beta: Vec<[f64; 2]>,
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    /// The entry's JSON is the one `rockwatch fragility` wrote before this type existed (its
    /// `json!` map: keys sorted, undefined numbers null), and reads back equal.
    #[test]
    fn an_entry_is_written_as_before_and_reads_back() {
        let entry = ImFragilityJson {
            median: 0.5,
            beta: 0.25,
            ci95: Ci95Json {
                median: Some([0.4, 0.6]),
                beta: None,
            },
            n_runs: 40,
            n_overturned: 12,
            unit: Some("m/s".into()),
            horizontal_definition: Some("component".into()),
            likelihood: Some("binomial over stripes".into()),
            log_likelihood: Some(f64::NAN),
            bootstrap: BootstrapJson {
                replicates: 3,
                failed: 1,
                median_beta: vec![[0.45, 0.2], [0.55, 0.3]],
            },
            median_if_flight_overturned: None,
        };
        let text = serde_json::to_value(&entry).unwrap().to_string();
        // The former writer's expression (crates/rockwatch/src/fragility/report.rs before
        // `ImFragilityJson`), with the same values.
        let pair = |v: Option<[f64; 2]>| v.map_or(serde_json::Value::Null, |[a, b]| json!([a, b]));
        let former = json!({
            "median": 0.5,
            "beta": 0.25,
            "ci95": {"median": pair(Some([0.4, 0.6])), "beta": pair(None)},
            "n_runs": 40_usize,
            "n_overturned": 12_usize,
            "unit": "m/s",
            "horizontal_definition": "component",
            "likelihood": "binomial over stripes",
            "log_likelihood": f64::NAN,
            "bootstrap": {"replicates": 3_usize, "failed": 1_usize, "median_beta": vec![(0.45, 0.2), (0.55, 0.3)]},
            "median_if_flight_overturned": None::<f64>,
        });
        assert_eq!(text, former.to_string());
        assert_eq!(
            text,
            r#"{"beta":0.25,"bootstrap":{"failed":1,"median_beta":[[0.45,0.2],[0.55,0.3]],"replicates":3},"ci95":{"beta":null,"median":[0.4,0.6]},"horizontal_definition":"component","likelihood":"binomial over stripes","log_likelihood":null,"median":0.5,"median_if_flight_overturned":null,"n_overturned":12,"n_runs":40,"unit":"m/s"}"#
        );
        let back: ImFragilityJson = serde_json::from_str(&text).unwrap();
        assert_eq!(back.log_likelihood, None);
        assert_eq!(
            back,
            ImFragilityJson {
                log_likelihood: None,
                ..entry
            }
        );
    }
}
