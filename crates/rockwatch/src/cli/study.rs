//! `rockwatch study`: the seed paper's intensity-measure study, reproduced and extended.

use std::io::IsTerminal;
use std::path::PathBuf;
use std::time::Instant;

use anyhow::{bail, Context};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use rockwatch::number_text::short_number;
use rockwatch::study::plots::write_plots;
use rockwatch::study::report::{display_name, summary, write_tables};
use rockwatch::units::AccelUnits;
use rockwatch_core::study::{
    analyse, run_study, ExclusionRule, StudyBlock, StudyConfig, DEFAULT_DT_S, DEFAULT_IM_PAD_S,
    DEFAULT_MAX_SLIDE_M, DEFAULT_PULSES_PER_PAIR, DEFAULT_SLIDE_FLOOR_M, DEFAULT_THETA_FLOOR_RAD,
    DEFAULT_T_EXTRA_S, DEFAULT_VECTOR_TOP,
};

use super::OutputFormat;

/// Run the intensity-measure study of the seed paper: which ground-motion IMs predict the
/// sliding and rocking demand of a freestanding block best (efficiency: R²) and most
/// independently of magnitude and distance (sufficiency).
///
/// For every Mw–R pair, Mavroeidis–Papageorgiou pulses are drawn by Latin hypercube; for every
/// pulse the 37 IMs of the seed are computed (on the pulse followed by --im-pad-s of zeros) and
/// every block is simulated (the pulse, then --t-extra seconds of free vibration). Then, per
/// block: DM ~ IM regressions (linear, and log-log over the responding runs), overall and per
/// pair; sufficiency (spread of R² across pairs; p-values of the residuals regressed on Mw and
/// on R, Luco & Cornell 2007); vector IMs (DM ~ IM1 + IM2); and a lognormal fragility curve of
/// overturning fitted by maximum likelihood with a 95 % delta-method band.
///
/// Default blocks (the seed's; it gives no sizes, R is that of its Figure 2): "sliding",
/// α = 45°, μs = μk = 0.1, R = 1.12 m, DM = max |slide| (m); "rocking", α = 11.31°, μs = 1.5,
/// μk = 1.0, R = 3.29 m, DM = max |θ| (rad).
///
/// Files written to --out: results.csv, efficiency.csv, efficiency.md, sufficiency.csv,
/// vector.csv, fragility.csv, fragility_fits.csv, fragility.json, summary.json, and
/// scatter_<block>.svg/.png, fragility_<block>.svg/.png. Results are bit-for-bit identical
/// for a given seed and arguments, whatever the number of threads.
#[derive(Debug, clap::Args)]
pub struct StudyArgs {
    /// Output directory (created if missing; files of the same name are overwritten).
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,

