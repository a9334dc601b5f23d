//! `rockwatch simulate`: one block under one record.

use std::path::PathBuf;

use anyhow::{bail, Context};
use rockwatch::number_text::{block_label, short_number};
use rockwatch::plot::{plot_simulation, plot_simulation_3d};
use rockwatch_core::dynamics::BlockParams;
use rockwatch_core::ode::Tolerance;
use rockwatch_core::record::Record;
use rockwatch_core::rocking3d::{
    simulate_3d, simulate_3d_traced, GroundMotion3d, Simulation3dOptions, Trace3d,
};
use rockwatch_core::simulate::{simulate, SimulationOptions, Status, Summary, Trace};

use super::rock_flags::{FrictionFlags, GeometryFlags, MeshPlan, Model, RockPlan};
use super::OutputFormat;

/// Simulate one rigid block (rest, slide, rock, slide-rock, overturn) under a recorded or
/// synthetic ground motion, then `--t-extra` seconds of free vibration.
///
/// Sign convention: the record's horizontal acceleration is positive towards the block's +x
/// axis; θ > 0 is rotation about the right (+x) corner.
#[derive(Debug, clap::Args)]
pub struct SimulateArgs {
    /// Horizontal ground acceleration: PEER NGA .AT2 (values in g) or CSV with header
    /// `t,ax` or `t,ax,ay` (s, m/s², m/s²; uniform t).
    #[arg(long, value_name = "FILE")]
    record: PathBuf,
    /// Vertical ground acceleration (+ up) as a second single-component file (AT2 or CSV),
    /// same sampling interval and length as --record.
    #[arg(long, value_name = "FILE")]
    vertical: Option<PathBuf>,
    /// Multiply both components by this factor.
    #[arg(long, default_value_t = 1.0, value_name = "X")]
    scale: f64,
    /// The rock: a rectangle, a general planar body or a mesh.
    #[command(flatten)]
    geometry: GeometryFlags,
    /// With --mesh: the direction of the block's +x axis (and of the record's horizontal
    /// component), degrees clockwise from the mesh's north axis. With --model 3d: the azimuth
    /// of the record's horizontal component (positive values accelerate the ground towards
    /// it).
    #[arg(long, value_name = "DEG", requires = "mesh")]
    azimuth: Option<f64>,
    /// With --model 3d: a second horizontal component (AT2 or CSV, same sampling interval as
    /// --record), with --azimuth2.
    #[arg(long, value_name = "FILE", requires_all = ["azimuth2", "mesh"])]
    record2: Option<PathBuf>,
    /// The azimuth of --record2's component (degrees clockwise from the mesh's north).
    #[arg(long, value_name = "DEG", requires = "record2")]
    azimuth2: Option<f64>,
    /// Friction and impact.
    #[command(flatten)]
    friction: FrictionFlags,
    /// Seconds of zero ground motion simulated after the record ends (the record plus this
    /// may take at most 2·10⁷ integration steps).
    #[arg(long = "t-extra", default_value_t = 10.0, value_name = "S")]
    t_extra: f64,
    /// Relative tolerance of the integrator (absolute tolerance is 1e-3 of it, in rad and m).
    /// Default: the library's, rtol 1e-9 and atol 1e-12.
    #[arg(long, value_name = "TOL")]
    rtol: Option<f64>,
    /// Output format on stdout.
    #[arg(long, value_enum, default_value_t = OutputFormat::Text)]
    format: OutputFormat,
    /// Also draw the ground acceleration (horizontal, and vertical when given), θ/α with its
    /// ±1 lines and slide against time, modes shaded; PNG if OUT ends in .png, SVG if it ends
    /// in .svg. With --model 3d: the ground's east, north, up, tilt/α and the foot's slide.
    #[arg(long, value_name = "OUT.svg|OUT.png")]
    plot: Option<PathBuf>,
    /// Write the time history as CSV, one row per input sample (and per sample of the
    /// --t-extra tail) until the end or the overturn: `t_s` (s), `ground_h_mps2` (horizontal
    /// ground acceleration along +x, m/s²), `ground_v_mps2` (vertical, + up, m/s²; only with
    /// --vertical), `theta_rad` (rotation, + about the +x pivot), `slide_m` (slip of the
    /// contact point, m), `mode` (rest, slide, rock, slide-rock, flight, overturned). With
    /// --model 3d (mesh frame: east, north, up of the mesh at rest): `t_s`, `ground_e_mps2`,
    /// `ground_n_mps2`, `ground_u_mps2`, `tilt_rad`, `tilt_over_alpha` (tilt/α(d), d the
    /// direction it leans towards), `direction_deg` (d, degrees from the mesh's north; the
    /// weakest direction at rest), `slide_m` (the foot's slip), `com_e_m`, `com_n_m`,
    /// `com_u_m` (centre of mass), `twist_rad`, `mode` (rest, slide, rock, overturned).
    #[arg(long, value_name = "OUT.csv")]
    trace: Option<PathBuf>,
}

