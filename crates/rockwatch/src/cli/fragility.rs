//! `rockwatch fragility`: the overturning fragility of one rock from a suite of records
//! (multiple-stripe analysis, docs/fragility.md).

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{bail, Context};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use rockwatch::fragility::plots::write_plots;
use rockwatch::fragility::report::{fragility_json, text_summary, write_runs_csv};
use rockwatch::number_text::{block_label, short_number};
use rockwatch::units::AccelUnits;
use rockwatch_core::catalogue::Catalogue;
use rockwatch_core::dynamics::{BlockOptions, BlockParams};
use rockwatch_core::fragility::HorizontalDefinition;
use rockwatch_core::fragility::{
    analyse, log_spaced, prepare, run_simulations, FragilityConfig, FragilityRecord, Im, Intensity,
    RockDirection, RockMember, DEFAULT_BOOTSTRAP, DEFAULT_SURFACE_GRID, DEFAULT_T_EXTRA_S,
};
use rockwatch_core::mesh::contact::{parse_azimuths, weakest_side};
use rockwatch_core::record::{read_at2, At2, Component, Record};
use rockwatch_core::STANDARD_GRAVITY_MPS2;
use serde_json::json;

use super::rock_flags::{Friction, FrictionFlags, GeometryFlags, MeshPlan, RockPlan};
use super::OutputFormat;

