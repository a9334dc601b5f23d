//! `rockwatch simulate`: one block under one record.

use std::path::PathBuf;

use anyhow::{bail, Context};
use rockwatch::plot::{plot_simulation, short_number};
use rockwatch_core::dynamics::BlockParams;
use rockwatch_core::ode::Tolerance;
use rockwatch_core::record::Record;
use rockwatch_core::simulate::{simulate, SimulationOptions, Status, Summary};

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
    /// Base width B of the block (m); with --height. Alternatively give --half-diagonal
    /// and --alpha, or a general body with --b-plus, --b-minus, --com-height and --rho.
    #[arg(
        long,
        value_name = "B",
        requires = "height",
        required_unless_present_any = ["half_diagonal", "b_plus"]
    )]
    width: Option<f64>,
    /// Height H of the block (m).
    #[arg(long, value_name = "H", requires = "width")]
    height: Option<f64>,
    /// Half-diagonal R = ½√(B² + H²) of the block (m); with --alpha, instead of --width and
    /// --height.
    #[arg(long = "half-diagonal", value_name = "R", requires = "alpha", conflicts_with_all = ["width", "height"])]
    half_diagonal: Option<f64>,
    /// Slenderness α = atan(B/H) of the block (degrees), with --half-diagonal.
    #[arg(long, value_name = "DEG", requires = "half_diagonal", conflicts_with_all = ["width", "height"])]
    alpha: Option<f64>,
    /// General body (docs/general-body.md): horizontal distance from the centre of mass to
    /// the +x pivot (m). With --b-minus, --com-height and --rho, instead of a rectangle.
    #[arg(long = "b-plus", value_name = "M", requires_all = ["b_minus", "com_height", "rho"], conflicts_with_all = ["width", "height", "half_diagonal", "alpha"])]
    b_plus: Option<f64>,
    /// General body: horizontal distance from the centre of mass to the −x pivot (m).
    #[arg(long = "b-minus", value_name = "M", requires = "b_plus")]
    b_minus: Option<f64>,
    /// General body: height of the centre of mass above the base (m).
    #[arg(long = "com-height", value_name = "M", requires = "b_plus")]
    com_height: Option<f64>,
    /// General body: radius of gyration about the centre of mass (m), I_c = m ρ²
    /// (a B × H rectangle has ρ² = (B² + H²)/12).
    #[arg(long, value_name = "M", requires = "b_plus")]
    rho: Option<f64>,
    /// Static friction coefficient μs.
    #[arg(long = "mu-s", value_name = "MS")]
    mu_s: f64,
    /// Kinetic friction coefficient μk (≤ μs, < 4/3).
    #[arg(long = "mu-k", value_name = "MK")]
    mu_k: f64,
    /// Restitution of a pure-rocking impact, in [0, 1]: the angular-velocity ratio for a
    /// rectangle (kinetic-energy ratio e² for any body); default Housner's η = 1 − 1.5 sin²α
    /// and its generalisation (ρ² + h² − b_old b_new)/(ρ² + R_new²).
    #[arg(long, value_name = "E")]
    restitution: Option<f64>,
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
    /// in .svg.
    #[arg(long, value_name = "OUT.svg|OUT.png")]
    plot: Option<PathBuf>,
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
    let params = match (args.width, args.height, args.half_diagonal, args.alpha) {
        _ if args.b_plus.is_some() => {
            match (args.b_plus, args.b_minus, args.com_height, args.rho) {
                (Some(bp), Some(bm), Some(h), Some(rho)) => {
                    BlockParams::from_body(bp, bm, h, rho, args.mu_s, args.mu_k, args.restitution)
                }
                _ => bail!("--b-plus needs --b-minus, --com-height and --rho"),
            }
        }
        (Some(b), Some(h), _, _) => {
            BlockParams::from_width_height(b, h, args.mu_s, args.mu_k, args.restitution)
        }
        (_, _, Some(r), Some(alpha_deg)) => BlockParams::from_r_alpha(
            r,
            alpha_deg.to_radians(),
            args.mu_s,
            args.mu_k,
            args.restitution,
        ),
        _ => bail!(
            "give --width and --height, --half-diagonal and --alpha, or --b-plus, --b-minus, \
             --com-height and --rho"
        ),
    }
    .context("invalid block")?;
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
        keep_trace: args.plot.is_some(),
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
        plot_simulation(path, trace, &params, &title)
            .map_err(|e| anyhow::anyhow!("writing plot {}: {e}", path.display()))?;
    }
    match args.format {
        OutputFormat::Json => outln!("{}", serde_json::to_string_pretty(&sim.summary)?),
        OutputFormat::Text => out!("{}", text_summary(&sim.summary, &params, &record)),
    }
    Ok(())
}

fn text_summary(s: &Summary, p: &BlockParams, record: &Record) -> String {
    use std::fmt::Write;
    let mut out = String::new();
    let _ = writeln!(
        out,
        "record      {} ({} samples, dt {} s)",
        record.source,
        record.len(),
        record.dt_s
    );
    let _ = writeln!(
        out,
        "block       {}, μs = {}, μk = {}, impact ratio {:.4} (+ → −), {:.4} (− → +)",
        p.geometry_label(),
        p.mu_s,
        p.mu_k,
        p.impact_ratio(1.0),
        p.impact_ratio(-1.0)
    );
    let status = match s.status {
        Status::Ok => "standing".to_string(),
        Status::Overturned => format!(
            "OVERTURNED (|θ| last passed α at t = {:.3} s)",
            s.overturn_time.unwrap_or(f64::NAN)
        ),
        Status::Flight => "lost contact (free flight): run stopped".to_string(),
    };
    let _ = writeln!(out, "result      {status}");
    let _ = writeln!(
        out,
        "max |θ|     {:.6} rad = {:.4} α{}",
        s.max_abs_theta,
        s.max_abs_theta_over_alpha,
        if s.exceeded_alpha {
            " (exceeded α)"
        } else {
            ""
        }
    );
    let _ = writeln!(
        out,
        "max |slide| {:.6} m, residual {:.6} m",
        s.max_abs_slide, s.residual_slide
    );
    let _ = writeln!(
        out,
        "impacts     {} ({} significant, {} flat landings)",
        s.n_impacts, s.n_impacts_significant, s.n_flat_landings
    );
    let _ = writeln!(out, "modes       (simulated {:.2} s)", s.duration);
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