pub fn run(args: SimulateArgs) -> anyhow::Result<()> {
    if !(args.scale.is_finite()) {
        bail!("--scale must be a finite number, got {}", args.scale);
    }
    if let Some(rtol) = args.rtol {
        if !(rtol.is_finite() && rtol > 0.0 && rtol < 1e-2) {
            bail!("--rtol must be in (0, 0.01), got {rtol}");
        }
    }
    let params = match args.geometry.plan(&args.friction)? {
        RockPlan::Planar(params) => params,
        RockPlan::Mesh(mesh) if mesh.model == Model::ThreeD => return run_3d(&mesh, args),
        RockPlan::Mesh(mesh) => {
            if args.record2.is_some() {
                bail!("--record2 needs --model 3d (the planar model takes one direction)");
            }
            let Some(azimuth) = args.azimuth else {
                bail!("--mesh needs --azimuth (the direction to simulate)");
            };
            mesh.block(azimuth)?
        }
    };
    run_with(params, args)
}

/// Simulates a mesh rock in 3-D (docs/rocking-3d.md) as the flags say.
fn run_3d(mesh: &MeshPlan, args: SimulateArgs) -> anyhow::Result<()> {
    if args.rtol.is_some() {
        bail!("--rtol is not a setting of --model 3d (fixed sub-steps of at most 0.25 ms, docs/rocking-3d.md)");
    }
    if mesh.friction.restitution.is_some() {
        bail!("--restitution is not available with --model 3d (impacts are plastic, docs/rocking-3d.md)");
    }
    let Some(azimuth) = args.azimuth else {
        bail!("--model 3d needs --azimuth (the azimuth of the record's horizontal component)");
    };
    let read = |path: &std::path::Path| -> anyhow::Result<Record> {
        let mut r = Record::read(path)?;
        r.scale(args.scale);
        r.check_bounds()
            .map_err(|e| anyhow::anyhow!("{} scaled by {:?}: {e}", path.display(), args.scale))?;
        Ok(r)
    };
    let first = read(&args.record)?;
    let second = match &args.record2 {
        Some(path) => Some(read(path)?),
        None => None,
    };
    let vertical = match &args.vertical {
        Some(path) => Some(read(path)?),
        None => None,
    };
    let mut horizontal = vec![(&first, azimuth)];
    if let (Some(r), Some(az)) = (&second, args.azimuth2) {
        horizontal.push((r, az));
    }
    let motion = GroundMotion3d::from_records(&horizontal, vertical.as_ref())?;
    let options = Simulation3dOptions {
        t_extra_s: args.t_extra,
        ..Simulation3dOptions::default()
    };
    let friction = mesh.friction;
    let context = || format!("simulating {} in 3-D", args.record.display());
    let summary = if args.plot.is_some() || args.trace.is_some() {
        let (summary, trace) = simulate_3d_traced(
            mesh.body_3d()?,
            friction.mu_s,
            friction.mu_k,
            &motion,
            &options,
        )
        .with_context(context)?;
        if let Some(path) = &args.plot {
            let title = format!(
                "{}{} — {} in 3-D, μs = {}, μk = {}",
                first.source,
                if args.scale == 1.0 {
                    String::new()
                } else {
                    format!(" × {}", short_number(args.scale))
                },
                mesh.mesh.path.display(),
                short_number(friction.mu_s),
                short_number(friction.mu_k)
            );
            plot_simulation_3d(path, &trace, &title)?;
        }
        if let Some(path) = &args.trace {
            write_trace_3d(path, &trace)
                .with_context(|| format!("writing trace {}", path.display()))?;
        }
        summary
    } else {
        simulate_3d(
            mesh.body_3d()?,
            friction.mu_s,
            friction.mu_k,
            &motion,
            &options,
        )
        .with_context(context)?
    };
    match args.format {
        OutputFormat::Json => outln!("{}", serde_json::to_string_pretty(&summary)?),
        OutputFormat::Text => {
            let mut out = String::new();
            use std::fmt::Write;
            let _ = writeln!(
                out,
                "record      {} ({} samples, dt {} s) at azimuth {azimuth}°{}{}",
                first.source,
                first.len(),
                short_number(first.dt_s),
                match (&second, args.azimuth2) {
                    (Some(r), Some(az)) => format!(", {} at azimuth {az}°", r.source),
                    _ => String::new(),
                },
                vertical
                    .as_ref()
                    .map(|v| format!(", vertical {}", v.source))
                    .unwrap_or_default()
            );
            let _ = writeln!(
                out,
                "rock        {} (3-D rigid body, resting facet h = {} m, weakest α = {}°), μs = {}, μk = {}",
                mesh.mesh.path.display(),
                short_number(mesh.mesh.rest.h_m),
                short_number(summary.alpha_min.to_degrees()),
                short_number(friction.mu_s),
                short_number(friction.mu_k)
            );
            let status = if summary.overturned {
                format!(
                    "OVERTURNED (tilt last passed α at t = {} s)",
                    short_number(summary.overturn_time.unwrap_or(f64::NAN))
                )
            } else {
                "standing".to_string()
            };
            let _ = writeln!(out, "result      {status}");
            let _ = writeln!(
                out,
                "max tilt    {} rad towards azimuth {}°; max tilt/α {} (azimuth {}°){}",
                short_number(summary.max_tilt),
                short_number(summary.max_tilt_azimuth_deg),
                short_number(summary.max_tilt_over_alpha),
                short_number(summary.max_tilt_over_alpha_azimuth_deg),
                if summary.exceeded_alpha {
                    " (exceeded α)"
                } else {
                    ""
                }
            );
            let _ = writeln!(
                out,
                "max slide   {} m (centre of mass, horizontal), residual {} m",
                short_number(summary.max_slide),
                short_number(summary.residual_slide)
            );
            let _ = writeln!(
                out,
                "twist       {} rad at the end, max |twist| {} rad",
                short_number(summary.twist),
                short_number(summary.max_abs_twist)
            );
            let p = summary.final_position;
            let q = summary.final_rotation;
            let _ = writeln!(
                out,
                "final pose  centre of mass ({}) m (east, north, up), rotation (w, x, y, z) ({})",
                p.map(short_number).join(", "),
                q.map(short_number).join(", ")
            );
            let _ = writeln!(
                out,
                "flight      {}",
                match summary.first_flight_time {
                    Some(t) => format!("yes, first at t = {} s", short_number(t)),
                    None => "no".to_string(),
                }
            );
            let _ = writeln!(
                out,
                "simulated   {} s, {} time steps, {} returns to rest",
                short_number(summary.duration),
                summary.n_steps,
                summary.n_rest_entries
            );
            out!("{out}");
        }
    }
    Ok(())
}

