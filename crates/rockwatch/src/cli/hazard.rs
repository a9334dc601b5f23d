//! `rockwatch hazard`: annual overturning rate, return period and survival probability of one
//! rock from its fragility and its site's hazard curve (docs/hazard.md).

use std::collections::BTreeMap;
use std::path::PathBuf;

use anyhow::{bail, Context};
use rockwatch::hazard_plots::{write_hazard_plots, HazardFigures};
use rockwatch::number_text::{json_number, short_number};
use rockwatch::units::AccelUnits;
use rockwatch_core::fragility::HorizontalDefinition;
use rockwatch_core::hazard::{
    fractile_weights, fragility_from_json, overturn_rate, parse_openquake_csv,
    parse_two_column_csv, rate_interval, rate_samples, CurveKind, ExposureAge, HazardCurve, Im,
    ImUnit, Lognormal, OverturnRate, RateSample, Site, SiteSelection,
};

use super::OutputFormat;

/// Combine a rock's lognormal overturning fragility with its site's hazard curve:
/// λ = ∫ P(overturn | im) |dλ_H(im)| (1/yr), the return period 1/λ and the probability
/// exp(−λT) that the rock survives T years (its exposure age).
///
/// With the fragility's bootstrap replicates (fragility.json of `rockwatch fragility`) and/or
/// several OpenQuake curves of one site (mean and quantile-q files), a 95 % interval on λ, the
/// return period and P(survival) from λ over every fractile curve × every replicate; with
/// --age-sigma-years, P(survival) = E_T[exp(−λT)] over a normal age truncated at 0
/// (docs/hazard.md).
///
/// The hazard levels are converted to the fragility's unit explicitly (the factor is printed);
/// an acceleration and a velocity are never mixed.
#[derive(Debug, clap::Args)]
pub struct HazardArgs {
    /// Fragility JSON: `{"ims": {"PGV": {"median": θ, "beta": β, "unit": "m/s"}}}` (unit
    /// optional: SI, m/s for PGV, m/s2 for PGA and SA; with `"bootstrap": {"median_beta":
    /// [[θ, β], …]}`, as `rockwatch fragility` writes it, the replicates give λ's interval),
    /// or the fragility.json written by `rockwatch study` (`{"blocks": {NAME: {"im",
    /// "im_unit", "median", "beta", …}}}`).
    #[arg(long, value_name = "FILE")]
    fragility: PathBuf,
    /// The IM of the fragility and the hazard curve: PGA, PGV, SA(T) (case-insensitive; the
    /// study's pha/phv are PGA/PGV; SA(1) is SA(1.0)).
    #[arg(long, value_name = "IM")]
    im: String,
    /// With a study fragility.json holding several blocks: the block to use.
    #[arg(long, value_name = "NAME")]
    block: Option<String>,
    /// Hazard curve: an OpenQuake hazard_curve-mean-<IMT>_*.csv (comment line with
    /// investigation_time and imt, header lon,lat,depth,poe-<level>…; PoE → annual rate by
    /// λ = −ln(1 − PoE)/T; levels in g for PGA/SA, cm/s for PGV), or a two-column CSV
    /// `level,annual_rate` (with --hazard-unit). Several OpenQuake files of one site and IMT
    /// (`hazard_curve-mean-…` and `quantile_curve-<q>-…`, told apart by their `kind`): the
    /// mean (else the 0.5 quantile) gives λ, the quantiles its hazard interval.
    #[arg(long = "hazard-curve", value_name = "FILE", num_args = 1.., required = true)]
    hazard_curve: Vec<PathBuf>,
    /// Unit of the levels of a two-column hazard curve: g, m/s2, cm/s2, m/s or cm/s.
    /// For an OpenQuake file it is implied by the IMT and, if given, must agree.
    #[arg(long = "hazard-unit", value_name = "UNIT")]
    hazard_unit: Option<String>,
    /// Investigation time (years) of an OpenQuake file's probabilities, if its comment line
    /// lacks it (if both are given they must agree).
    #[arg(long = "investigation-time", value_name = "Y")]
    investigation_time: Option<f64>,
    /// Row (0-based) of the site in an OpenQuake file with several sites (default 0; or
    /// --lon/--lat).
    #[arg(long, value_name = "N", conflicts_with_all = ["lon", "lat"])]
    site: Option<usize>,
    /// Longitude (degrees) of the rock: the OpenQuake file's nearest site (great-circle
    /// distance, said in the output) is used. With --lat.
    #[arg(
        long,
        value_name = "DEG",
        requires = "lat",
        allow_negative_numbers = true
    )]
    lon: Option<f64>,
    /// Latitude (degrees) of the rock, with --lon.
    #[arg(
        long,
        value_name = "DEG",
        requires = "lon",
        allow_negative_numbers = true
    )]
    lat: Option<f64>,
    /// Exposure ages T (years), comma-separated: prints exp(−λT) for each (E_T[exp(−λT)]
    /// with --age-sigma-years).
    #[arg(
        long = "age-years",
        value_name = "T[,T2…]",
        value_delimiter = ',',
        required = true
    )]
    age_years: Vec<f64>,
    /// Standard deviations σ (years) of the exposure ages: one for all or one per age,
    /// comma-separated (default 0: ages known exactly). The age is a normal T ± σ truncated at
    /// 0, and P(survival) = E_T[exp(−λT)].
    #[arg(
        long = "age-sigma-years",
        value_name = "S[,S2…]",
        value_delimiter = ','
    )]
    age_sigma_years: Vec<f64>,
    /// Directory to write the plots into (created if missing): hazard_curves (the hazard
    /// curves with their fractile band over the fragility with its bootstrap band),
    /// hazard_deaggregation (the contribution to λ by IM level) and hazard_survival
    /// (P(survival) against age with its band, T ± σ marked), each .svg and .png.
    #[arg(long, value_name = "DIR")]
    plots: Option<PathBuf>,
    /// Output format on stdout.
    #[arg(long, value_enum, default_value_t = OutputFormat::Text)]
    format: OutputFormat,
    /// The horizontal-component definition of the hazard curve's IM (its GMPEs'): rotd50,
    /// rotd100, gm or component. OpenQuake's hazard-curve CSV does not carry it (see the
    /// GMPEs of the logic tree: the NGA-West2 models give RotD50). When given and the
    /// fragility's (fragility.json's `horizontal_definition`) differs, a warning says so.
    #[arg(long = "hazard-definition", value_name = "DEF")]
    hazard_definition: Option<String>,
    /// Unit of an acceleration fragility's median and of the hazard levels' conversion
    /// (`× 1 → g`) in the text output: m/s2 or g (9.80665 m/s²). The JSON output keeps the
    /// fragility's SI unit and median (its `unit`, `median` fields).
    #[arg(long, value_enum, default_value_t = AccelUnits::Mps2, value_name = "g|m/s2")]
    units: AccelUnits,
}