/// Fit the overturning fragility of one rock from a suite of ground-motion records by
/// multiple-stripe analysis: every record is scaled to each stripe of an IM (--stripes) or by
/// each factor (--scales), the rock is simulated under every scaled record (for every ensemble
/// member and incidence angle), and a lognormal fragility P(overturn | IM) = Φ(ln(IM/θ)/β) is
/// fitted by maximum likelihood for every --im (binomial likelihood over the stripes for the
/// stripe IM, over the (record, scale) groups for the others), with 95 % percentile bootstrap
/// intervals from resampling the records. The IMs are ranked by β; a two-IM probit surface
/// P = Φ(c0 + c1 ln IM1 + c2 ln IM2) is fitted too (--surface).
///
/// Records are single horizontal components (AT2 in g, CSV `t,ax` in m/s²), or with
/// --horizontal-im rotd50|rotd100|gm pairs of AT2 components of one event and station, whose
/// PGA, PGV, PGD, SA(T) and PGV/PGA are in that definition (docs/fragility.md §1). --azimuths gives
/// the incidence angles φ of each record in the rock's frame: the rock's direction of azimuth
/// ψ sees the record times cos(φ − ψ). A planar block's frame is its +x axis, and the default
/// 0,180 applies each record along +x and along −x (both pivots: an asymmetric rock topples
/// more easily one way). A meshed rock's frame is north (the mesh's north axis with --mesh,
/// true north with a catalogue entry): its directions and the incidences are azimuths, and
/// the default 0:360:30 spreads the records over all azimuths, whatever its directions. A
/// vertical record is applied as it is (scaled, not projected).
///
/// Files written to --out: fragility.json, runs.csv, fragility_<IM>.svg/png and
/// surface_<IM1>_<IM2>.svg/png. Results are identical for a given --seed whatever --threads.
#[derive(Debug, clap::Args)]
pub struct FragilityArgs {
    /// Catalogue entry to use (with --catalogue): its geometry, friction and uncertain ranges.
    #[arg(long, value_name = "ID", requires = "catalogue", conflicts_with_all = ["width", "half_diagonal", "b_plus", "mesh", "mu_s"])]
    pbr: Option<String>,
    /// Catalogue file (TOML or CSV) holding --pbr.
    #[arg(long, value_name = "FILE", requires = "pbr")]
    catalogue: Option<PathBuf>,
    /// The rock: a rectangle, a general planar body or a mesh (with --mu-s).
    #[command(flatten)]
    geometry: GeometryFlags,
    /// With --mesh: the toppling directions, degrees clockwise from the mesh's north axis: a
    /// list, or FROM:TO:STEP (TO excluded). Default: every 15°.
    #[arg(
        long,
        value_name = "DEG,…|FROM:TO:STEP",
        requires = "mesh",
        default_value = "0:360:15"
    )]
    directions: String,
    /// Friction and impact (with the geometry flags).
    #[command(flatten)]
    friction: FrictionFlags,
    /// The records: a directory (every .AT2 and .csv file in it, by name, except those given
    /// as --vertical-records) or a comma-separated list of files. An AT2 record whose header
    /// names a vertical component (UP, V, DWN, …) is never taken as horizontal: without
    /// --vertical-records it is paired with the records of the same event and station.
    #[arg(
        long,
        value_name = "DIR|FILE,…",
        value_delimiter = ',',
        required = true
    )]
    records: Vec<PathBuf>,
    /// Vertical components: either one file per record, in the order of --records (sorted
    /// by name for a directory), or NAME=FILE pairs naming the horizontal record's file name.
    #[arg(
        long = "vertical-records",
        value_name = "FILE,…|NAME=FILE,…",
        value_delimiter = ','
    )]
    vertical_records: Vec<String>,
    /// Horizontal-component definition of PGA, PGV, PGD, SA(T) and PGV/PGA: `component` (each
    /// record file is one component, applied along each incidence) or, from pairs of
    /// horizontal components, `rotd50` (the median over rotation angles of the rotated
    /// component's peak, Boore 2010: the definition of NGA-West2 and most OpenQuake GMPEs),
    /// `rotd100` or `gm` (geometric mean of the two as recorded). With a pair definition the
    /// AT2 records of one event and station (their headers) are one record: the incidence φ
    /// puts the first component along φ and the second along φ + 90°. The other IMs are of the
    /// first component. fragility.json says which definition each IM has.
    #[arg(long = "horizontal-im", value_name = "DEF", default_value = "component", value_parser = parse_definition)]
    horizontal_im: HorizontalDefinition,
    /// IMs to fit, comma-separated: PGA, PGV, PGD, CAV, ARIAS, SMA, EDA, EPV, A_RMS, IC,
    /// PGV/PGA, D5_75, D5_95, T5, T75, T95, TP, SA(T), ASI(T1-T2), SI(T1-T2), VSI(T1-T2)
    /// (SI units: m/s2, m/s, m, s). Scale-invariant IMs (PGV/PGA, TP, the Husid times and
    /// durations) only enter the surface.
    #[arg(long, value_name = "IM,…", value_delimiter = ',', required = true)]
    im: Vec<String>,
    /// Stripes IM:LO:HI:N: N levels of IM from LO to HI, log-spaced (SI units of the IM; an
    /// acceleration may be written in g with a suffix, e.g. PGA:0.05g:1.5g:20).
    #[arg(
        long,
        value_name = "IM:LO:HI:N",
        conflicts_with = "scales",
        required_unless_present = "scales"
    )]
    stripes: Option<String>,
    /// Scale factors A:B:N: N factors from A to B, log-spaced, applied to every record.
    #[arg(long, value_name = "A:B:N")]
    scales: Option<String>,
    /// Ensemble members of the --pbr entry (Latin hypercube over its uncertain parameters,
    /// the catalogue's seed); default: the entry's own `ensemble` (1 = nominal).
    #[arg(long, value_name = "K")]
    ensemble: Option<usize>,
    /// Incidence angles φ (degrees) of the records in the rock's frame: a list, or
    /// FROM:TO:STEP (TO excluded). The rock's direction ψ sees the record times cos(φ − ψ).
    /// Default: 0,180 for a planar block (its +x axis and back); 0:360:30 (azimuths from north)
    /// for a meshed rock.
    #[arg(long, value_name = "DEG,…|FROM:TO:STEP")]
    azimuths: Option<String>,
    /// The two IMs of the surface, IM1,IM2 (of --im); default PGA,PGV/PGA when both are
    /// listed, else the first two IMs.
    #[arg(long, value_name = "IM1,IM2", value_delimiter = ',')]
    surface: Option<Vec<String>>,
    /// Bootstrap replicates (0: no confidence intervals).
    #[arg(long, default_value_t = DEFAULT_BOOTSTRAP, value_name = "N")]
    bootstrap: usize,
    /// Seed of the bootstrap (u64).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Worker threads (0 = all cores). The results do not depend on it.
    #[arg(long, default_value_t = 0, value_name = "N")]
    threads: usize,
    /// Most seconds of free vibration after each record (runs stop earlier once the block is
    /// at rest or has fallen).
    #[arg(long = "t-extra", default_value_t = DEFAULT_T_EXTRA_S, value_name = "S")]
    t_extra: f64,
    /// Output directory (created if missing).
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
    /// Skip the SVG/PNG plots.
    #[arg(long = "no-plots")]
    no_plots: bool,
    /// Output on stdout: text (table) or json (the content of fragility.json).
    #[arg(long, value_enum, default_value_t = OutputFormat::Text)]
    format: OutputFormat,
    /// Unit of accelerations (PGA, SA(T), SMA, EDA, A_RMS) in the text table and the plots:
    /// m/s2 or g (9.80665 m/s²). fragility.json and runs.csv stay in SI units (m/s2) either
    /// way, with the unit in their `unit` fields and column headers.
    #[arg(long, value_enum, default_value_t = AccelUnits::Mps2, value_name = "g|m/s2")]
    units: AccelUnits,
}

fn parse_number(text: &str, what: &str, unit_g: bool) -> anyhow::Result<f64> {
    let t = text.trim();
    let (body, factor) = match t.strip_suffix(['g', 'G']) {
        Some(b) if unit_g => (b, STANDARD_GRAVITY_MPS2),
        Some(_) => bail!("{what}: {t:?}: a g suffix needs an acceleration IM"),
        None => (t, 1.0),
    };
    let v: f64 = body
        .parse()
        .with_context(|| format!("{what}: {t:?} is not a number"))?;
    Ok(v * factor)
}

