//! `rockwatch hazard`: annual overturning rate, return period and survival probability of one
//! rock from its fragility and its site's hazard curve (docs/hazard.md).

use std::collections::BTreeMap;
use std::path::PathBuf;

use anyhow::{bail, Context};
use rockwatch::number_text::short_number;
use rockwatch::units::AccelUnits;
use rockwatch_core::fragility::HorizontalDefinition;
use rockwatch_core::hazard::{
    canonical_im, fragility_from_json, overturn_rate, parse_openquake_csv, parse_two_column_csv,
    HazardCurve, ImUnit, Site, SiteSelection,
};

use super::OutputFormat;

/// Combine a rock's lognormal overturning fragility with its site's hazard curve:
/// λ = ∫ P(overturn | im) |dλ_H(im)| (1/yr), the return period 1/λ and the probability
/// exp(−λT) that the rock survives T years (its exposure age).
///
/// The hazard levels are converted to the fragility's unit explicitly (the factor is printed);
/// an acceleration and a velocity are never mixed.
#[derive(Debug, clap::Args)]
pub struct HazardArgs {
    /// Fragility JSON: `{"ims": {"PGV": {"median": θ, "beta": β, "unit": "m/s"}}}` (unit
    /// optional: SI, m/s for PGV, m/s2 for PGA and SA), or the fragility.json written by
    /// `rockwatch study` (`{"blocks": {NAME: {"im", "im_unit", "median", "beta", …}}}`).
    #[arg(long, value_name = "FILE")]
    fragility: PathBuf,
    /// The IM of the fragility and the hazard curve: PGA, PGV, SA(T) (case-insensitive; the
    /// study's pha/phv are PGA/PGV).
    #[arg(long, value_name = "IM")]
    im: String,
    /// With a study fragility.json holding several blocks: the block to use.
    #[arg(long, value_name = "NAME")]
    block: Option<String>,
    /// Hazard curve: an OpenQuake hazard_curve-mean-<IMT>_*.csv (comment line with
    /// investigation_time and imt, header lon,lat,depth,poe-<level>…; PoE → annual rate by
    /// λ = −ln(1 − PoE)/T; levels in g for PGA/SA, cm/s for PGV), or a two-column CSV
    /// `level,annual_rate` (with --hazard-unit).
    #[arg(long = "hazard-curve", value_name = "FILE")]
    hazard_curve: PathBuf,
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
    /// Exposure ages T (years), comma-separated: prints exp(−λT) for each.
    #[arg(
        long = "age-years",
        value_name = "T[,T2…]",
        value_delimiter = ',',
        required = true
    )]
    age_years: Vec<f64>,
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
fn read_curve(args: &HazardArgs, text: &str, name: &str) -> anyhow::Result<HazardCurve> {
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
            if canonical_im(imt) != canonical_im(&args.im) {
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

pub fn run(args: HazardArgs) -> anyhow::Result<()> {
    for &t in &args.age_years {
        if !(t.is_finite() && t >= 0.0) {
            bail!("--age-years: {t} must be a finite number of years ≥ 0");
        }
    }
    let read = |path: &PathBuf| {
        rockwatch_core::bounded_read::read_to_string_bounded(
            path,
            rockwatch_core::bounded_read::MAX_DATA_FILE_BYTES,
        )
        .with_context(|| format!("cannot read {}", path.display()))
    };
    let fragility_name = args.fragility.display().to_string();
    let fragility = fragility_from_json(
        &read(&args.fragility)?,
        &fragility_name,
        &args.im,
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
        &fragility.im,
    );
    let curve_name = args.hazard_curve.display().to_string();
    let curve = read_curve(&args, &read(&args.hazard_curve)?, &curve_name)?;
    let factor = curve.unit.factor_to(fragility.unit)?;
    let converted = curve.converted_to(fragility.unit)?;
    let rate = overturn_rate(&converted, &fragility.curve);
    let survival: BTreeMap<String, f64> = args
        .age_years
        .iter()
        .map(|&t| (format_years(t), rate.survival(t)))
        .collect();
    match args.format {
        OutputFormat::Json => {
            let json = serde_json::json!({
                "annual_overturn_rate": rate.annual_rate,
                "return_period_years": rate.return_period_years(),
                "survival": survival,
                "extrapolated_fraction": rate.extrapolated_fraction,
                "im": fragility.im,
                "unit": fragility.unit.to_string(),
                "median": fragility.curve.median,
                "beta": fragility.curve.beta,
                "hazard_unit": curve.unit.to_string(),
                "hazard_to_fragility_factor": factor,
                "hazard_levels": curve.levels.len(),
                "fragility_horizontal_definition": fragility.horizontal_definition,
                "hazard_horizontal_definition": hazard_definition.map(HorizontalDefinition::name),
                "site": curve.site.map(|site| site_json(&site, &args)),
            });
            outln!("{}", serde_json::to_string_pretty(&json)?);
        }
        OutputFormat::Text => {
            // The unit of the text (--units): g for an acceleration if asked, else the
            // fragility's own.
            let shown = match args.units {
                AccelUnits::G if fragility.unit.is_acceleration() => ImUnit::G,
                _ => fragility.unit,
            };
            let factor = curve.unit.factor_to(shown)?;
            let median = fragility.curve.median * fragility.unit.factor_to(shown)?;
            outln!(
                "fragility   {} ({}): median {} {}, beta {}",
                fragility_name,
                fragility.im,
                short_number(median),
                shown,
                short_number(fragility.curve.beta)
            );
            let site = curve
                .site
                .map(|site| site_text(&site, &args))
                .unwrap_or_default();
            outln!(
                // The unit factor is exact (9.80665 = g by definition): printed whole.
                "hazard      {} ({} levels {} to {} {}{site}; × {factor} → {})",
                curve_name,
                curve.levels.len(),
                short_number(curve.levels[0]),
                short_number(curve.levels[curve.levels.len() - 1]),
                curve.unit,
                shown
            );
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
                "λ           {} overturns per year",
                short_number(rate.annual_rate)
            );
            outln!(
                "return      {} years",
                short_number(rate.return_period_years())
            );
            for (t, p) in &survival {
                outln!(
                    "survival    {} after {t} years (P(overturn) {})",
                    short_number(*p),
                    short_number(1.0 - p)
                );
            }
            outln!(
                "tails       {:.2} % of λ comes from beyond the curve's levels (power-law continuation)",
                100.0 * rate.extrapolated_fraction
            );
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