/// The hazard curve file: OpenQuake if it starts with a comment line mentioning
/// investigation_time or has a lon,lat,depth header, else two columns.
fn read_curve(args: &HazardArgs, im: Im, text: &str, name: &str) -> anyhow::Result<HazardCurve> {
    let first = text.lines().find(|l| !l.trim().is_empty()).unwrap_or("");
    let openquake = (first.trim_start().starts_with('#') && first.contains("investigation_time"))
        || text
            .lines()
            .any(|l| l.trim_start().starts_with("lon,lat,depth"));
    if openquake {
        let site = match (args.lon, args.lat) {
            (Some(lon), Some(lat)) => SiteSelection::Nearest { lon, lat },
            _ => SiteSelection::Row(args.site.unwrap_or(0)),
        };
        let curve = parse_openquake_csv(text, name, site, args.investigation_time)?;
        if let Some(imt) = &curve.imt {
            if Im::from_openquake_imt(imt)? != im {
                bail!("{name}: the hazard curve is for {imt}, not {}", args.im);
            }
        }
        if let Some(u) = &args.hazard_unit {
            let given = ImUnit::parse(u)?;
            if given != curve.unit {
                bail!(
                    "--hazard-unit {given} disagrees with OpenQuake's unit {} for {}",
                    curve.unit,
                    curve.imt.as_deref().unwrap_or("?")
                );
            }
        }
        Ok(curve)
    } else {
        if args.investigation_time.is_some() {
            bail!("--investigation-time applies to OpenQuake files; {name} has annual rates");
        }
        if args.site.is_some() || args.lon.is_some() {
            bail!(
                "--site and --lon/--lat choose a site of an OpenQuake file; {name} is one \
                 site's two-column curve"
            );
        }
        let unit = args.hazard_unit.as_deref().with_context(|| {
            format!(
                "{name}: a two-column hazard curve needs --hazard-unit (g, m/s2, cm/s2, m/s, cm/s)"
            )
        })?;
        Ok(parse_two_column_csv(text, name, ImUnit::parse(unit)?)?)
    }
}