    /// Pulses per Mw–R pair (the seed: 250).
    #[arg(long = "pulses-per-pair", default_value_t = DEFAULT_PULSES_PER_PAIR,
          value_name = "N")]
    pub pulses_per_pair: usize,

    /// Random seed of the study (u64); each pair's pulses use a seed derived from it.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,

    /// Moment magnitudes, comma-separated.
    #[arg(long, value_delimiter = ',', default_values_t = [6.5, 7.0, 7.5, 8.0, 8.5],
          value_name = "MW,...")]
    pub mw: Vec<f64>,

    /// Rupture distances (km), comma-separated.
    #[arg(long = "r-km", value_delimiter = ',', default_values_t = [5.0, 10.0, 15.0],
          value_name = "R,...")]
    pub r_km: Vec<f64>,

    /// Sampling interval of the pulse records (s), in (0, 0.1].
    #[arg(long, default_value_t = DEFAULT_DT_S, value_name = "S")]
    pub dt: f64,

    /// Seconds of zero acceleration appended to each pulse before its IMs are computed (lets
    /// every oscillator of period ≤ 3 s reach its free-vibration peak).
    #[arg(long = "im-pad-s", default_value_t = DEFAULT_IM_PAD_S, value_name = "S")]
    pub im_pad_s: f64,

    /// Seconds of free vibration (zero ground motion) simulated after each pulse.
    #[arg(long = "t-extra", default_value_t = DEFAULT_T_EXTRA_S, value_name = "S")]
    pub t_extra: f64,

    /// Add a block (repeatable): NAME:key=value,... with keys r (half-diagonal, m) and
    /// alpha-deg (or alpha in rad), or width and height (m); mu-s; mu-k (default mu-s);
    /// restitution (optional); dm = slide or theta (default theta when mu-s > tan α, else
    /// slide). A block named "sliding" or "rocking" replaces that default block. Example of a
    /// slide-rock-prone block: slide-rock:r=1.5,alpha-deg=10,mu-s=0.2,mu-k=0.19
    #[arg(long = "block", value_name = "SPEC")]
    pub blocks: Vec<String>,

    /// Study only the --block blocks (drop the two default blocks).
    #[arg(long = "no-default-blocks")]
    pub no_default_blocks: bool,

    /// Keep overturned runs in the regressions (default: excluded, like the seed's
    /// "excessive" responses).
    #[arg(long = "keep-overturned")]
    pub keep_overturned: bool,

    /// Exclude runs whose max |slide| exceeds this (m); "inf" disables the rule.
    #[arg(long = "max-slide-m", default_value_t = DEFAULT_MAX_SLIDE_M, value_name = "M")]
    pub max_slide_m: f64,

    /// Exclude runs whose max |θ| exceeds this (rad); default: no limit.
    #[arg(long = "max-theta-rad", default_value_t = f64::INFINITY, value_name = "RAD")]
    pub max_theta_rad: f64,

    /// Smallest max |slide| counted as a response (m): smaller slides are "no response"
    /// (kept in the linear regressions, left out of the log-log ones).
    #[arg(long = "slide-floor-m", default_value_t = DEFAULT_SLIDE_FLOOR_M, value_name = "M")]
    pub slide_floor_m: f64,

    /// Smallest max |θ| counted as a response (rad).
    #[arg(long = "theta-floor-rad", default_value_t = DEFAULT_THETA_FLOOR_RAD,
          value_name = "RAD")]
    pub theta_floor_rad: f64,

    /// Number of best two-IM vector regressions reported per block.
    #[arg(long = "vector-top", default_value_t = DEFAULT_VECTOR_TOP, value_name = "N")]
    pub vector_top: usize,

    /// IM of the fragility curves (a name of results.csv, e.g. asi_1.0-2.5, or its canonical
    /// name, ASI(1.0-2.5)); default: the IM of largest likelihood.
    #[arg(long = "fragility-im", value_name = "IM")]
    pub fragility_im: Option<String>,

    /// Worker threads (0 = all cores). The results do not depend on it.
    #[arg(long, default_value_t = 0, value_name = "N")]
    pub threads: usize,

    /// Skip the SVG/PNG plots.
    #[arg(long = "no-plots")]
    pub no_plots: bool,

    /// Output on stdout: text (top IMs per block, timing) or json (the summary: {"study":
    /// {...}, "blocks": {NAME: {"n", "excluded", "counts", "ranking": [{"im", "unit", "r2",
    /// "r2_by_pair": {"M6.5-R10": ..}, "r2_log", "r2_log_by_pair", "sufficiency_p_mw",
    /// "sufficiency_p_r" (log-log residuals), "sufficiency_p_mw_linear",
    /// "sufficiency_p_r_linear", "r2_pair_sd"}, ...], "vector": [...], "fragility": {...} or
    /// null, "fragility_note"}}}). The progress bar is hidden with json.
    #[arg(long, value_enum, default_value_t = OutputFormat::Text)]
    pub format: OutputFormat,

    /// Unit of accelerations (PHA, SA, …: the IMs in m/s²) in the text's fragility line and
    /// the plots' IM axes: m/s2 or g (9.80665 m/s²). The CSV and JSON files stay in SI units
    /// (their `unit`/`im_unit` columns and fields say m/s2).
    #[arg(long, value_enum, default_value_t = AccelUnits::Mps2, value_name = "g|m/s2")]
    pub units: AccelUnits,
}