/// Simulates the block `params` as the flags say.
fn run_with(params: BlockParams, args: SimulateArgs) -> anyhow::Result<()> {
    let mut record = Record::read(&args.record)?;
    if let Some(vertical) = &args.vertical {
        record.attach_vertical(vertical)?;
    }
    record.scale(args.scale);
    record.check_bounds().map_err(|e| {
        anyhow::anyhow!("{} scaled by {:?}: {e}", args.record.display(), args.scale)
    })?;
    let mut options = SimulationOptions {
        t_extra_s: args.t_extra,
        keep_trace: args.plot.is_some() || args.trace.is_some(),
        ..SimulationOptions::default()
    };
    if let Some(rtol) = args.rtol {
        options.block.tolerance = Tolerance {
            rtol,
            atol: rtol * 1e-3,
        };
    }
    let sim = simulate(params, &record, &options)
        .with_context(|| format!("simulating {}", args.record.display()))?;
    if let (Some(path), Some(trace)) = (&args.plot, &sim.trace) {
        let title = if args.scale == 1.0 {
            record.source.clone()
        } else {
            format!("{} × {}", record.source, short_number(args.scale))
        };
        plot_simulation(path, trace, &params, &title)?;
    }
    if let (Some(path), Some(trace)) = (&args.trace, &sim.trace) {
        write_trace(path, trace).with_context(|| format!("writing trace {}", path.display()))?;
    }
    match args.format {
        OutputFormat::Json => outln!("{}", serde_json::to_string_pretty(&sim.summary)?),
        OutputFormat::Text => out!("{}", text_summary(&sim.summary, &params, &record)),
    }
    Ok(())
}

