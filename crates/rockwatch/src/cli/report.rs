//! `rockwatch report`: an event report drawn again from its JSON in a state directory (a
//! node's, or one `rockwatch monitor --state-dir` wrote).

use std::path::PathBuf;

use rockwatch::reports::{find_report, plot_report, read_report, ReportReason};

use super::OutputFormat;

/// Draw an event report again (PNG) from the JSON the node wrote into its state directory
/// (`reports/<UTC data time>_<pbr>.json`), and print it.
#[derive(Debug, clap::Args)]
pub struct ReportArgs {
    /// State directory written by the node or `rockwatch monitor --state-dir`.
    #[arg(long = "state-dir", value_name = "DIR")]
    state_dir: PathBuf,
    /// The rock (its catalogue `id`).
    #[arg(long, value_name = "ID")]
    pbr: String,
    /// The report of this episode (its alerts' episode number; the last report of it);
    /// default: the rock's last report.
    #[arg(long, value_name = "N")]
    episode: Option<u32>,
    /// Where to draw the plot (.png or .svg); default: the PNG beside the JSON.
    #[arg(long, value_name = "FILE")]
    out: Option<PathBuf>,
    /// Output: a summary, or the report's JSON (as the file holds it).
    #[arg(long, value_enum, default_value_t = OutputFormat::Text)]
    format: OutputFormat,
}

pub fn run(args: ReportArgs) -> anyhow::Result<()> {
    let json = find_report(&args.state_dir, &args.pbr, args.episode)?;
    let report = read_report(&json)?;
    let png = args.out.unwrap_or_else(|| json.with_extension("png"));
    plot_report(&report, &png)?;
    match args.format {
        OutputFormat::Json => outln!("{}", serde_json::to_string_pretty(&report)?),
        OutputFormat::Text => {
            outln!(
                "{} {} at {} (station {}, episode {}): {} alerts, {} points; max |θ/α| {:.3}",
                report.pbr_id,
                match report.reason {
                    ReportReason::Overturned => "overturned",
                    ReportReason::EpisodeEnd => "episode end",
                },
                report.data_time,
                report.rock.station,
                report.episode.map_or("-".to_string(), |e| e.to_string()),
                report.alerts.len(),
                report.points.len(),
                report
                    .points
                    .iter()
                    .map(|p| p.theta_over_alpha.abs())
                    .fold(0.0, f64::max)
            );
            outln!("report: {}", json.display());
            outln!("plot:   {}", png.display());
        }
    }
    Ok(())
}