fn build_config(args: &StudyArgs) -> anyhow::Result<StudyConfig> {
    let mut blocks = if args.no_default_blocks {
        Vec::new()
    } else {
        vec![StudyBlock::seed_sliding()?, StudyBlock::seed_rocking()?]
    };
    let mut given: Vec<String> = Vec::new();
    for spec in &args.blocks {
        let block = StudyBlock::parse_spec(spec)?;
        if given.contains(&block.name) {
            bail!(
                "--block {spec:?}: two --block options name {:?}",
                block.name
            );
        }
        given.push(block.name.clone());
        match blocks.iter_mut().find(|b| b.name == block.name) {
            Some(default_block) => *default_block = block,
            None => blocks.push(block),
        }
    }
    if blocks.is_empty() {
        bail!("no blocks: give --block SPEC with --no-default-blocks");
    }
    let config = StudyConfig {
        magnitudes: args.mw.clone(),
        distances_km: args.r_km.clone(),
        pulses_per_pair: args.pulses_per_pair,
        seed: args.seed,
        dt_s: args.dt,
        im_pad_s: args.im_pad_s,
        t_extra_s: args.t_extra,
        blocks,
        exclusion: ExclusionRule {
            exclude_overturned: !args.keep_overturned,
            max_slide_m: args.max_slide_m,
            max_theta_rad: args.max_theta_rad,
        },
        slide_floor_m: args.slide_floor_m,
        theta_floor_rad: args.theta_floor_rad,
        vector_top: args.vector_top,
        fragility_im: args
            .fragility_im
            .as_deref()
            .map(|im| im.parse().context("--fragility-im"))
            .transpose()?,
    };
    config.validate()?;
    Ok(config)
}

/// Runs the study, writes the files, prints the summary.
pub fn run(args: StudyArgs) -> anyhow::Result<()> {
    let config = build_config(&args)?;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(args.threads)
        .build()
        .context("cannot start the worker threads")?;
    let n_pulses = config.magnitudes.len() * config.distances_km.len() * config.pulses_per_pair;
    let show_bar = args.format == OutputFormat::Text
        && std::io::stderr().is_terminal()
        && std::io::stdout().is_terminal();
    let bar = if show_bar {
        let bar =
            ProgressBar::with_draw_target(Some(n_pulses as u64), ProgressDrawTarget::stderr());
        bar.set_style(
            ProgressStyle::with_template(
                "{elapsed_precise} [{bar:30}] {pos}/{len} pulses, eta {eta}",
            )
            .map_or_else(
                |_| ProgressStyle::default_bar(),
                |s| s.progress_chars("=> "),
            ),
        );
        bar
    } else {
        ProgressBar::hidden()
    };
    let started = Instant::now();
    let (data, analysis) = pool.install(|| -> anyhow::Result<_> {
        let data = run_study(&config, &|| bar.inc(1))?;
        bar.finish_and_clear();
        let analysis = analyse(&config, &data);
        Ok((data, analysis))
    })?;
    let computed_s = started.elapsed().as_secs_f64();
    let mut files = write_tables(&args.out, &config, &data, &analysis)?;
    if !args.no_plots {
        files.extend(write_plots(
            &args.out, &config, &data, &analysis, args.units,
        )?);
    }
    let total_s = started.elapsed().as_secs_f64();

    match args.format {
        OutputFormat::Json => {
            outln!(
                "{}",
                serde_json::to_string_pretty(&summary(&config, &data, &analysis))?
            );
        }
        OutputFormat::Text => {
            outln!(
                "{} pulses × {} blocks on {} threads: simulated and analysed in {:.1} s, \
                 {:.1} s with the files",
                data.cases.len(),
                config.blocks.len(),
                pool.current_num_threads(),
                computed_s,
                total_s
            );
            for block in &analysis.blocks {
                let c = &block.counts;
                outln!(
                    "\nblock {} (DM {}): {} used ({} responding), {} excluded ({} overturned)",
                    block.name,
                    block.dm.label(),
                    c.used(),
                    c.responding,
                    c.excluded(),
                    c.overturned
                );
                outln!(
                    "  {:<22} {:>8} {:>8} {:>10} {:>10}",
                    "IM",
                    "R²",
                    "R² log",
                    "p(Mw)",
                    "p(R)"
                );
                for sc in block.ranking.iter().take(10) {
                    outln!(
                        "  {:<22} {:>8.4} {:>8.4} {:>10.3e} {:>10.3e}",
                        display_name(sc.im()),
                        sc.r2(),
                        sc.r2_log(),
                        sc.p_mw_log,
                        sc.p_r_log
                    );
                }
                match &block.fragility.selected {
                    Some(f) => {
                        let (unit, div) = args.units.show(&f.im_unit);
                        outln!(
                            "  fragility of overturning: P = Φ(ln({}/{} {unit})/{})",
                            display_name(f.im),
                            short_number(f.median / div),
                            short_number(f.beta)
                        )
                    }
                    None => outln!("  {}", block.fragility.note),
                }
            }
            outln!("\nwrote {} files to {}", files.len(), args.out.display());
        }
    }
    Ok(())
}
