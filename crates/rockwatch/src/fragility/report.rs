//! Writers of a rock's fragility (the computations are in [`rockwatch_core::fragility`]):
//! `fragility.json`, `runs.csv` and the text summary.

use std::fmt::Write as _;
use std::path::Path;

use rockwatch_core::fragility::{
    cell_counts, wilson_interval, BootstrapJson, Ci95Json, FragilityConfig, FragilityRecord,
    FragilityResult, HorizontalDefinition, Im, ImFragilityJson, Intensity, Prepared, RunResult,
    Z_95,
};
use serde_json::{json, Map, Value};

use crate::number_text::{json_number, short_number};
use crate::units::AccelUnits;

/// A file name for an IM: `SA(1.0)` → `SA_1p0`, `PGV/PGA` → `PGV_PGA`.
#[must_use]
pub fn im_slug(name: &str) -> String {
    name.chars()
        .filter_map(|c| match c {
            '(' | '/' => Some('_'),
            '.' => Some('p'),
            ')' => None,
            c => Some(c),
        })
        .collect()
}

/// The horizontal-component definition of IM `im` in this analysis: the configuration's
/// (`RotD50`, `RotD100`, `GM`) for the IMs that have one when the records are pairs, else
/// `component` (one component as recorded, along each incidence).
#[must_use]
pub fn definition_of(config: &FragilityConfig, im: &Im) -> &'static str {
    if im.has_horizontal_definition() {
        config.horizontal.name()
    } else {
        HorizontalDefinition::Component.name()
    }
}

/// The JSON document of `fragility.json` (see the command's help for the schema).
#[must_use]
pub fn fragility_json(
    rock: Value,
    config: &FragilityConfig,
    records: &[FragilityRecord],
    prepared: &Prepared,
    result: &FragilityResult,
) -> Value {
    let usable = result.n_runs - result.n_flight - result.n_failed;
    let mut ims = Map::new();
    let mut not_fitted = Map::new();
    for f in &result.ims {
        let name = f.im.name();
        match &f.fit {
            Ok(fit) => {
                let entry = ImFragilityJson {
                    median: fit.median,
                    beta: fit.beta,
                    ci95: Ci95Json {
                        median: f.ci_median,
                        beta: f.ci_beta,
                    },
                    n_runs: usable,
                    n_overturned: result.n_overturned,
                    unit: Some(f.im.unit().to_owned()),
                    horizontal_definition: Some(definition_of(config, &f.im).to_owned()),
                    likelihood: Some(
                        if f.is_stripe_im {
                            "binomial over stripes"
                        } else {
                            "binomial over (record, scale) groups"
                        }
                        .to_owned(),
                    ),
                    log_likelihood: Some(fit.log_likelihood),
                    bootstrap: BootstrapJson {
                        replicates: f.bootstrap.len() + f.bootstrap_failed,
                        failed: f.bootstrap_failed,
                        median_beta: f.bootstrap.iter().map(|&(m, b)| [m, b]).collect(),
                    },
                    median_if_flight_overturned: f.median_flight_overturned,
                };
                ims.insert(name, json!(entry));
            }
            Err(e) => {
                let reason = f.note.clone().unwrap_or_else(|| e.to_string());
                not_fitted.insert(name, json!(reason));
            }
        }
    }
    let ranking: Vec<Value> = result
        .ranking
        .iter()
        .map(|&i| {
            let f = &result.ims[i];
            json!({"im": f.im.name(), "beta": f.fit.as_ref().map_or(f64::NAN, |x| x.beta)})
        })
        .collect();
    let surface = result.surface.as_ref().map(|s| {
        let (a, b) = s.ims;
        let (na, nb) = (config.ims[a].name(), config.ims[b].name());
        match &s.fit {
            Ok(fit) => json!({
                "ims": [na, nb],
                "units": [config.ims[a].unit(), config.ims[b].unit()],
                "model": "P = Phi(c0 + c1 ln im1 + c2 ln im2)",
                "coefficients": fit.coef,
                "covariance": fit.covariance,
                "beta_im1": json_number(fit.beta1()),
                "median_im1": {"at_im2_power": json_number(-fit.coef[2] / fit.coef[1]), "coefficient": json_number((-fit.coef[0] / fit.coef[1]).exp())},
                "log_likelihood": fit.log_likelihood,
                "grid": {"im1": s.grid1, "im2": s.grid2, "p": s.p},
            }),
            Err(e) => json!({"ims": [na, nb], "error": e.to_string()}),
        }
    });
    let intensity = match &config.intensity {
        Intensity::Stripes { im, levels } => json!({
            "stripes": {"im": config.ims[*im].name(), "unit": config.ims[*im].unit(), "levels": levels, "spacing": "log"}
        }),
        Intensity::Scales(s) => json!({"scales": s}),
    };
    let scale_range = prepared
        .scales
        .iter()
        .flatten()
        .fold((f64::INFINITY, 0.0_f64), |(lo, hi), &s| {
            (lo.min(s), hi.max(s))
        });
    json!({
        "ims": ims,
        "not_fitted": not_fitted,
        "ranking": ranking,
        "surface": surface,
        "rock": rock,
        "intensity": intensity,
        "records": records.iter().map(|r| &r.name).collect::<Vec<_>>(),
        "incidences_deg": config.incidences_deg,
        "horizontal_definition": {
            "definition": config.horizontal.name(),
            "records": if config.horizontal == HorizontalDefinition::Component { "one horizontal component each, applied along each incidence" } else { "pairs of horizontal components: the first along each incidence, the second 90° clockwise of it" },
            "applies_to": "PGA, PGV, PGD, SA(T), PGV/PGA; the other IMs are of the first component (ims.<IM>.horizontal_definition)",
        },
        "members": config.members.len(),
        "scale_factor_range": [json_number(scale_range.0), json_number(scale_range.1)],
        "runs": {"total": result.n_runs, "usable": usable, "overturned": result.n_overturned, "flight": result.n_flight, "failed": result.n_failed},
        "flight_runs": {
            "count": result.n_flight,
            "criterion": "left out of the fits: free flight is detected, not modelled, so its outcome is unknown",
            "bias": "leaving them out biases each median upwards where they happen (the strongest shaking) if they would have overturned; ims.<IM>.median_if_flight_overturned is the median of the fit that counts each as an overturn: the true median lies between the two",
        },
        "bootstrap": {"replicates": config.bootstrap, "seed": config.seed, "resampling": "records, with replacement"},
    })
}

