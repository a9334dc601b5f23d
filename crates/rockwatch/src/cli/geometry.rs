//! `rockwatch geometry`: a rock's mass properties, resting contact and planar body per
//! direction from its closed mesh (docs/meshes.md).

use std::path::PathBuf;

use rockwatch_core::mesh::cap::Cap;
use rockwatch_core::mesh::contact::{
    parse_azimuths, weakest_side, DirectionBody, RestingContact, SENSITIVITY_TOLERANCES_M,
};

use rockwatch::number_text::short_number;
use rockwatch::rock_plots::{plot_alpha_rose, plot_section};

use super::rock_flags::{describe_cap, LoadedMesh, MeshFlags};
use super::OutputFormat;

/// The planar rigid body of each toppling direction of a rock from its closed triangle mesh
/// (OBJ, PLY ASCII/binary little-endian, STL ASCII/binary; metres).
///
/// Volume, centre of mass and inertia by the divergence theorem (unit density: ρ does not
/// depend on it); the rock rests on the stable convex-hull facet nearest to --up (widened to
/// every vertex within --contact-tolerance of its plane, default 0). For each azimuth (degrees
/// clockwise from the mesh's north axis: +y when up is z, see docs/meshes.md for the others):
/// the lever arms b₊, b₋ — the distance from the centre of mass's projection to the edge of
/// the support polygon along ±direction, the edge the rock tips about — the height h of the
/// centre of mass, the radius of gyration ρ about the horizontal axis perpendicular to the
/// direction, and α± = atan(b±/h). Then the weakest direction and how the bodies change with
/// the contact tolerance (0, 1, 2, 5 mm).
#[derive(Debug, clap::Args)]
#[command(mut_arg("mesh", |a| a.required(true)))]
pub struct GeometryArgs {
    /// The mesh and how it rests (--mesh, --up, --contact-tolerance, --cap).
    #[command(flatten)]
    mesh: MeshFlags,
    /// Directions: FROM:TO:STEP (degrees, TO excluded) or a list A,B,C.
    #[arg(long, default_value = "0:360:15", value_name = "FROM:TO:STEP|LIST")]
    azimuths: String,
    /// Output format on stdout.
    #[arg(long, value_enum, default_value_t = OutputFormat::Text)]
    format: OutputFormat,
    /// Draw α against azimuth (every degree; polar, north up, the weakest direction marked):
    /// PNG if OUT ends in .png, SVG if it ends in .svg.
    #[arg(long = "polar-plot", value_name = "OUT.svg|OUT.png")]
    polar_plot: Option<PathBuf>,
    /// Draw the rock's section in the vertical plane of --section through its centre of mass,
    /// with the contact chord, the pivots and the centre of mass (.svg or .png).
    #[arg(long = "section-plot", value_name = "OUT.svg|OUT.png")]
    section_plot: Option<PathBuf>,
    /// The direction of --section-plot (degrees clockwise from the mesh's north axis);
    /// default: the weakest direction of --azimuths.
    #[arg(long, value_name = "DEG", requires = "section_plot")]
    section: Option<f64>,
}

/// The JSON of `rockwatch geometry --format json`.
#[derive(Debug, serde::Serialize)]
struct GeometryJson<'a> {
    mesh: String,
    /// What --cap closed (null: the mesh was closed).
    cap: Option<&'a Cap>,
    volume_m3: f64,
    com_m: [f64; 3],
    /// Inertia tensor about the centre of mass, mesh axes, unit density (m⁵ = kg·m² per kg/m³).
    inertia_unit_density: [[f64; 3]; 3],
    up_axis: &'static str,
    /// True vertical, east and north (unit vectors, mesh coordinates).
    vertical: [f64; 3],
    east: [f64; 3],
    north: [f64; 3],
    tilt_deg: f64,
    contact_tolerance_m: f64,
    contact_vertices: usize,
    directions: &'a [DirectionBody],
    /// The smallest α of the directions listed.
    weakest: Weakest,
    /// The bodies at each tolerance of [`SENSITIVITY_TOLERANCES_M`] (and the one in force).
    tolerance_sensitivity: &'a [Sensitivity],
}