/// Writes the trace CSV of `--trace` (columns in [`SimulateArgs::trace`]).
fn write_trace(path: &std::path::Path, trace: &Trace) -> std::io::Result<()> {
    use std::io::Write;
    let mut out = std::io::BufWriter::new(std::fs::File::create(path)?);
    let vertical = !trace.vertical_mps2.is_empty();
    if vertical {
        writeln!(
            out,
            "t_s,ground_h_mps2,ground_v_mps2,theta_rad,slide_m,mode"
        )?;
    } else {
        writeln!(out, "t_s,ground_h_mps2,theta_rad,slide_m,mode")?;
    }
    for i in 0..trace.t_s.len() {
        write!(out, "{},{}", trace.t_s[i], trace.horizontal_mps2[i])?;
        if vertical {
            write!(out, ",{}", trace.vertical_mps2[i])?;
        }
        writeln!(
            out,
            ",{},{},{}",
            trace.theta_rad[i],
            trace.slide_m[i],
            trace.mode[i].as_str()
        )?;
    }
    out.flush()
}

/// Writes the trace CSV of `--trace` with `--model 3d` (columns in [`SimulateArgs::trace`]).
fn write_trace_3d(path: &std::path::Path, trace: &Trace3d) -> std::io::Result<()> {
    use std::io::Write;
    let mut out = std::io::BufWriter::new(std::fs::File::create(path)?);
    writeln!(
        out,
        "t_s,ground_e_mps2,ground_n_mps2,ground_u_mps2,tilt_rad,tilt_over_alpha,direction_deg,\
         slide_m,com_e_m,com_n_m,com_u_m,twist_rad,mode"
    )?;
    for i in 0..trace.t_s.len() {
        let (a, v, x) = (trace.ground[i], trace.view[i], trace.position_m[i]);
        writeln!(
            out,
            "{},{},{},{},{},{},{},{},{},{},{},{},{}",
            trace.t_s[i],
            a.east_mps2,
            a.north_mps2,
            a.up_mps2,
            v.theta_rad,
            v.theta_over_alpha,
            v.direction_deg,
            v.slide_m,
            x[0],
            x[1],
            x[2],
            trace.twist_rad[i],
            v.mode.as_str()
        )?;
    }
    out.flush()
}

fn text_summary(s: &Summary, p: &BlockParams, record: &Record) -> String {
    use std::fmt::Write;
    let mut out = String::new();
    let _ = writeln!(
        out,
        "record      {} ({} samples, dt {} s)",
        record.source,
        record.len(),
        short_number(record.dt_s)
    );
    let _ = writeln!(
        out,
        "block       {}, impact ratio {} (+ → −), {} (− → +)",
        block_label(p),
        short_number(p.impact_ratio(1.0)),
        short_number(p.impact_ratio(-1.0))
    );
    let status = match s.status {
        Status::Ok => "standing".to_string(),
        Status::Overturned => format!(
            "OVERTURNED (|θ| last passed α at t = {} s)",
            short_number(s.overturn_time.unwrap_or(f64::NAN))
        ),
        Status::Flight => "lost contact (free flight): run stopped".to_string(),
    };
    let _ = writeln!(out, "result      {status}");
    let _ = writeln!(
        out,
        "max |θ|     {} rad = {} α{}",
        short_number(s.max_abs_theta),
        short_number(s.max_abs_theta_over_alpha),
        if s.exceeded_alpha {
            " (exceeded α)"
        } else {
            ""
        }
    );
    let _ = writeln!(
        out,
        "max |slide| {} m, residual {} m",
        short_number(s.max_abs_slide),
        short_number(s.residual_slide)
    );
    let _ = writeln!(
        out,
        "impacts     {} ({} significant, {} flat landings)",
        s.n_impacts, s.n_impacts_significant, s.n_flat_landings
    );
    let _ = writeln!(
        out,
        "modes       (simulated {} s)",
        short_number(s.duration)
    );
    for (t, mode) in s.modes.iter().take(40) {
        let _ = writeln!(out, "  {t:>10.4} s  {}", mode.as_str());
    }
    if s.modes.len() > 40 {
        let _ = writeln!(
            out,
            "  … {} more mode changes (see --format json)",
            s.modes.len() - 40
        );
    }
    out
}