fn parse_definition(text: &str) -> Result<HorizontalDefinition, String> {
    HorizontalDefinition::parse(text)
        .ok_or_else(|| format!("{text:?}: expected component, rotd50, rotd100 or gm"))
}

fn parse_count(text: &str, what: &str) -> anyhow::Result<usize> {
    let n: usize = text
        .trim()
        .parse()
        .with_context(|| format!("{what}: {text:?} is not a count"))?;
    if !(1..=10_000).contains(&n) {
        bail!("{what}: the count must be 1 to 10000, got {n}");
    }
    Ok(n)
}

fn range(lo: f64, hi: f64, n: usize, what: &str) -> anyhow::Result<Vec<f64>> {
    if !(lo.is_finite() && hi.is_finite() && lo > 0.0 && hi >= lo) {
        bail!("{what}: need 0 < LO ≤ HI, got {lo} and {hi}");
    }
    if n > 1 && hi == lo {
        bail!("{what}: {n} levels need LO < HI");
    }
    Ok(log_spaced(lo, hi, n))
}

/// The rock of the analysis: its members, a label for people and its description for
/// fragility.json.
struct Rock {
    members: Vec<RockMember>,
    label: String,
    info: serde_json::Value,
    /// A meshed rock: directions and incidences are azimuths from north (else from the
    /// block's +x axis).
    meshed: bool,
}

impl Rock {
    /// The default incidences of the rock's frame (see [`FragilityArgs::azimuths`]).
    fn default_incidences(&self) -> &'static str {
        if self.meshed {
            "0:360:30"
        } else {
            "0,180"
        }
    }
}

/// One direction's planar body for fragility.json.
fn direction_json(azimuth_deg: f64, p: &BlockParams) -> serde_json::Value {
    json!({
        "azimuth_deg": azimuth_deg, "b_plus_m": p.b_plus_m, "b_minus_m": p.b_minus_m,
        "com_height_m": p.com_height_m, "rho_m": p.rho_m,
        "alpha_plus_deg": p.plus.alpha_rad.to_degrees(), "alpha_minus_deg": p.minus.alpha_rad.to_degrees(),
    })
}

/// A meshed rock's planar directions (azimuth of each body's +x axis in degrees, and the body)
/// in words: how many, and its weakest side — the azimuth it tips towards, α and the uplift
/// acceleration g·tan α (m/s²) — rather than one direction's body as if it were the rock.
fn directions_label<'a>(
    directions: impl Iterator<Item = (f64, &'a BlockParams)> + Clone,
) -> String {
    let count = directions.clone().count();
    let weakest = weakest_side(directions.map(|(azimuth_deg, p)| {
        (
            azimuth_deg,
            p.plus.alpha_rad.to_degrees(),
            p.minus.alpha_rad.to_degrees(),
        )
    }));
    match weakest {
        Some((towards, alpha_deg)) => format!(
            "{count} direction{} (a planar body each, docs/meshes.md), weakest towards {}°: α = \
             {}°, uplift at {} m/s²",
            if count == 1 { "" } else { "s" },
            short_number(towards),
            short_number(alpha_deg),
            short_number(STANDARD_GRAVITY_MPS2 * alpha_deg.to_radians().tan())
        ),
        None => "no direction".to_string(),
    }
}

/// The SHA-256 of a file, lower-case hex: the exact mesh a result used.
fn file_sha256(path: &Path) -> anyhow::Result<String> {
    use sha2::{Digest, Sha256};
    let mut file =
        std::fs::File::open(path).with_context(|| format!("reading {}", path.display()))?;
    let mut hasher = Sha256::new();
    std::io::copy(&mut file, &mut hasher).with_context(|| format!("reading {}", path.display()))?;
    Ok(hasher
        .finalize()
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect())
}

