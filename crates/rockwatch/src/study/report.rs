//! Writers of the study's tables: `results.csv`, `efficiency.csv`/`.md`, `sufficiency.csv`,
//! `vector.csv`, `fragility.csv`, `fragility_fits.csv`, `fragility.json` and `summary.json`.
//!
//! Every table is first built as a `String` by a pure function (testable without files);
//! [`write_tables`] writes them. Numbers are printed in Rust's shortest round-trip format,
//! so a file is bit-for-bit reproducible; an undefined value is an empty CSV field, `—` in
//! Markdown and `null` in JSON.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use serde::ser::{SerializeMap, Serializer};

use rockwatch_core::ims::{Im, PeriodRange, STUDY_IMS};
use rockwatch_core::study::fragility::{LognormalFragility, Z_95};
use rockwatch_core::study::{BlockAnalysis, StudyAnalysis, StudyConfig, StudyData};

/// A file of the study could not be written.
#[derive(Debug, thiserror::Error)]
#[error("cannot write {path}: {source}")]
pub struct ReportError {
    /// The file.
    pub path: PathBuf,
    /// The I/O error.
    pub source: std::io::Error,
}

/// A CSV number: shortest round-trip decimal (Rust's `Debug` form, with an exponent below
/// 1e−5 and from 1e16 on), empty if not finite.
fn num(v: f64) -> String {
    if v.is_finite() {
        format!("{v:?}")
    } else {
        String::new()
    }
}

fn opt(v: Option<f64>) -> String {
    v.map_or_else(String::new, num)
}

/// Markdown cell with 4 decimals (like the seed's tables), `—` if undefined.
fn md4(v: f64) -> String {
    if v.is_finite() {
        format!("{v:.4}")
    } else {
        "—".to_string()
    }
}

/// Finite value or `None` (JSON `null`).
fn finite(v: f64) -> Option<f64> {
    v.is_finite().then_some(v)
}

/// The seed's label of an IM in tables and plots: `PHA`, `SI (2.5 to 3.0 s)`, `PGV/PGA`, …
#[must_use]
pub fn display_name(im: Im) -> String {
    let range = |kind: &str, r: PeriodRange| {
        let label = r.label();
        let (t1, t2) = label.split_once('-').unwrap_or((&label, ""));
        format!("{kind} ({t1} to {t2} s)")
    };
    match im {
        Im::Pga => "PHA".into(),
        Im::Pgv => "PHV".into(),
        Im::Pgd => "PHD".into(),
        Im::Tp => "Tp".into(),
        Im::D5_95 => "D5-95".into(),
        Im::ARms => "a_rms".into(),
        Im::Ic => "Ic".into(),
        Im::Arias => "Arias".into(),
        Im::Si(r) => range("SI", r),
        Im::Asi(r) => range("ASI", r),
        Im::Vsi(r) => range("VSI", r),
        other => other.to_string(),
    }
}

/// `results.csv`: one row per pulse × block with the pulse parameters, the response, the
/// category (used or why excluded) and the 37 IMs.
#[must_use]
pub fn results_csv(config: &StudyConfig, data: &StudyData, analysis: &StudyAnalysis) -> String {
    let mut s = String::with_capacity(data.cases.len() * config.blocks.len() * 900);
    s.push_str(
        "pulse_id,mw,r_km,tp_s,vp_mps,gamma,nu_rad,amplitude_mps,duration_s,block,dm,status,\
         overturned,exceeded_alpha,modes,max_abs_slide_m,max_abs_theta_rad,\
         max_abs_theta_over_alpha,category",
    );
    for im in STUDY_IMS {
        s.push(',');
        s.push_str(&im.study_name());
    }
    s.push('\n');
    for (i, case) in data.cases.iter().enumerate() {
        for (b, block) in config.blocks.iter().enumerate() {
            let r = &data.responses[i][b];
            let category = analysis
                .blocks
                .get(b)
                .map_or("", |a| a.categories[i].as_str());
            let p = &case.parameters;
            let _ = write!(
                s,
                "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
                case.id,
                num(case.mw),
                num(case.r_km),
                num(p.tp_s),
                num(p.vp_mps),
                num(p.gamma),
                num(p.nu_rad),
                num(case.amplitude_mps),
                num(case.duration_s),
                block.name,
                block.dm.as_str(),
                r.status.as_str(),
                r.status == rockwatch_core::study::ResponseStatus::Overturned,
                r.exceeded_alpha,
                r.modes_label(),
                num(r.max_abs_slide_m),
                num(r.max_abs_theta_rad),
                num(r.max_abs_theta_rad / block.params.alpha_rad),
                category
            );
            for v in case.ims {
                s.push(',');
                s.push_str(&num(v));
            }
            s.push('\n');
        }
    }
    s
}