/// Writes `runs.csv`: one row per run with its scaled IMs.
pub fn write_runs_csv(
    path: &Path,
    config: &FragilityConfig,
    records: &[FragilityRecord],
    prepared: &Prepared,
    runs: &[RunResult],
) -> std::io::Result<()> {
    let mut text = String::from(
        "record,vertical,level,scale,member,incidence_deg,status,direction,max_theta_over_alpha,max_slide_m",
    );
    for im in &config.ims {
        let _ = write!(text, ",{} ({})", im.name(), im.unit());
    }
    text.push_str(",error\n");
    for run in runs {
        let rec = &records[run.record];
        let _ = write!(
            text,
            "{},{},{},{},{},{},{},{},{},{}",
            rec.name,
            rec.record.vertical_mps2.is_some(),
            run.level,
            run.scale,
            run.member,
            config.incidences_deg[run.incidence],
            run.status.as_str(),
            run.direction.map_or(String::new(), |d| d.to_string()),
            run.max_abs_theta_over_alpha,
            run.max_abs_slide_m
        );
        for i in 0..config.ims.len() {
            let _ = write!(
                text,
                ",{}",
                prepared.scaled_im(config, run.record, run.level, i)
            );
        }
        let error = run.error.as_deref().unwrap_or("").replace(['"', ','], ";");
        let _ = writeln!(text, ",{error}");
    }
    std::fs::write(path, text)
}

/// Stripe fractions of the stripe IM: `(level, k, n, wilson lo, hi)` with each record one
/// trial (the runs of one record, its members and incidences, are not independent: the two
/// polarities of a record on a symmetric rock are the same trial): n records with usable runs
/// at the stripe, k the sum of their fractions overturned.
#[must_use]
pub fn stripe_fractions(
    config: &FragilityConfig,
    prepared: &Prepared,
    runs: &[RunResult],
) -> Vec<(f64, f64, f64, f64, f64)> {
    let Intensity::Stripes { levels, .. } = &config.intensity else {
        return Vec::new();
    };
    let counts = cell_counts(config, prepared.ims.len(), runs);
    levels
        .iter()
        .enumerate()
        .map(|(j, &l)| {
            let (n, k) = counts
                .iter()
                .filter(|row| row[j].trials > 0.0)
                .fold((0.0, 0.0), |(n, k), row| {
                    (n + 1.0, k + row[j].events / row[j].trials)
                });
            let (lo, hi) = wilson_interval(k, n, Z_95);
            (l, k, n, lo, hi)
        })
        .collect()
}