/// One hazard-curve file: its name, the curve as read, and the curve in the fragility's unit.
struct CurveFile {
    name: String,
    curve: HazardCurve,
    converted: HazardCurve,
}

/// Which of several curves gives λ (`central`) and the fractile curves (indices into the
/// files, increasing quantile) with their quantiles and weights ([`fractile_weights`]).
struct Arrangement {
    central: usize,
    fractiles: Vec<(usize, f64, f64)>,
}

/// One curve: it gives λ, no fractiles. Several: OpenQuake curves of one site and IMT, each
/// a mean or a quantile (their `kind`), at most one mean and each quantile once, at least two
/// quantiles; λ from the mean, else from the 0.5 quantile.
fn arrange(files: &[CurveFile]) -> anyhow::Result<Arrangement> {
    if files.len() == 1 {
        return Ok(Arrangement {
            central: 0,
            fractiles: Vec::new(),
        });
    }
    let (mut mean, mut quantiles) = (None, Vec::new());
    for (i, f) in files.iter().enumerate() {
        match &f.curve.kind {
            Some(CurveKind::Mean) if mean.is_none() => mean = Some(i),
            Some(CurveKind::Mean) => bail!("{}: a second mean hazard curve", f.name),
            Some(CurveKind::Quantile(q)) => {
                if quantiles.iter().any(|&(_, other)| other == *q) {
                    bail!("{}: a second quantile-{q} hazard curve", f.name);
                }
                quantiles.push((i, *q));
            }
            other => bail!(
                "{}: several hazard curves must be OpenQuake mean and quantile curves \
                 (kind='mean', kind='quantile-0.16', …); this one's kind is {}",
                f.name,
                other
                    .as_ref()
                    .map_or("not said".to_owned(), |k| format!("{k:?}"))
            ),
        }
        let (first, this) = (&files[0], f);
        if first.curve.imt != this.curve.imt {
            bail!(
                "{} is for {:?} and {} for {:?}: the curves must be of one IMT",
                first.name,
                first.curve.imt,
                this.name,
                this.curve.imt
            );
        }
        let position = |c: &HazardCurve| c.site.map(|s| (s.lon, s.lat));
        if position(&first.curve) != position(&this.curve) {
            bail!(
                "{} and {} are of different sites ({:?} and {:?}): the curves must be of one site",
                first.name,
                this.name,
                position(&first.curve),
                position(&this.curve)
            );
        }
    }
    if quantiles.len() < 2 {
        bail!(
            "several hazard curves need at least two quantile curves (e.g. quantile-0.16 and \
             quantile-0.84) for the hazard's interval"
        );
    }
    quantiles.sort_by(|a, b| a.1.total_cmp(&b.1));
    let weights = fractile_weights(&quantiles.iter().map(|q| q.1).collect::<Vec<_>>())?;
    let central = match mean.or_else(|| quantiles.iter().find(|q| q.1 == 0.5).map(|q| q.0)) {
        Some(c) => c,
        None => bail!(
            "of several hazard curves, λ comes from the mean (hazard_curve-mean-…) or else the \
             0.5 quantile: give one of them"
        ),
    };
    Ok(Arrangement {
        central,
        fractiles: quantiles
            .into_iter()
            .zip(weights)
            .map(|((i, q), w)| (i, q, w))
            .collect(),
    })
}

/// The label of a curve in the output: its kind (`mean`, `quantile-0.16`), else its file.
fn curve_label(file: &CurveFile) -> String {
    file.curve
        .kind
        .as_ref()
        .map_or_else(|| file.name.clone(), ToString::to_string)
}

/// `[lo, hi]` as JSON, or null.
fn pair_json(pair: Option<[f64; 2]>) -> serde_json::Value {
    pair.map_or(serde_json::Value::Null, |[a, b]| serde_json::json!([a, b]))
}