/// `efficiency.csv`: per block, the IMs sorted by overall linear R² with the linear and
/// log–log fits, overall and per pair.
#[must_use]
pub fn efficiency_csv(data: &StudyData, analysis: &StudyAnalysis) -> String {
    let mut s = String::from(
        "block,dm,rank,im,unit,n,r2,slope,intercept,n_log,r2_log,slope_log,intercept_log",
    );
    for p in &data.pairs {
        let _ = write!(s, ",r2_{}", p.label());
    }
    for p in &data.pairs {
        let _ = write!(s, ",r2_log_{}", p.label());
    }
    s.push('\n');
    for block in &analysis.blocks {
        for (rank, sc) in block.ranking.iter().enumerate() {
            let lin = sc.linear;
            let log = sc.log;
            let _ = write!(
                s,
                "{},{},{},{},{},{},{},{},{},{},{},{},{}",
                block.name,
                block.dm.as_str(),
                rank + 1,
                sc.name(),
                sc.unit(),
                lin.map_or(0, |f| f.n),
                opt(lin.map(|f| f.r2)),
                opt(lin.map(|f| f.slope)),
                opt(lin.map(|f| f.intercept)),
                log.map_or(0, |f| f.n),
                opt(log.map(|f| f.r2)),
                opt(log.map(|f| f.slope)),
                opt(log.map(|f| f.intercept)),
            );
            for v in sc.r2_by_pair.iter().chain(&sc.r2_log_by_pair) {
                s.push(',');
                s.push_str(&opt(*v));
            }
            s.push('\n');
        }
    }
    s
}

/// `sufficiency.csv`: spread of the per-pair R² (the seed's criterion) and the Luco–Cornell
/// p-values of the residuals on Mw and R (log–log and linear), IMs in ranking order.
#[must_use]
pub fn sufficiency_csv(analysis: &StudyAnalysis) -> String {
    let mut s = String::from(
        "block,im,r2,r2_pair_sd,r2_pair_range,n_log,p_mw_log,p_r_log,n,p_mw_linear,p_r_linear\n",
    );
    for block in &analysis.blocks {
        for sc in &block.ranking {
            let _ = writeln!(
                s,
                "{},{},{},{},{},{},{},{},{},{},{}",
                block.name,
                sc.name(),
                num(sc.r2()),
                num(sc.r2_pair_sd),
                num(sc.r2_pair_range),
                sc.log.map_or(0, |f| f.n),
                num(sc.p_mw_log),
                num(sc.p_r_log),
                sc.linear.map_or(0, |f| f.n),
                num(sc.p_mw_linear),
                num(sc.p_r_linear),
            );
        }
    }
    s
}