/// The rock's members: from the catalogue (ensemble) or the rock flags.
fn rock(args: &FragilityArgs) -> anyhow::Result<Rock> {
    if let (Some(id), Some(path)) = (&args.pbr, &args.catalogue) {
        let catalogue = Catalogue::load(path)?;
        let pbr = catalogue
            .get(id)
            .with_context(|| format!("{}: no pbr {id:?}", path.display()))?;
        let k = args.ensemble.unwrap_or(pbr.ensemble_size());
        if k == 0 {
            bail!("--ensemble must be at least 1");
        }
        if k > 1 && !pbr.has_uncertainty() {
            bail!(
                "pbr {id:?} has no uncertain parameter: an ensemble of {k} would repeat the \
                 nominal rock (use --ensemble 1)"
            );
        }
        if let Some(mesh) = pbr.mesh() {
            if let (Some(body), Some((nominal, drawn))) = (mesh.body(), pbr.rigid_members(k)) {
                return rigid_catalogue_rock(pbr, path, mesh, body, nominal, drawn);
            }
        }
        // Every toppling direction of the rock: one for a planar entry, at 0 in its own frame;
        // one per true azimuth of a meshed rock, in the frame of north. Member i is one rock in
        // every direction.
        let directions = pbr.directions_sized(k)?;
        let mesh = pbr.mesh();
        let frame_deg = |azimuth: f64| {
            if mesh.is_some() {
                azimuth.rem_euclid(360.0)
            } else {
                0.0
            }
        };
        let members: Vec<RockMember> = (0..k)
            .map(|i| RockMember::Planar {
                directions: directions
                    .iter()
                    .map(|d| RockDirection {
                        azimuth_deg: frame_deg(d.azimuth.degrees()),
                        params: if k > 1 { d.members[i] } else { d.nominal },
                    })
                    .collect(),
            })
            .collect();
        // A meshed rock is its directions, not its first direction's body.
        let geometry = match mesh {
            Some(m) => format!(
                "{}: {}",
                m.path.display(),
                directions_label(
                    directions
                        .iter()
                        .map(|d| (frame_deg(d.azimuth.degrees()), &d.nominal))
                )
            ),
            None => pbr
                .nominal()
                .geometry_label_with(short_number, short_number),
        };
        let label = format!(
            "{id} ({}), {geometry}, {} member{}",
            pbr.name(),
            k,
            if k == 1 { "" } else { "s (Latin hypercube)" }
        );
        let mut info = json!({
            "pbr": id, "catalogue": path.display().to_string(), "ensemble": k,
            "seed": pbr.seed(), "model": "2d",
            "directions": directions
                .iter()
                .map(|d| direction_json(d.azimuth.degrees(), &d.nominal))
                .collect::<Vec<_>>(),
        });
        if let Some(m) = mesh {
            info["mesh"] = json!(m.path.display().to_string());
            info["mesh_sha256"] = json!(file_sha256(&m.path)?);
            info["cap"] = json!(m.cap);
        }
        return Ok(Rock {
            members,
            label,
            info,
            meshed: mesh.is_some(),
        });
    }
    if args.ensemble.is_some_and(|k| k > 1) {
        bail!("--ensemble needs a catalogue entry with uncertain parameters (--pbr, --catalogue)");
    }
    let params = match args.geometry.plan(&args.friction)? {
        RockPlan::Planar(params) => params,
        RockPlan::Mesh(mesh) => {
            if mesh.model == super::rock_flags::Model::ThreeD {
                return rigid_mesh_rock(&mesh);
            }
            return mesh_rock(args, &mesh);
        }
    };
    let label = block_label(&params);
    let info = json!({
        "b_plus_m": params.b_plus_m, "b_minus_m": params.b_minus_m,
        "com_height_m": params.com_height_m, "rho_m": params.rho_m,
        "mu_s": params.mu_s, "mu_k": params.mu_k, "restitution": params.restitution,
        "model": "2d",
    });
    Ok(Rock {
        members: vec![RockMember::planar(params)],
        label,
        info,
        meshed: false,
    })
}

/// The rock of `--mesh`: one member, one direction per `--directions` azimuth (from the mesh's
/// north axis, the frame of the incidences).
fn mesh_rock(args: &FragilityArgs, mesh: &MeshPlan) -> anyhow::Result<Rock> {
    let azimuths =
        parse_azimuths(&args.directions).map_err(|e| anyhow::anyhow!("--directions: {e}"))?;
    let directions = azimuths
        .iter()
        .map(|&azimuth| {
            Ok(RockDirection {
                azimuth_deg: azimuth.rem_euclid(360.0),
                params: mesh.block(azimuth)?,
            })
        })
        .collect::<anyhow::Result<Vec<_>>>()?;
    let Friction {
        mu_s,
        mu_k,
        restitution,
    } = mesh.friction;
    let loaded = &mesh.mesh;
    let label = format!(
        "{}: {}, μs = {}, μk = {}",
        loaded.path.display(),
        directions_label(directions.iter().map(|d| (d.azimuth_deg, &d.params))),
        short_number(mu_s),
        short_number(mu_k)
    );
    let info = json!({
        "mesh": loaded.path.display().to_string(), "mesh_sha256": file_sha256(&loaded.path)?,
        "cap": loaded.cap,
        "model": "2d", "up": loaded.up.as_str(), "contact_tolerance_m": loaded.rest.tolerance_m,
        "directions": directions
            .iter()
            .map(|d| direction_json(d.azimuth_deg, &d.params))
            .collect::<Vec<_>>(),
        "mu_s": mu_s, "mu_k": mu_k, "restitution": restitution,
    });
    Ok(Rock {
        members: vec![RockMember::Planar { directions }],
        label,
        info,
        meshed: true,
    })
}

