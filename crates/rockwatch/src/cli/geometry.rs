//! `rockwatch geometry`: a rock's mass properties, resting contact and planar body per
//! direction from its closed mesh (docs/meshes.md).

use std::path::PathBuf;

use anyhow::Context;
use rockwatch_core::mesh::contact::{
    parse_azimuths, DirectionBody, RestingContact, RockGeometry, UpAxis,
    DEFAULT_CONTACT_TOLERANCE_M,
};

use super::OutputFormat;

/// The planar rigid body of each toppling direction of a rock from its closed triangle mesh
/// (OBJ, PLY ASCII/binary little-endian, STL ASCII/binary; metres).
///
/// Volume, centre of mass and inertia by the divergence theorem (unit density: ρ does not
/// depend on it); the rock rests on the stable convex-hull facet nearest to --up, widened to
/// every vertex within --contact-tolerance of its plane. For each azimuth (degrees clockwise
/// from the mesh's north axis: +y when up is z, see docs/meshes.md for the others): the
/// horizontal distances b₊, b₋ from the centre of mass to the extreme contact points along
/// ±direction, the height h of the centre of mass, the radius of gyration ρ about the
/// horizontal axis perpendicular to the direction, and α± = atan(b±/h).
#[derive(Debug, clap::Args)]
pub struct GeometryArgs {
    /// The closed mesh: .obj, .ply or .stl (coordinates in metres).
    #[arg(long, value_name = "FILE")]
    mesh: PathBuf,
    /// The mesh axis pointing (roughly) up: x, y or z, optionally signed (-z).
    #[arg(long, default_value = "z", value_name = "AXIS")]
    up: String,
    /// Directions: FROM:TO:STEP (degrees, TO excluded) or a list A,B,C.
    #[arg(long, default_value = "0:360:15", value_name = "FROM:TO:STEP|LIST")]
    azimuths: String,
    /// Vertices within this distance of the resting facet's plane touch the ground (m).
    #[arg(long = "contact-tolerance", default_value_t = DEFAULT_CONTACT_TOLERANCE_M, value_name = "M")]
    contact_tolerance: f64,
    /// Output format on stdout.
    #[arg(long, value_enum, default_value_t = OutputFormat::Text)]
    format: OutputFormat,
}

/// The JSON of `rockwatch geometry --format json`.
#[derive(Debug, serde::Serialize)]
struct GeometryJson<'a> {
    mesh: String,
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
}

pub fn run(args: GeometryArgs) -> anyhow::Result<()> {
    let up = UpAxis::parse(&args.up).map_err(|e| anyhow::anyhow!("--up: {e}"))?;
    let azimuths =
        parse_azimuths(&args.azimuths).map_err(|e| anyhow::anyhow!("--azimuths: {e}"))?;
    if !(args.contact_tolerance.is_finite() && args.contact_tolerance >= 0.0) {
        anyhow::bail!(
            "--contact-tolerance must be a finite length ≥ 0 (m), got {}",
            args.contact_tolerance
        );
    }
    let rock = RockGeometry::read(&args.mesh)?;
    let rest = rock
        .rest(up, args.contact_tolerance)
        .with_context(|| format!("resting contact of {}", args.mesh.display()))?;
    let directions: Vec<DirectionBody> = azimuths.iter().map(|&az| rest.direction(az)).collect();
    match args.format {
        OutputFormat::Json => {
            let json = GeometryJson {
                mesh: args.mesh.display().to_string(),
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
            };
            outln!("{}", serde_json::to_string_pretty(&json)?);
        }
        OutputFormat::Text => out!("{}", text(&args, up, &rest, &directions)),
    }
    Ok(())
}

fn text(args: &GeometryArgs, up: UpAxis, rest: &RestingContact, dirs: &[DirectionBody]) -> String {
    use std::fmt::Write;
    let mut out = String::new();
    let m = &rest.mass;
    let v3 = |v: [f64; 3]| format!("({:.4}, {:.4}, {:.4})", v[0], v[1], v[2]);
    let _ = writeln!(out, "mesh        {}", args.mesh.display());
    let _ = writeln!(out, "volume      {:.6} m³", m.volume_m3);
    let _ = writeln!(out, "com         {} m", v3(m.com_m));
    let _ = writeln!(
        out,
        "resting     facet of {} hull vertices, {} contact vertices within {} m; vertical {} \
         ({:.2}° from {}), north {}",
        rest.facet_vertices,
        rest.contact_vertices(),
        rest.tolerance_m,
        v3(rest.up),
        rest.tilt_deg,
        up.as_str(),
        v3(rest.north)
    );
    let _ = writeln!(out, "com height  {:.4} m", rest.h_m);
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
    out
}