/// `vector.csv`: the best two-IM regressions per block.
#[must_use]
pub fn vector_csv(analysis: &StudyAnalysis) -> String {
    let mut s = String::from(
        "block,rank,im1,im2,n,r2,adjusted_r2,best_scalar_r2,gain_r2,b0,b1,b2,\
         n_log,r2_log,adjusted_r2_log,best_scalar_r2_log,gain_r2_log\n",
    );
    for block in &analysis.blocks {
        for (rank, v) in block.vector.iter().enumerate() {
            let lin = v.linear.as_ref();
            let log = v.log.as_ref();
            let coef = |k: usize| opt(lin.and_then(|f| f.coefficients.get(k).copied()));
            let r2 = lin.map_or(f64::NAN, |f| f.r2);
            let r2_log = log.map_or(f64::NAN, |f| f.r2);
            let _ = writeln!(
                s,
                "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
                block.name,
                rank + 1,
                STUDY_IMS[v.ims[0]].study_name(),
                STUDY_IMS[v.ims[1]].study_name(),
                lin.map_or(0, |f| f.n),
                num(r2),
                opt(lin.map(|f| f.adjusted_r2)),
                num(v.best_scalar_r2),
                num(r2 - v.best_scalar_r2),
                coef(0),
                coef(1),
                coef(2),
                log.map_or(0, |f| f.n),
                num(r2_log),
                opt(log.map(|f| f.adjusted_r2)),
                num(v.best_scalar_r2_log),
                num(r2_log - v.best_scalar_r2_log),
            );
        }
    }
    s
}

/// Log-spaced IM grid over the positive IM values of the fragility sample (60 points).
fn fragility_grid(data: &StudyData, curve: &LognormalFragility) -> Vec<f64> {
    let j = STUDY_IMS.iter().position(|im| *im == curve.im).unwrap_or(0);
    let (lo, hi) = data
        .cases
        .iter()
        .map(|c| c.ims[j])
        .filter(|v| *v > 0.0 && v.is_finite())
        .fold((f64::INFINITY, 0.0_f64), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
    if !(lo.is_finite() && hi > lo) {
        return Vec::new();
    }
    let n = 60;
    (0..n)
        .map(|k| (lo.ln() + (hi.ln() - lo.ln()) * k as f64 / (n - 1) as f64).exp())
        .collect()
}

/// `fragility.csv`: the selected curve of each block on a log-spaced IM grid with its
/// pointwise 95 % band.
#[must_use]
pub fn fragility_csv(data: &StudyData, analysis: &StudyAnalysis) -> String {
    let mut s = String::from("block,im,unit,im_value,probability,lower_95,upper_95\n");
    for block in &analysis.blocks {
        if let Some(curve) = &block.fragility.selected {
            for x in fragility_grid(data, curve) {
                let (lo, hi) = curve.band(x, Z_95);
                let _ = writeln!(
                    s,
                    "{},{},{},{},{},{},{}",
                    block.name,
                    curve.im.study_name(),
                    curve.im_unit,
                    num(x),
                    num(curve.probability(x)),
                    num(lo),
                    num(hi)
                );
            }
        }
    }
    s
}

/// `fragility_fits.csv`: the lognormal fit of every IM for every block.
#[must_use]
pub fn fragility_fits_csv(analysis: &StudyAnalysis) -> String {
    let mut s = String::from(
        "block,im,unit,selected,n,n_overturned,median,beta,a,b,var_a,cov_ab,var_b,\
         log_likelihood,error\n",
    );
    for block in &analysis.blocks {
        for (j, fit) in block.fragility.fits.iter().enumerate() {
            let selected = block
                .fragility
                .selected
                .as_ref()
                .is_some_and(|f| f.im == STUDY_IMS[j]);
            match fit {
                Ok(f) => {
                    let _ = writeln!(
                        s,
                        "{},{},{},{},{},{},{},{},{},{},{},{},{},{},",
                        block.name,
                        f.im.study_name(),
                        f.im_unit,
                        selected,
                        f.n,
                        f.n_events,
                        num(f.median),
                        num(f.beta),
                        num(f.a),
                        num(f.b),
                        num(f.covariance[0][0]),
                        num(f.covariance[0][1]),
                        num(f.covariance[1][1]),
                        num(f.log_likelihood)
                    );
                }
                Err(e) => {
                    let _ = writeln!(
                        s,
                        "{},{},{},false,{},{},,,,,,,,,\"{e}\"",
                        block.name,
                        STUDY_IMS[j].study_name(),
                        STUDY_IMS[j].unit(),
                        block.fragility.n,
                        block.fragility.n_overturned,
                    );
                }
            }
        }
    }
    s
}

/// `fragility.json`: `{"blocks": {NAME: curve or null}}`: each block's selected curve, which
/// deserializes into [`LognormalFragility`] (then `probability`, `band`).
pub fn fragility_json(analysis: &StudyAnalysis) -> serde_json::Result<String> {
    let blocks: BTreeMap<&str, Option<&LognormalFragility>> = analysis
        .blocks
        .iter()
        .map(|b| (b.name.as_str(), b.fragility.selected.as_ref()))
        .collect();
    let mut root = BTreeMap::new();
    root.insert("blocks", blocks);
    serde_json::to_string_pretty(&root)
}

/// A map serialised in the order given (pair labels in study order).
#[derive(Debug, Clone, PartialEq)]
pub struct OrderedMap(pub Vec<(String, Option<f64>)>);

impl serde::Serialize for OrderedMap {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let mut map = serializer.serialize_map(Some(self.0.len()))?;
        for (k, v) in &self.0 {
            map.serialize_entry(k, v)?;
        }
        map.end()
    }
}