/// The rock of `--mesh F --model 3d`: one 3-D rigid body in the mesh's frame (the frame of
/// the incidences: its north axis).
fn rigid_mesh_rock(mesh: &MeshPlan) -> anyhow::Result<Rock> {
    let Friction {
        mu_s,
        mu_k,
        restitution,
    } = mesh.friction;
    if restitution.is_some() {
        bail!("--restitution is not available with --model 3d (impacts are plastic, docs/rocking-3d.md)");
    }
    let body = mesh.body_3d()?;
    let loaded = &mesh.mesh;
    let label = format!(
        "{} in 3-D, μs = {}, μk = {}",
        loaded.path.display(),
        short_number(mu_s),
        short_number(mu_k)
    );
    let info = json!({
        "mesh": loaded.path.display().to_string(), "mesh_sha256": file_sha256(&loaded.path)?,
        "cap": loaded.cap, "model": "3d", "up": loaded.up.as_str(),
        "body": body_json(&body), "mu_s": mu_s, "mu_k": mu_k,
    });
    Ok(Rock {
        members: vec![RockMember::Rigid3d {
            body: std::sync::Arc::new(body),
            heading_deg: 0.0,
            mu_s,
            mu_k,
        }],
        label,
        info,
        meshed: true,
    })
}

/// The rock of a `model = "3d"` catalogue entry: its nominal rock, or its `drawn` members
/// (heading and friction from the entry's Latin hypercube), in the frame of north.
fn rigid_catalogue_rock(
    pbr: &rockwatch_core::catalogue::Pbr,
    path: &Path,
    mesh: &rockwatch_core::catalogue::MeshRock,
    body: &rockwatch_core::rocking3d::RockBody,
    nominal: rockwatch_core::catalogue::RigidMember,
    drawn: Vec<rockwatch_core::catalogue::RigidMember>,
) -> anyhow::Result<Rock> {
    let chosen = if drawn.is_empty() {
        vec![nominal]
    } else {
        drawn
    };
    let k = chosen.len();
    let shared = std::sync::Arc::new(body.clone());
    let members = chosen
        .iter()
        .map(|m| RockMember::Rigid3d {
            body: shared.clone(),
            heading_deg: m.heading_deg,
            mu_s: m.mu_s,
            mu_k: m.mu_k,
        })
        .collect();
    let label = format!(
        "{} ({}), {} in 3-D, {k} member{}",
        pbr.id(),
        pbr.name(),
        mesh.path.display(),
        if k == 1 { "" } else { "s (Latin hypercube)" }
    );
    let info = json!({
        "pbr": pbr.id(), "catalogue": path.display().to_string(), "ensemble": k,
        "seed": pbr.seed(), "model": "3d", "mesh": mesh.path.display().to_string(),
        "mesh_sha256": file_sha256(&mesh.path)?, "cap": mesh.cap, "body": body_json(body),
        "nominal": { "heading_deg": nominal.heading_deg, "mu_s": nominal.mu_s, "mu_k": nominal.mu_k },
    });
    Ok(Rock {
        members,
        label,
        info,
        meshed: true,
    })
}

/// A 3-D body for fragility.json: mass, height of the centre of mass, the weakest direction's
/// uplift angle and the hull's vertex count.
fn body_json(body: &rockwatch_core::rocking3d::RockBody) -> serde_json::Value {
    json!({
        "density_kg_m3": rockwatch_core::rocking3d::body::NOMINAL_DENSITY_KG_M3,
        "mass_kg": body.mass_kg(), "com_height_m": body.h_m(),
        "alpha_min_deg": body.weakest_direction().1.to_degrees(),
        "hull_vertices": body.vertices().len(),
    })
}

fn is_record_file(p: &Path) -> bool {
    p.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("at2") || e.eq_ignore_ascii_case("csv"))
}

fn file_name(p: &Path) -> String {
    p.file_name().map_or_else(
        || p.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    )
}

/// The header of an AT2 record file (None for another format).
fn at2_header(path: &Path) -> anyhow::Result<Option<At2>> {
    let is_at2 = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("at2"));
    Ok(if is_at2 { Some(read_at2(path)?) } else { None })
}