/// ` (95 %: a to b)` of an interval in the text, empty without one.
fn interval_text(interval: Option<[f64; 2]>) -> String {
    interval.map_or_else(String::new, |[a, b]| {
        format!(" (95 %: {} to {})", short_number(a), short_number(b))
    })
}

/// The exposure ages of --age-years with the σ of --age-sigma-years (none: 0; one: for all;
/// else one per age).
fn exposure_ages(args: &HazardArgs) -> anyhow::Result<Vec<ExposureAge>> {
    let sigmas = &args.age_sigma_years;
    if sigmas.len() > 1 && sigmas.len() != args.age_years.len() {
        bail!(
            "--age-sigma-years: {} values for {} ages (give one for all, or one per age)",
            sigmas.len(),
            args.age_years.len()
        );
    }
    args.age_years
        .iter()
        .enumerate()
        .map(|(i, &t)| {
            if !(t.is_finite() && t >= 0.0) {
                bail!("--age-years: {t} must be a finite number of years ≥ 0");
            }
            let sigma = match sigmas.len() {
                0 => 0.0,
                1 => sigmas[0],
                _ => sigmas[i],
            };
            ExposureAge::new(t, sigma).with_context(|| "--age-sigma-years")
        })
        .collect()
}

pub fn run(args: HazardArgs) -> anyhow::Result<()> {
    let ages = exposure_ages(&args)?;
    let read = |path: &PathBuf| {
        rockwatch_core::bounded_read::read_to_string_bounded(
            path,
            rockwatch_core::bounded_read::MAX_DATA_FILE_BYTES,
        )
        .with_context(|| format!("cannot read {}", path.display()))
    };
    let fragility_name = args.fragility.display().to_string();
    let im: Im = args.im.parse().context("--im")?;
    let fragility = fragility_from_json(
        &read(&args.fragility)?,
        &fragility_name,
        im,
        args.block.as_deref(),
    )?;
    let hazard_definition = match &args.hazard_definition {
        Some(d) => Some(HorizontalDefinition::parse(d).with_context(|| {
            format!("--hazard-definition {d:?}: expected rotd50, rotd100, gm or component")
        })?),
        None => None,
    };
    let definition_warning = definition_warning(
        fragility.horizontal_definition.as_deref(),
        hazard_definition,
        &fragility.im_name,
    );
    let mut files = Vec::with_capacity(args.hazard_curve.len());
    for path in &args.hazard_curve {
        let name = path.display().to_string();
        let curve = read_curve(&args, im, &read(path)?, &name)?;
        let converted = curve.converted_to(fragility.unit)?;
        files.push(CurveFile {
            name,
            curve,
            converted,
        });
    }
    let Arrangement { central, fractiles } = arrange(&files)?;
    let curve = &files[central].curve;
    let factor = curve.unit.factor_to(fragility.unit)?;
    // λ of every curve with the maximum-likelihood fragility; the central one is λ.
    let rates: Vec<OverturnRate> = files
        .iter()
        .map(|f| overturn_rate(&f.converted, &fragility.curve))
        .collect();
    let rate = &rates[central];
    // The epistemic distribution of λ: the fractile curves (or the central curve alone) ×
    // the bootstrap replicates (or the maximum-likelihood fit alone).
    let replicates: &[Lognormal] = if fragility.bootstrap.is_empty() {
        std::slice::from_ref(&fragility.curve)
    } else {
        &fragility.bootstrap
    };
    let weighted: Vec<(&HazardCurve, f64)> = if fractiles.is_empty() {
        vec![(&files[central].converted, 1.0)]
    } else {
        fractiles
            .iter()
            .map(|&(i, _, w)| (&files[i].converted, w))
            .collect()
    };
    let uncertain = !fragility.bootstrap.is_empty() || !fractiles.is_empty();
    let samples = if uncertain {
        rate_samples(&weighted, replicates)
    } else {
        Vec::new()
    };
    let interval = rate_interval(&samples);
    // The two sources alone: the central curve × the replicates, the fractiles × the fit.
    let fragility_interval = if fragility.bootstrap.is_empty() {
        None
    } else if fractiles.is_empty() {
        interval
    } else {
        rate_interval(&rate_samples(
            &[(&files[central].converted, 1.0)],
            &fragility.bootstrap,
        ))
    };
    let hazard_samples: Vec<RateSample> = fractiles
        .iter()
        .enumerate()
        .map(|(c, &(i, _, w))| RateSample {
            curve: c,
            replicate: 0,
            annual_rate: rates[i].annual_rate,
            weight: w,
        })
        .collect();
    let hazard_interval = rate_interval(&hazard_samples);
    // Each fractile curve's interval over the replicates.
    let curve_interval = |i: usize| -> Option<[f64; 2]> {
        if fragility.bootstrap.is_empty() {
            return None;
        }
        match fractiles.iter().position(|f| f.0 == i) {
            Some(c) => {
                let own: Vec<RateSample> =
                    samples.iter().filter(|s| s.curve == c).copied().collect();
                rate_interval(&own)
            }
            None if i == central => fragility_interval,
            None => None,
        }
    };
    let return_interval = interval.map(|[lo, hi]| [1.0 / hi, 1.0 / lo]);
    // P(survival) = E_T[exp(−λT)]: decreasing in λ, so λ's interval maps onto its interval.
    let survivals: Vec<(ExposureAge, f64, Option<[f64; 2]>)> = ages
        .iter()
        .map(|age| {
            (
                *age,
                age.survival(rate.annual_rate),
                interval.map(|[lo, hi]| [age.survival(hi), age.survival(lo)]),
            )
        })
        .collect();
    let survival: BTreeMap<String, f64> = survivals
        .iter()
        .map(|(age, p, _)| (format_years(age.mean_years), *p))
        .collect();
    // The unit of the text and the plots (--units): g for an acceleration if asked, else the
    // fragility's own.
    let shown = match args.units {
        AccelUnits::G if fragility.unit.is_acceleration() => ImUnit::G,
        _ => fragility.unit,
    };
    let plots = match &args.plots {
        Some(dir) => {
            std::fs::create_dir_all(dir)
                .with_context(|| format!("cannot create {}", dir.display()))?;
            let figures = HazardFigures {
                title: format!("{fragility_name} ({})", fragility.im_name),
                im: fragility.im_name.clone(),
                unit: shown.to_string(),
                to_shown: fragility.unit.factor_to(shown)?,
                curves: files
                    .iter()
                    .enumerate()
                    .map(|(i, f)| (&f.converted, curve_label(f), i == central))
                    .collect(),
                fractile_band: !fractiles.is_empty(),
                fragility: fragility.curve,
                replicates: &fragility.bootstrap,
                rate,
                rate_interval: interval,
                ages: survivals.clone(),
            };
            write_hazard_plots(dir, &figures)?
        }
        None => Vec::new(),
    };
    let sources = {
        let mut s = Vec::new();
        if !fragility.bootstrap.is_empty() {
            s.push(format!(
                "{} fragility bootstrap replicates",
                fragility.bootstrap.len()
            ));
        }
        if !fractiles.is_empty() {
            s.push(format!(
                "{} hazard fractiles ({}; weights {})",
                fractiles.len(),
                fractiles
                    .iter()
                    .map(|f| short_number(f.1))
                    .collect::<Vec<_>>()
                    .join(", "),
                fractiles
                    .iter()
                    .map(|f| short_number(f.2))
                    .collect::<Vec<_>>()
                    .join(", ")
            ));
        }
        s.join(" × ")
    };
    match args.format {
        OutputFormat::Json => {
            let curves: Vec<serde_json::Value> = files
                .iter()
                .enumerate()
                .map(|(i, f)| {
                    let fractile = fractiles.iter().find(|q| q.0 == i);
                    serde_json::json!({
                        "file": f.name,
                        "kind": f.curve.kind.as_ref().map(ToString::to_string),
                        "quantile": fractile.map(|q| q.1),
                        "weight": fractile.map(|q| q.2),
                        "central": i == central,
                        "annual_overturn_rate": rates[i].annual_rate,
                        "return_period_years": rates[i].return_period_years(),
                        "extrapolated_fraction": rates[i].extrapolated_fraction,
                        "annual_overturn_rate_interval": pair_json(curve_interval(i)),
                    })
                })
                .collect();
            let by_level: Vec<serde_json::Value> = rate
                .by_level
                .iter()
                .map(|c| {
                    serde_json::json!({
                        "lower": c.lower,
                        "upper": json_number(c.upper),
                        "annual_overturn_rate": c.annual_rate,
                        "fraction": if rate.annual_rate > 0.0 { c.annual_rate / rate.annual_rate } else { 0.0 },
                    })
                })
                .collect();
            let survival_by_age: Vec<serde_json::Value> = survivals
                .iter()
                .map(|(age, p, range)| {
                    serde_json::json!({
                        "age_years": age.mean_years,
                        "age_sigma_years": age.sigma_years,
                        "survival": p,
                        "overturn_probability": 1.0 - p,
                        "survival_interval": pair_json(*range),
                    })
                })
                .collect();
            let json = serde_json::json!({
                "annual_overturn_rate": rate.annual_rate,
                "annual_overturn_rate_interval": pair_json(interval),
                "return_period_years": rate.return_period_years(),
                "return_period_interval_years": pair_json(return_interval),
                "survival": survival,
                "survival_by_age": survival_by_age,
                "interval": {
                    "percentiles": rockwatch_core::stats::INTERVAL_95,
                    "fragility_bootstrap_replicates": fragility.bootstrap.len(),
                    "hazard_fractiles": fractiles.iter().map(|f| f.1).collect::<Vec<_>>(),
                    "samples": samples.len(),
                    "fragility_only": pair_json(fragility_interval),
                    "hazard_only": pair_json(hazard_interval),
                },
                "hazard_curves": curves,
                "contribution_by_level": by_level,
                "extrapolated_fraction": rate.extrapolated_fraction,
                "im": fragility.im_name,
                "unit": fragility.unit.to_string(),
                "median": fragility.curve.median,
                "beta": fragility.curve.beta,
                "hazard_unit": curve.unit.to_string(),
                "hazard_to_fragility_factor": factor,
                "hazard_levels": curve.levels.len(),
                "fragility_horizontal_definition": fragility.horizontal_definition,
                "hazard_horizontal_definition": hazard_definition.map(HorizontalDefinition::name),
                "site": curve.site.map(|site| site_json(&site, &args)),
                "plots": plots,
            });
            outln!("{}", serde_json::to_string_pretty(&json)?);
        }
        OutputFormat::Text => {
            let median = fragility.curve.median * fragility.unit.factor_to(shown)?;
            let replicates_text = if fragility.bootstrap.is_empty() {
                String::new()
            } else {
                format!(", {} bootstrap replicates", fragility.bootstrap.len())
            };
            outln!(
                "fragility   {} ({}): median {} {}, beta {}{replicates_text}",
                fragility_name,
                fragility.im_name,
                short_number(median),
                shown,
                short_number(fragility.curve.beta)
            );
            for f in &files {
                let c = &f.curve;
                let factor = c.unit.factor_to(shown)?;
                let site = c
                    .site
                    .map(|site| site_text(&site, &args))
                    .unwrap_or_default();
                let kind = c.kind.as_ref().map_or(String::new(), |k| format!("{k}; "));
                outln!(
                    // The unit factor is exact (9.80665 = g by definition): printed whole.
                    "hazard      {} ({kind}{} levels {} to {} {}{site}; × {factor} → {})",
                    f.name,
                    c.levels.len(),
                    short_number(c.levels[0]),
                    short_number(c.levels[c.levels.len() - 1]),
                    c.unit,
                    shown
                );
            }
            outln!(
                "component   fragility {}, hazard {}",
                fragility
                    .horizontal_definition
                    .as_deref()
                    .unwrap_or("not said"),
                hazard_definition.map_or(
                    "not said (--hazard-definition; OpenQuake's CSV does not carry it)",
                    HorizontalDefinition::name
                )
            );
            outln!(
                "λ           {} overturns per year{}",
                short_number(rate.annual_rate),
                interval_text(interval)
            );
            if interval.is_some() {
                outln!("interval    2.5 and 97.5 % percentiles of λ over {sources}");
            }
            if files.len() > 1 {
                outln!(
                    "by curve    {} (the fitted fragility)",
                    files
                        .iter()
                        .zip(&rates)
                        .map(|(f, r)| format!("{} {}", curve_label(f), short_number(r.annual_rate)))
                        .collect::<Vec<_>>()
                        .join(", ")
                );
            }
            outln!(
                "return      {} years{}",
                short_number(rate.return_period_years()),
                interval_text(return_interval)
            );
            for (age, p, range) in &survivals {
                let sigma = if age.sigma_years > 0.0 {
                    format!(" ± {}", format_years(age.sigma_years))
                } else {
                    String::new()
                };
                let range = range.map_or(String::new(), |[a, b]| {
                    format!("95 %: {} to {}; ", short_number(a), short_number(b))
                });
                outln!(
                    "survival    {} after {}{sigma} years ({range}P(overturn) {})",
                    short_number(*p),
                    format_years(age.mean_years),
                    short_number(1.0 - p)
                );
            }
            outln!(
                "tails       {:.2} % of λ comes from beyond the curve's levels (power-law continuation)",
                100.0 * rate.extrapolated_fraction
            );
            if !plots.is_empty() {
                outln!(
                    "wrote       {}",
                    plots
                        .iter()
                        .map(|p| p.display().to_string())
                        .collect::<Vec<_>>()
                        .join(", ")
                );
            }
        }
    }
    if let Some(warning) = definition_warning {
        eprintln!("rockwatch: warning: {warning}");
    }
    if rate.extrapolated_fraction > 0.01 {
        eprintln!(
            "rockwatch: warning: {:.1} % of λ comes from the power-law continuation of the hazard \
             curve beyond its levels: extend the curve to cover the fragility",
            100.0 * rate.extrapolated_fraction
        );
    }
    Ok(())
}