/// One IM of a block's ranking in the JSON summary.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct RankingEntry {
    pub im: String,
    pub unit: &'static str,
    /// Overall R² of DM ~ IM.
    pub r2: Option<f64>,
    pub r2_by_pair: OrderedMap,
    /// Overall R² of ln DM ~ ln IM over the responding runs.
    pub r2_log: Option<f64>,
    pub r2_log_by_pair: OrderedMap,
    /// Luco–Cornell p-value of the log–log residuals on Mw.
    pub sufficiency_p_mw: Option<f64>,
    /// Luco–Cornell p-value of the log–log residuals on R.
    pub sufficiency_p_r: Option<f64>,
    pub sufficiency_p_mw_linear: Option<f64>,
    pub sufficiency_p_r_linear: Option<f64>,
    /// Standard deviation of the per-pair R² (the seed's criterion).
    pub r2_pair_sd: Option<f64>,
}

/// One vector IM in the JSON summary.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct VectorEntry {
    pub ims: [String; 2],
    pub r2: Option<f64>,
    pub adjusted_r2: Option<f64>,
    pub r2_log: Option<f64>,
    pub best_scalar_r2: Option<f64>,
}

/// One block in the JSON summary.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct BlockSummary {
    pub dm: &'static str,
    pub half_diagonal_m: f64,
    pub alpha_rad: f64,
    pub mu_s: f64,
    pub mu_k: f64,
    /// Runs used in the regressions.
    pub n: usize,
    /// Runs excluded from them.
    pub excluded: usize,
    /// Runs of every category (used: responding, no_response; the others excluded).
    pub counts: rockwatch_core::study::CategoryCounts,
    pub ranking: Vec<RankingEntry>,
    pub vector: Vec<VectorEntry>,
    pub fragility: Option<LognormalFragility>,
    pub fragility_note: String,
}

/// The study's settings in the JSON summary.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct StudySettings {
    pub magnitudes: Vec<f64>,
    pub distances_km: Vec<f64>,
    pub pulses_per_pair: usize,
    pub pulses: usize,
    pub seed: u64,
    pub dt_s: f64,
    pub im_pad_s: f64,
    pub t_extra_s: f64,
    pub exclude_overturned: bool,
    pub max_slide_m: Option<f64>,
    pub max_theta_rad: Option<f64>,
    pub slide_floor_m: f64,
    pub theta_floor_rad: f64,
}

/// The JSON summary (`summary.json`, and stdout with `--format json`).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Summary {
    pub study: StudySettings,
    pub blocks: BTreeMap<String, BlockSummary>,
}