/// The direction and side with the smallest α (the least acceleration to lift off).
#[derive(Debug, Clone, Copy, serde::Serialize)]
struct Weakest {
    /// Azimuth (degrees clockwise from the mesh's north axis) towards which the rock tips.
    azimuth_deg: f64,
    alpha_deg: f64,
    /// The uplift acceleration of that tip, g·tan α (m/s²).
    uplift_mps2: f64,
}

/// The directions' bodies at one contact tolerance, against the resting facet alone.
#[derive(Debug, Clone, Copy, serde::Serialize)]
struct Sensitivity {
    tolerance_m: f64,
    contact_vertices: usize,
    weakest: Weakest,
    /// The largest ratio b±(tolerance) / b±(0) over the directions and sides.
    b_ratio_max: f64,
}

/// The weakest side of the directions `dirs` (non-empty: `--azimuths` gives at least one).
fn weakest(dirs: &[DirectionBody]) -> Weakest {
    let (azimuth_deg, alpha_deg) = weakest_side(
        dirs.iter()
            .map(|d| (d.azimuth_deg, d.alpha_plus_deg, d.alpha_minus_deg)),
    )
    .unwrap_or((0.0, f64::INFINITY));
    Weakest {
        azimuth_deg,
        alpha_deg,
        uplift_mps2: rockwatch_core::STANDARD_GRAVITY_MPS2 * alpha_deg.to_radians().tan(),
    }
}

/// The bodies of `azimuths` at each sensitivity tolerance and at `in_force` (m), in increasing
/// tolerance.
fn sensitivity(rest: &RestingContact, azimuths: &[f64], in_force: f64) -> Vec<Sensitivity> {
    let mut tolerances = SENSITIVITY_TOLERANCES_M.to_vec();
    if !tolerances.contains(&in_force) {
        tolerances.push(in_force);
        tolerances.sort_by(f64::total_cmp);
    }
    let bodies = |tol: f64| -> Vec<DirectionBody> {
        azimuths
            .iter()
            .map(|&az| rest.direction_at(az, tol))
            .collect()
    };
    let facet = bodies(0.0);
    tolerances
        .into_iter()
        .map(|tol| {
            let dirs = bodies(tol);
            let b_ratio_max = dirs
                .iter()
                .zip(&facet)
                .flat_map(|(d, f)| [d.b_plus_m / f.b_plus_m, d.b_minus_m / f.b_minus_m])
                .fold(1.0, f64::max);
            Sensitivity {
                tolerance_m: tol,
                contact_vertices: rest.patch(tol).len(),
                weakest: weakest(&dirs),
                b_ratio_max,
            }
        })
        .collect()
}

pub fn run(args: GeometryArgs) -> anyhow::Result<()> {
    let azimuths =
        parse_azimuths(&args.azimuths).map_err(|e| anyhow::anyhow!("--azimuths: {e}"))?;
    let Some(mesh) = args.mesh.load()? else {
        anyhow::bail!("give --mesh FILE");
    };
    let (rock, rest, up) = (&mesh.rock, &mesh.rest, mesh.up);
    let directions: Vec<DirectionBody> = azimuths.iter().map(|&az| rest.direction(az)).collect();
    let sensitivity = sensitivity(rest, &azimuths, rest.tolerance_m);
    let weakest_listed = weakest(&directions);
    let name = mesh.path.display().to_string();
    if let Some(path) = &args.polar_plot {
        // Every degree; the weakest of that rose is marked (it may fall between --azimuths).
        let rose: Vec<DirectionBody> = (0..360).map(|k| rest.direction(f64::from(k))).collect();
        let w = weakest(&rose);
        plot_alpha_rose(path, &name, &rose, (w.azimuth_deg, w.alpha_deg))?;
    }
    if let Some(path) = &args.section_plot {
        let az = args.section.unwrap_or(weakest_listed.azimuth_deg);
        if !az.is_finite() {
            anyhow::bail!("--section must be a finite number of degrees, got {az}");
        }
        let body = rest.direction(az);
        plot_section(path, &name, &rock.section(rest, az), &body)?;
    }
    match args.format {
        OutputFormat::Json => {
            let json = GeometryJson {
                mesh: name.clone(),
                cap: mesh.cap.as_ref(),
                volume_m3: rest.mass.volume_m3,
                com_m: rest.mass.com_m,
                inertia_unit_density: rest.mass.inertia_com,
                up_axis: up.as_str(),
                vertical: rest.up,
                east: rest.east,
                north: rest.north,
                tilt_deg: rest.tilt_deg,
                contact_tolerance_m: rest.tolerance_m,
                contact_vertices: rest.contact_vertices(),
                directions: &directions,
                weakest: weakest_listed,
                tolerance_sensitivity: &sensitivity,
            };
            outln!("{}", serde_json::to_string_pretty(&json)?);
        }
        OutputFormat::Text => out!("{}", text(&mesh, &directions, &sensitivity)),
    }
    Ok(())
}