/// Reads the records and pairs the vertical components.
fn read_records(args: &FragilityArgs) -> anyhow::Result<Vec<FragilityRecord>> {
    let (named, ordered): (Vec<&String>, Vec<&String>) =
        args.vertical_records.iter().partition(|v| v.contains('='));
    if !named.is_empty() && !ordered.is_empty() {
        bail!(
            "--vertical-records: use either FILE,… (by order) or NAME=FILE,… (by name), not both"
        );
    }
    let vertical_names: Vec<String> = args
        .vertical_records
        .iter()
        .map(|v| file_name(Path::new(v.split_once('=').map_or(v.as_str(), |(_, f)| f))))
        .collect();
    let mut paths = Vec::new();
    for p in &args.records {
        if p.is_dir() {
            let mut in_dir: Vec<PathBuf> = std::fs::read_dir(p)
                .with_context(|| format!("cannot list {}", p.display()))?
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|f| is_record_file(f) && !vertical_names.contains(&file_name(f)))
                .collect();
            in_dir.sort();
            if in_dir.is_empty() {
                bail!("{}: no .AT2 or .csv record", p.display());
            }
            paths.extend(in_dir);
        } else {
            paths.push(p.clone());
        }
    }
    if !ordered.is_empty() && ordered.len() != paths.len() {
        bail!(
            "--vertical-records: {} files for {} records (give one per record, in order, or \
             NAME=FILE pairs)",
            ordered.len(),
            paths.len()
        );
    }
    // A vertical component among the records (a PEER header ending in UP, V, DWN, …) is never
    // taken as a horizontal one: without --vertical-records it is paired with the horizontal
    // records of the same event and station, else refused.
    let mut verticals = Vec::new();
    let mut horizontals = Vec::with_capacity(paths.len());
    for path in paths {
        match at2_header(&path)? {
            Some(at2) if at2.component() == Component::Vertical => {
                if !args.vertical_records.is_empty() {
                    bail!(
                        "{}: a vertical component (its AT2 header says {:?}) among the records: give it with --vertical-records, not as a record",
                        path.display(),
                        at2.header[1]
                    );
                }
                verticals.push((path, at2.station_key().to_string()));
            }
            header => horizontals.push((path, header.map(|h| h.station_key().to_string()))),
        }
    }
    if !ordered.is_empty() && args.horizontal_im != HorizontalDefinition::Component {
        bail!(
            "--vertical-records FILE,… (by order) with --horizontal-im {}: give NAME=FILE pairs \
             (NAME the first component's file) or let the AT2 headers pair them",
            args.horizontal_im.name()
        );
    }
    let pairs = horizontal_pairs(args, horizontals)?;
    let paths: Vec<(PathBuf, Option<String>)> = pairs
        .iter()
        .map(|(first, _, key)| (first.clone(), key.clone()))
        .collect();
    let mut records = Vec::with_capacity(paths.len());
    for (i, (path, key)) in paths.iter().enumerate() {
        let mut name = file_name(path);
        let mut record = Record::read(path)?;
        let mut second_horizontal_mps2 = None;
        if let Some(second) = &pairs[i].1 {
            let other = Record::read(second)?;
            if (other.dt_s - record.dt_s).abs() > 1e-9 * record.dt_s || other.len() != record.len()
            {
                bail!(
                    "{} and {}: the two horizontal components of a pair need the same sampling \
                     interval and length ({} s × {} and {} s × {})",
                    path.display(),
                    second.display(),
                    record.dt_s,
                    record.len(),
                    other.dt_s,
                    other.len()
                );
            }
            name = format!("{name}+{}", file_name(second));
            second_horizontal_mps2 = Some(other.horizontal_mps2);
        }
        let vertical = if !ordered.is_empty() {
            Some(PathBuf::from(ordered[i]))
        } else if let Some((v, _)) = verticals
            .iter()
            .find(|(_, vkey)| key.as_deref() == Some(vkey.as_str()))
        {
            eprintln!(
                "rockwatch: {} is the vertical component of {name} (the same event and station in their AT2 headers): paired",
                file_name(v)
            );
            Some(v.clone())
        } else {
            named
                .iter()
                .find(|v| v.split_once('=').is_some_and(|(n, _)| n == file_name(path)))
                .and_then(|v| v.split_once('=').map(|(_, f)| PathBuf::from(f)))
        };
        if let Some(v) = vertical {
            record.attach_vertical(&v)?;
        }
        records.push(FragilityRecord {
            name,
            record,
            second_horizontal_mps2,
        });
    }
    for (v, key) in &verticals {
        if !paths
            .iter()
            .any(|(_, k)| k.as_deref() == Some(key.as_str()))
        {
            bail!(
                "{}: a vertical component (its AT2 header names {key:?}) with no horizontal record of the same event and station: it cannot be used as a horizontal one; remove it, add its horizontal records, or pair it with --vertical-records NAME=FILE",
                v.display()
            );
        }
    }
    if records.is_empty() {
        bail!("no horizontal record among --records");
    }
    for v in &named {
        let n = v.split_once('=').map_or("", |(n, _)| n);
        // A pair is named by its first file.
        if !records
            .iter()
            .any(|r| r.name == n || r.name.starts_with(&format!("{n}+")))
        {
            bail!("--vertical-records {v:?}: no record named {n:?}");
        }
    }
    Ok(records)
}