fn block_summary(config: &StudyConfig, data: &StudyData, b: &BlockAnalysis) -> BlockSummary {
    let labels: Vec<String> = data.pairs.iter().map(|p| p.label()).collect();
    let by_pair = |v: &[Option<f64>]| {
        OrderedMap(
            labels
                .iter()
                .cloned()
                .zip(v.iter().map(|x| x.and_then(finite)))
                .collect(),
        )
    };
    let params = &config.blocks[b.block_index].params;
    BlockSummary {
        dm: b.dm.as_str(),
        // Study blocks are rectangles: both pivots have the same R.
        half_diagonal_m: params.plus.half_diagonal_m,
        alpha_rad: params.alpha_rad,
        mu_s: params.mu_s,
        mu_k: params.mu_k,
        n: b.counts.used(),
        excluded: b.counts.excluded(),
        counts: b.counts,
        ranking: b
            .ranking
            .iter()
            .map(|sc| RankingEntry {
                im: sc.name(),
                unit: sc.unit(),
                r2: finite(sc.r2()),
                r2_by_pair: by_pair(&sc.r2_by_pair),
                r2_log: finite(sc.r2_log()),
                r2_log_by_pair: by_pair(&sc.r2_log_by_pair),
                sufficiency_p_mw: finite(sc.p_mw_log),
                sufficiency_p_r: finite(sc.p_r_log),
                sufficiency_p_mw_linear: finite(sc.p_mw_linear),
                sufficiency_p_r_linear: finite(sc.p_r_linear),
                r2_pair_sd: finite(sc.r2_pair_sd),
            })
            .collect(),
        vector: b
            .vector
            .iter()
            .map(|v| VectorEntry {
                ims: v.ims.map(|j| STUDY_IMS[j].study_name()),
                r2: v.linear.as_ref().and_then(|f| finite(f.r2)),
                adjusted_r2: v.linear.as_ref().and_then(|f| finite(f.adjusted_r2)),
                r2_log: v.log.as_ref().and_then(|f| finite(f.r2)),
                best_scalar_r2: finite(v.best_scalar_r2),
            })
            .collect(),
        fragility: b.fragility.selected.clone(),
        fragility_note: b.fragility.note.clone(),
    }
}

/// Builds the JSON summary.
#[must_use]
pub fn summary(config: &StudyConfig, data: &StudyData, analysis: &StudyAnalysis) -> Summary {
    Summary {
        study: StudySettings {
            magnitudes: config.magnitudes.clone(),
            distances_km: config.distances_km.clone(),
            pulses_per_pair: config.pulses_per_pair,
            pulses: data.cases.len(),
            seed: config.seed,
            dt_s: config.dt_s,
            im_pad_s: config.im_pad_s,
            t_extra_s: config.t_extra_s,
            exclude_overturned: config.exclusion.exclude_overturned,
            max_slide_m: finite(config.exclusion.max_slide_m),
            max_theta_rad: finite(config.exclusion.max_theta_rad),
            slide_floor_m: config.slide_floor_m,
            theta_floor_rad: config.theta_floor_rad,
        },
        blocks: analysis
            .blocks
            .iter()
            .map(|b| (b.name.clone(), block_summary(config, data, b)))
            .collect(),
    }
}

/// The pairs shown in the seed-layout table: those at R = 10 km (the seed's Tables 1 and 2)
/// if the study has that distance, else all pairs.
fn seed_layout_pairs(data: &StudyData) -> Vec<usize> {
    let at_10: Vec<usize> = (0..data.pairs.len())
        .filter(|&p| data.pairs[p].r_km == 10.0)
        .collect();
    if at_10.is_empty() {
        (0..data.pairs.len()).collect()
    } else {
        at_10
    }
}

fn md_table(s: &mut String, data: &StudyData, block: &BlockAnalysis, pairs: &[usize], log: bool) {
    s.push_str("| Intensity measure |");
    for &p in pairs {
        let _ = write!(s, " {} |", data.pairs[p].label().replace('-', " "));
    }
    s.push_str(" Overall R² |\n|---|");
    for _ in pairs {
        s.push_str("---:|");
    }
    s.push_str("---:|\n");
    let mut rows: Vec<&rockwatch_core::study::ImScore> = block.ranking.iter().collect();
    if log {
        rockwatch_core::study::sort_desc_by(&mut rows, |sc| sc.r2_log());
    }
    for sc in rows {
        let _ = write!(s, "| {} |", display_name(sc.im()));
        for &p in pairs {
            let v = if log {
                sc.r2_log_by_pair[p]
            } else {
                sc.r2_by_pair[p]
            };
            let _ = write!(s, " {} |", md4(v.unwrap_or(f64::NAN)));
        }
        let overall = if log { sc.r2_log() } else { sc.r2() };
        let _ = writeln!(s, " {} |", md4(overall));
    }
    s.push('\n');
}