fn text(mesh: &LoadedMesh, dirs: &[DirectionBody], sensitivity: &[Sensitivity]) -> String {
    use std::fmt::Write;
    let mut out = String::new();
    let (rest, up) = (&mesh.rest, mesh.up);
    let m = &rest.mass;
    // A coordinate 10¹² times smaller than the vector's largest is rounding noise of the
    // integrals (the bundled wedge's com y: -1.291e-18 m): printed as 0.
    let v3 = |v: [f64; 3]| {
        let scale = v.iter().fold(0.0_f64, |a, x| a.max(x.abs()));
        let v = v.map(|x| if x.abs() <= 1e-12 * scale { 0.0 } else { x });
        format!("({})", v.map(short_number).join(", "))
    };
    let _ = writeln!(out, "mesh        {}", mesh.path.display());
    if let Some(cap) = &mesh.cap {
        let _ = writeln!(out, "capped      {}", describe_cap(cap));
    }
    let _ = writeln!(out, "volume      {} m³", short_number(m.volume_m3));
    let _ = writeln!(out, "com         {} m", v3(m.com_m));
    let _ = writeln!(
        out,
        "resting     facet of {} hull vertices, {} contact vertices within {} m; vertical {} \
         ({}° from {}), north {}",
        rest.facet_vertices,
        rest.contact_vertices(),
        short_number(rest.tolerance_m),
        v3(rest.up),
        short_number(rest.tilt_deg),
        up.as_str(),
        v3(rest.north)
    );
    let _ = writeln!(out, "com height  {} m", short_number(rest.h_m));
    let _ = writeln!(
        out,
        "{:>8} {:>9} {:>9} {:>8} {:>8} {:>8} {:>8}",
        "az(°)", "b+(m)", "b-(m)", "h(m)", "rho(m)", "α+(°)", "α-(°)"
    );
    for d in dirs {
        let _ = writeln!(
            out,
            "{:>8.2} {:>9.4} {:>9.4} {:>8.4} {:>8.4} {:>8.3} {:>8.3}",
            d.azimuth_deg,
            d.b_plus_m,
            d.b_minus_m,
            d.h_m,
            d.rho_m,
            d.alpha_plus_deg,
            d.alpha_minus_deg
        );
    }
    let w = weakest(dirs);
    let _ = writeln!(
        out,
        "weakest     towards {}°: α = {}°, uplift at {} m/s² ({} g) (of the directions listed)",
        short_number(w.azimuth_deg),
        short_number(w.alpha_deg),
        short_number(w.uplift_mps2),
        short_number(w.uplift_mps2 / rockwatch_core::STANDARD_GRAVITY_MPS2)
    );
    let _ = writeln!(
        out,
        "contact tolerance sensitivity (b± against the resting facet alone, 0 mm):"
    );
    let _ = writeln!(
        out,
        "{:>8} {:>9} {:>12} {:>10} {:>9}",
        "tol(mm)", "vertices", "weakest α(°)", "towards(°)", "max b×"
    );
    for s in sensitivity {
        let _ = writeln!(
            out,
            "{:>8.1} {:>9} {:>12.3} {:>10.2} {:>9.3}{}",
            s.tolerance_m * 1e3,
            s.contact_vertices,
            s.weakest.alpha_deg,
            s.weakest.azimuth_deg,
            s.b_ratio_max,
            if s.tolerance_m == rest.tolerance_m {
                "  (in force)"
            } else {
                ""
            }
        );
    }
    out
}