/// The azimuth (degrees) an AT2 header names as its component (`…, 228`), or 0 for `N`/`NS`
/// and 90 for `E`/`EW`; None otherwise.
fn component_azimuth(at2: &At2) -> Option<f64> {
    let token = at2.header[1]
        .rsplit(',')
        .next()?
        .trim()
        .to_ascii_uppercase();
    let token = token.rsplit(['-', '_', ' ']).next()?.to_string();
    match token.as_str() {
        "N" | "NS" | "SN" => Some(0.0),
        "E" | "EW" | "WE" => Some(90.0),
        t => t.parse::<f64>().ok().filter(|a| a.is_finite()),
    }
}

/// A record's horizontal file, its second component's (a pair) and its AT2 station key.
type HorizontalPair = (PathBuf, Option<PathBuf>, Option<String>);

/// The horizontal records as (first, second, station key): one each with `--horizontal-im
/// component`; else the AT2 records of one event and station paired, the second 90°
/// clockwise of the first when their headers give azimuths (refused when they are not
/// orthogonal), else in file-name order.
fn horizontal_pairs(
    args: &FragilityArgs,
    horizontals: Vec<(PathBuf, Option<String>)>,
) -> anyhow::Result<Vec<HorizontalPair>> {
    if args.horizontal_im == HorizontalDefinition::Component {
        return Ok(horizontals
            .into_iter()
            .map(|(path, key)| (path, None, key))
            .collect());
    }
    let definition = args.horizontal_im.name();
    let mut pairs: Vec<HorizontalPair> = Vec::new();
    let mut used = vec![false; horizontals.len()];
    for i in 0..horizontals.len() {
        if used[i] {
            continue;
        }
        let (path, key) = &horizontals[i];
        let Some(key) = key else {
            bail!(
                "{}: --horizontal-im {definition} needs pairs of horizontal components: only AT2 \
                 records are paired (by the event and station of their headers)",
                path.display()
            );
        };
        let partners: Vec<usize> = (i + 1..horizontals.len())
            .filter(|&j| !used[j] && horizontals[j].1.as_deref() == Some(key.as_str()))
            .collect();
        let [j] = partners[..] else {
            bail!(
                "{}: --horizontal-im {definition} needs exactly two horizontal components of \
                 {key:?}, found {}",
                path.display(),
                partners.len() + 1
            );
        };
        used[i] = true;
        used[j] = true;
        let (a, b) = (&horizontals[i].0, &horizontals[j].0);
        let azimuths = (
            at2_header(a)?.as_ref().and_then(component_azimuth),
            at2_header(b)?.as_ref().and_then(component_azimuth),
        );
        let (first, second) = match azimuths {
            (Some(za), Some(zb)) => {
                let turn = (zb - za).rem_euclid(360.0);
                if (turn - 90.0).abs() < 1.0 {
                    (a, b)
                } else if (turn - 270.0).abs() < 1.0 {
                    (b, a)
                } else {
                    bail!(
                        "{} ({za}°) and {} ({zb}°): the two horizontal components of a pair must \
                         be orthogonal",
                        a.display(),
                        b.display()
                    );
                }
            }
            _ => (a, b),
        };
        eprintln!(
            "rockwatch: {} and {} are the horizontal components of {key:?}: one record, IMs in {definition}",
            file_name(first),
            file_name(second)
        );
        pairs.push((first.clone(), Some(second.clone()), Some(key.clone())));
    }
    Ok(pairs)
}