/// The warning when the fragility's horizontal-component definition (`fragility`, as its
/// file says) and the hazard's (`hazard`, --hazard-definition) differ, or when the fragility's
/// `im` is one component as recorded and the hazard's is not said (GMPEs give RotD50 or a
/// geometric mean, not one component along an azimuth). None when they agree or neither is
/// known.
fn definition_warning(
    fragility: Option<&str>,
    hazard: Option<HorizontalDefinition>,
    im: &str,
) -> Option<String> {
    let fragility_def = fragility.and_then(HorizontalDefinition::parse);
    match (fragility_def, hazard) {
        (Some(f), Some(h)) if f != h => Some(format!(
            "the fragility's {im} is {} and the hazard curve's {}: the two IMs differ (RotD50 \
             exceeds GM by a few %, one component along an azimuth scatters around both); \
             refit the fragility with --horizontal-im {}",
            f.name(),
            h.name(),
            h.name().to_ascii_lowercase()
        )),
        (Some(HorizontalDefinition::Component), None) => Some(format!(
            "the fragility's {im} is of one horizontal component as recorded, while hazard \
             curves use their GMPEs' definition (RotD50 for NGA-West2, else often GM): refit \
             with pairs of components (--horizontal-im rotd50), or say the hazard's with \
             --hazard-definition"
        )),
        _ => None,
    }
}

/// The site of an OpenQuake curve in the `hazard` line: `, site 2 of 3 at -118.5, 34.3`, and
/// for the nearest to --lon/--lat `, the nearest to -118.48, 34.28 (1.234 km)`.
fn site_text(site: &Site, args: &HazardArgs) -> String {
    let mut text = format!(
        ", site {} of {} at {}, {}",
        site.row, site.rows, site.lon, site.lat
    );
    if let (Some(d), Some(lon), Some(lat)) = (site.distance_km, args.lon, args.lat) {
        text += &format!(", the nearest to {lon}, {lat} ({} km)", short_number(d));
    }
    text
}

/// The site of an OpenQuake curve in the JSON: its row (0-based) among `rows`, lon, lat
/// (degrees), and with --lon/--lat the point asked for and its distance to the site (km).
fn site_json(site: &Site, args: &HazardArgs) -> serde_json::Value {
    serde_json::json!({
        "row": site.row,
        "rows": site.rows,
        "lon": site.lon,
        "lat": site.lat,
        "requested_lon": args.lon,
        "requested_lat": args.lat,
        "distance_km": site.distance_km,
    })
}

/// An age as a JSON key: `10000`, `12500.5`.
fn format_years(t: f64) -> String {
    format!("{t}")
}