/// `efficiency.md`: for each block, the table in the layout of the seed's Tables 1 and 2 (IM
/// rows sorted by overall R², columns for the R = 10 km pairs), the same over all pairs, and
/// the log–log table.
#[must_use]
pub fn efficiency_md(config: &StudyConfig, data: &StudyData, analysis: &StudyAnalysis) -> String {
    let mut s = String::from("# Intensity-measure study: efficiency (R²)\n\n");
    let _ = writeln!(
        s,
        "{} pulses ({} per Mw–R pair), seed {}, dt = {} s. Linear R² of DM ~ IM over the runs \
         kept by the exclusion rule (overturned runs excluded: {}; max |slide| ≤ {} m; \
         max |θ| ≤ {} rad); log–log R² of ln DM ~ ln IM over the responding runs (DM ≥ {} m \
         for slides, ≥ {} rad for rotations). — = undefined (no response in that pair).\n",
        data.cases.len(),
        config.pulses_per_pair,
        config.seed,
        config.dt_s,
        config.exclusion.exclude_overturned,
        config.exclusion.max_slide_m,
        config.exclusion.max_theta_rad,
        config.slide_floor_m,
        config.theta_floor_rad
    );
    let seed_pairs = seed_layout_pairs(data);
    let all: Vec<usize> = (0..data.pairs.len()).collect();
    for block in &analysis.blocks {
        let c = &block.counts;
        let _ = writeln!(
            s,
            "## Block `{}` (DM: {})\n\n{} runs used ({} responding, {} without response); {} \
             excluded ({} overturned, {} flight, {} failed, {} slide above max, {} θ above \
             max).\n",
            block.name,
            block.dm.label(),
            c.used(),
            c.responding,
            c.no_response,
            c.excluded(),
            c.overturned,
            c.flight,
            c.failed,
            c.slide_above_max,
            c.theta_above_max
        );
        s.push_str("### Linear R², seed layout\n\n");
        md_table(&mut s, data, block, &seed_pairs, false);
        if seed_pairs.len() != all.len() {
            s.push_str("### Linear R², all pairs\n\n");
            md_table(&mut s, data, block, &all, false);
        }
        s.push_str("### Log–log R² (responding runs), all pairs\n\n");
        md_table(&mut s, data, block, &all, true);
    }
    s
}

/// Writes every table of the study into `out_dir` (created if missing) and returns the paths.
pub fn write_tables(
    out_dir: &Path,
    config: &StudyConfig,
    data: &StudyData,
    analysis: &StudyAnalysis,
) -> Result<Vec<PathBuf>, ReportError> {
    std::fs::create_dir_all(out_dir).map_err(|source| ReportError {
        path: out_dir.to_path_buf(),
        source,
    })?;
    let json = |r: serde_json::Result<String>| {
        r.map_err(|e| ReportError {
            path: out_dir.to_path_buf(),
            source: std::io::Error::other(e),
        })
    };
    let files = [
        ("results.csv", results_csv(config, data, analysis)),
        ("efficiency.csv", efficiency_csv(data, analysis)),
        ("efficiency.md", efficiency_md(config, data, analysis)),
        ("sufficiency.csv", sufficiency_csv(analysis)),
        ("vector.csv", vector_csv(analysis)),
        ("fragility.csv", fragility_csv(data, analysis)),
        ("fragility_fits.csv", fragility_fits_csv(analysis)),
        ("fragility.json", json(fragility_json(analysis))?),
        (
            "summary.json",
            json(serde_json::to_string_pretty(&summary(
                config, data, analysis,
            )))?,
        ),
    ];
    let mut written = Vec::with_capacity(files.len());
    for (name, text) in files {
        let path = out_dir.join(name);
        std::fs::write(&path, text).map_err(|source| ReportError {
            path: path.clone(),
            source,
        })?;
        written.push(path);
    }
    Ok(written)
}