fn build_config(args: &FragilityArgs, rock: &Rock) -> anyhow::Result<FragilityConfig> {
    let ims: Vec<Im> = args
        .im
        .iter()
        .map(|n| n.parse::<Im>().context("--im"))
        .collect::<anyhow::Result<_>>()?;
    for (i, a) in ims.iter().enumerate() {
        if ims[..i].contains(a) {
            bail!("--im lists {} twice", a.name());
        }
    }
    let index_of = |name: &str| -> anyhow::Result<usize> {
        let im: Im = name.parse()?;
        ims.iter()
            .position(|x| *x == im)
            .with_context(|| format!("{} is not among --im", im.name()))
    };
    let intensity = if let Some(s) = &args.stripes {
        let parts: Vec<&str> = s.rsplitn(4, ':').collect();
        let [n, hi, lo, im] = parts[..] else {
            bail!("--stripes {s:?}: expected IM:LO:HI:N");
        };
        let im = index_of(im).context("--stripes")?;
        let g = ims[im].unit() == "m/s2";
        let levels = range(
            parse_number(lo, "--stripes", g)?,
            parse_number(hi, "--stripes", g)?,
            parse_count(n, "--stripes")?,
            "--stripes",
        )?;
        Intensity::Stripes { im, levels }
    } else if let Some(s) = &args.scales {
        let parts: Vec<&str> = s.split(':').collect();
        let [a, b, n] = parts[..] else {
            bail!("--scales {s:?}: expected A:B:N");
        };
        Intensity::Scales(range(
            parse_number(a, "--scales", false)?,
            parse_number(b, "--scales", false)?,
            parse_count(n, "--scales")?,
            "--scales",
        )?)
    } else {
        bail!("give --stripes IM:LO:HI:N or --scales A:B:N");
    };
    let surface = match &args.surface {
        Some(pair) => {
            let [a, b] = &pair[..] else {
                bail!("--surface needs two IMs, IM1,IM2");
            };
            Some((index_of(a)?, index_of(b)?))
        }
        None => {
            let pga = ims.iter().position(|x| *x == Im::Pga);
            let ratio = ims.iter().position(|x| *x == Im::PgvPga);
            match (pga, ratio) {
                (Some(a), Some(b)) => Some((a, b)),
                _ if ims.len() >= 2 => Some((0, 1)),
                _ => None,
            }
        }
    };
    let config = FragilityConfig {
        ims,
        intensity,
        members: rock.members.clone(),
        incidences_deg: parse_azimuths(
            args.azimuths
                .as_deref()
                .unwrap_or(rock.default_incidences()),
        )
        .map_err(|e| anyhow::anyhow!("--azimuths: {e}"))?,
        t_extra_s: args.t_extra,
        block: BlockOptions::default(),
        bootstrap: args.bootstrap,
        seed: args.seed,
        surface,
        surface_grid: DEFAULT_SURFACE_GRID,
        horizontal: args.horizontal_im,
    };
    config.validate()?;
    Ok(config)
}

/// Runs the analysis, writes the files, prints the summary.
pub fn run(args: FragilityArgs) -> anyhow::Result<()> {
    let rock = rock(&args)?;
    let config = build_config(&args, &rock)?;
    let records = read_records(&args)?;
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create {}", args.out.display()))?;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(args.threads)
        .build()
        .context("cannot start the worker threads")?;
    let started = Instant::now();
    let n_runs = config.n_runs(records.len());
    let show_bar = args.format == OutputFormat::Text && std::io::stderr().is_terminal();
    let bar = if show_bar {
        let bar = ProgressBar::with_draw_target(Some(n_runs as u64), ProgressDrawTarget::stderr());
        bar.set_style(
            ProgressStyle::with_template(
                "{spinner} [{elapsed_precise}] {bar:40} {pos}/{len} runs ({per_sec}, eta {eta})",
            )
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
        bar
    } else {
        ProgressBar::hidden()
    };
    let (prepared, runs, result) = pool.install(|| -> anyhow::Result<_> {
        let prepared = prepare(&config, &records)?;
        let runs = run_simulations(&config, &records, &prepared, &|| bar.inc(1));
        bar.finish_and_clear();
        let result = analyse(&config, &prepared, &runs);
        Ok((prepared, runs, result))
    })?;
    for run in runs.iter().filter(|r| r.error.is_some()).take(5) {
        eprintln!(
            "rockwatch: warning: {} × {}: {}",
            records[run.record].name,
            run.scale,
            run.error.as_deref().unwrap_or("")
        );
    }
    if result.n_failed > 0 || result.n_flight > 0 {
        eprintln!(
            "rockwatch: warning: {} runs failed and {} lost contact (free flight); both are left \
             out of the fits (runs.csv lists them; fragility.json's flight_runs and each IM's \
             median_if_flight_overturned bound the bias of leaving the flights out)",
            result.n_failed, result.n_flight
        );
    }
    let doc = fragility_json(rock.info, &config, &records, &prepared, &result);
    let json_path = args.out.join("fragility.json");
    std::fs::write(&json_path, serde_json::to_string_pretty(&doc)? + "\n")
        .with_context(|| format!("cannot write {}", json_path.display()))?;
    let csv_path = args.out.join("runs.csv");
    write_runs_csv(&csv_path, &config, &records, &prepared, &runs)
        .with_context(|| format!("cannot write {}", csv_path.display()))?;
    let mut written = vec![json_path, csv_path];
    if !args.no_plots {
        // The rock in words (its catalogue id and name, or its geometry and friction).
        written.extend(write_plots(
            &args.out,
            &rock.label,
            &config,
            &prepared,
            &runs,
            &result,
            args.units,
        )?);
    }
    match args.format {
        OutputFormat::Json => outln!("{}", serde_json::to_string_pretty(&doc)?),
        OutputFormat::Text => {
            out!(
                "{}",
                text_summary(
                    &rock.label,
                    &config,
                    &records,
                    &result,
                    &written,
                    args.units
                )
            );
            outln!(
                "time        {:.1} s on {} threads",
                started.elapsed().as_secs_f64(),
                pool.current_num_threads()
            );
        }
    }
    if result.ranking.is_empty() {
        bail!("no IM could be fitted (see not_fitted in fragility.json)");
    }
    Ok(())
}
