//! `rockwatch demo`: the README's first command. Runs on embedded data with no arguments.
//!
//! Until the live node exists (ROS 2 / iceoryx2), the demo simulates a set of illustrative
//! blocks under the bundled Rinaldi Receiving Station record of the 1994 Northridge
//! earthquake (horizontal 228° and vertical components, PEER NGA RSN1063) through the same
//! real-time stepping API the node will use, and prints a table.

use std::path::Path;

use anyhow::Context;
use rockwatch::dynamics::BlockParams;
use rockwatch::record::{parse_at2_text, Record};
use rockwatch::simulate::{simulate, SimulationOptions, Status};

use super::OutputFormat;

const HORIZONTAL_AT2: &str = include_str!("../../tests/data/records/Rinaldi228.AT2");
const VERTICAL_AT2: &str = include_str!("../../tests/data/records/RinaldiUP.AT2");

/// Run the built-in demonstration: illustrative blocks under a bundled near-fault record.
#[derive(Debug, clap::Args)]
pub struct DemoArgs {
    /// Output format on stdout.
    #[arg(long, value_enum, default_value_t = OutputFormat::Text)]
    format: OutputFormat,
}

/// An illustrative block: (name, B (m), H (m), μs, μk). The numbers are illustrative, not
/// measured rocks, except the two blocks of the seed paper's study.
const BLOCKS: [(&str, f64, f64, f64, f64); 6] = [
    ("slender PBR (illustrative)", 0.4, 2.0, 0.8, 0.6),
    ("stocky PBR (illustrative)", 1.2, 2.0, 0.8, 0.6),
    ("squat sliding boulder (illustrative)", 1.5, 1.5, 0.3, 0.25),
    (
        "slide-rock-prone block (illustrative)",
        0.6,
        2.0,
        0.35,
        0.34,
    ),
    // Seed paper's rocking block: α = 11.31°, μs = 1.5, μk = 1.0, R = 3.29 m (its Figure 2).
    ("seed rocking block R=3.29 m", 1.2904, 6.4520, 1.5, 1.0),
    // Seed paper's sliding block: α = 45°, μs = μk = 0.1, R = 1.12 m.
    ("seed sliding block R=1.12 m", 1.5839, 1.5839, 0.1, 0.1),
];

pub fn run(args: DemoArgs) -> anyhow::Result<()> {
    let source = Path::new("bundled:Rinaldi228.AT2");
    let mut record: Record = parse_at2_text(HORIZONTAL_AT2, source)?.into_record(source);
    let vertical = parse_at2_text(VERTICAL_AT2, Path::new("bundled:RinaldiUP.AT2"))?
        .into_record(Path::new("bundled:RinaldiUP.AT2"));
    record.vertical_mps2 = Some(vertical.horizontal_mps2);
    let options = SimulationOptions::default();

    let mut rows = Vec::new();
    for (name, b, h, mu_s, mu_k) in BLOCKS {
        let params = BlockParams::from_width_height(b, h, mu_s, mu_k, None)
            .with_context(|| format!("demo block {name}"))?;
        let sim =
            simulate(params, &record, &options).with_context(|| format!("demo block {name}"))?;
        rows.push((name, params, sim.summary));
    }
    match args.format {
        OutputFormat::Json => {
            let blocks: Vec<_> = rows
                .iter()
                .map(|(name, p, s)| {
                    serde_json::json!({
                        "name": name, "width_m": p.width_m, "height_m": p.height_m,
                        "mu_s": p.mu_s, "mu_k": p.mu_k, "summary": s,
                    })
                })
                .collect();
            outln!(
                "{}",
                serde_json::to_string_pretty(&serde_json::json!({
                    "record": "Northridge 1994, Rinaldi Receiving Sta, 228° + UP (PEER NGA RSN1063)",
                    "t_extra_s": options.t_extra_s,
                    "blocks": blocks,
                }))?
            );
        }
        OutputFormat::Text => {
            outln!(
                "rockwatch demo: Northridge 1994, Rinaldi Receiving Sta (228° + UP, PEER NGA RSN1063), {:.2} s + {} s free vibration",
                record.duration_s(),
                options.t_extra_s
            );
            outln!(
                "{:<40} {:>7} {:>5} {:>5} {:>11} {:>9} {:>10} {:>8}  modes visited",
                "block",
                "α (°)",
                "μs",
                "μk",
                "result",
                "max θ/α",
                "max slide",
                "impacts"
            );
            for (name, p, s) in &rows {
                let result = match s.status {
                    Status::Ok => "standing".to_string(),
                    Status::Overturned => {
                        format!("FELL {:.2}s", s.overturn_time.unwrap_or(f64::NAN))
                    }
                    Status::Flight => "flight".to_string(),
                };
                let mut visited: Vec<&str> = Vec::new();
                for (_, m) in &s.modes {
                    if !visited.contains(&m.as_str()) {
                        visited.push(m.as_str());
                    }
                }
                outln!(
                    "{:<40} {:>7.2} {:>5} {:>5} {:>11} {:>9.3} {:>8.4} m {:>8}  {}",
                    name,
                    p.alpha_rad.to_degrees(),
                    p.mu_s,
                    p.mu_k,
                    result,
                    s.max_abs_theta_over_alpha,
                    s.max_abs_slide,
                    s.n_impacts,
                    visited.join(" → ")
                );
            }
        }
    }
    Ok(())
}