/// The text summary.
#[must_use]
pub fn text_summary(
    rock_label: &str,
    config: &FragilityConfig,
    records: &[FragilityRecord],
    result: &FragilityResult,
    written: &[std::path::PathBuf],
    units: AccelUnits,
) -> String {
    let mut out = String::new();
    let _ = writeln!(out, "rock        {rock_label}");
    let _ = writeln!(
        out,
        "runs        {} ({} records × {} levels × {} member(s) × {} incidence(s)), {} overturned, {} flight, {} failed",
        result.n_runs,
        records.len(),
        config.intensity.len(),
        config.members.len(),
        config.incidences_deg.len(),
        result.n_overturned,
        result.n_flight,
        result.n_failed
    );
    let _ = writeln!(
        out,
        "component   {}",
        if config.horizontal == HorizontalDefinition::Component {
            "one horizontal component per record, along each incidence (--horizontal-im \
             component)"
                .to_string()
        } else {
            format!(
                "{} of each pair of horizontal components for PGA, PGV, PGD, SA(T), PGV/PGA; \
                 the other IMs of the first component",
                config.horizontal.name()
            )
        }
    );
    let _ = writeln!(
        out,
        "{:<14} {:>12} {:>8} {:>25} {:>17}  unit",
        "IM", "median", "beta", "95% CI median", "95% CI beta"
    );
    let fmt_ci = |c: Option<[f64; 2]>, div: f64| {
        c.map_or("-".to_string(), |[a, b]| {
            format!("[{}, {}]", short_number(a / div), short_number(b / div))
        })
    };
    for &i in &result.ranking {
        let f = &result.ims[i];
        if let Ok(fit) = &f.fit {
            // The median and its interval in the unit of the last column (--units).
            let (unit, div) = units.show(f.im.unit());
            let _ = writeln!(
                out,
                "{:<14} {:>12} {:>8} {:>25} {:>17}  {unit}",
                f.im.name(),
                short_number(fit.median / div),
                short_number(fit.beta),
                fmt_ci(f.ci_median, div),
                fmt_ci(f.ci_beta, 1.0),
            );
        }
    }
    if result.n_flight > 0 {
        for &i in &result.ranking {
            let f = &result.ims[i];
            if let (Ok(fit), Some(bound)) = (&f.fit, f.median_flight_overturned) {
                let (unit, div) = units.show(f.im.unit());
                let _ = writeln!(
                    out,
                    "flight      {}: median {} with the {} flight runs left out, {} if each had overturned ({}): the true median lies between",
                    f.im.name(),
                    short_number(fit.median / div),
                    result.n_flight,
                    short_number(bound / div),
                    unit
                );
            }
        }
    }
    for f in &result.ims {
        let total = f.bootstrap.len() + f.bootstrap_failed;
        if f.fit.is_ok() && f.bootstrap_failed * 20 > total {
            let _ = writeln!(
                out,
                "note        {}: {} of {total} bootstrap replicates had no finite fit (separated \
                 resamples; too few records or stripes): its interval is optimistic",
                f.im.name(),
                f.bootstrap_failed
            );
        }
        if let Err(e) = &f.fit {
            let reason = f.note.clone().unwrap_or_else(|| e.to_string());
            let _ = writeln!(out, "{:<14} not fitted: {reason}", f.im.name());
        }
    }
    if let Some(s) = &result.surface {
        let (a, b) = s.ims;
        match &s.fit {
            Ok(fit) => {
                let _ = writeln!(
                    out,
                    "surface     P = Φ({} + {} ln {} + {} ln {}): median {} ∝ {}^{}, β = {}",
                    short_number(fit.coef[0]),
                    short_number(fit.coef[1]),
                    config.ims[a].name(),
                    short_number(fit.coef[2]),
                    config.ims[b].name(),
                    config.ims[a].name(),
                    config.ims[b].name(),
                    short_number(-fit.coef[2] / fit.coef[1]),
                    short_number(fit.beta1())
                );
                // The coefficients multiply ln of SI values: say so when the table is in g.
                let shown = [a, b].map(|i| units.show(config.ims[i].unit()).0);
                if shown.contains(&"g") {
                    let _ = writeln!(
                        out,
                        "            (the surface's IMs in SI units: {} in {}, {} in {})",
                        config.ims[a].name(),
                        config.ims[a].unit(),
                        config.ims[b].name(),
                        config.ims[b].unit()
                    );
                }
            }
            Err(e) => {
                let _ = writeln!(
                    out,
                    "surface     {} × {}: not fitted: {e}",
                    config.ims[a].name(),
                    config.ims[b].name()
                );
            }
        }
    }
    for p in written {
        let _ = writeln!(out, "wrote       {}", p.display());
    }
    out
}
