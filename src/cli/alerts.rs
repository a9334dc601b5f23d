//! `rockwatch alerts` and `rockwatch reset`: the alert history of a state directory, and
//! the operator reset of a fallen block.

use std::path::PathBuf;

use anyhow::bail;
use rockwatch::engine::JournalRecord;
use rockwatch::journal::{read_journal, Journal};

use super::OutputFormat;

/// List the alert history kept in a state directory (alerts, episode ends, resets).
#[derive(Debug, clap::Args)]
pub struct AlertsArgs {
    /// State directory written by `rockwatch monitor` or the node.
    #[arg(long = "state-dir", value_name = "DIR")]
    state_dir: PathBuf,
    /// Output format: a table, or one JSON array of records.
    #[arg(long, value_enum, default_value_t = OutputFormat::Text)]
    format: OutputFormat,
}

/// Reset a fallen block: it stands again and a new episode can begin.
///
/// Appends a reset record to the state directory's journal; a running node applies it when
/// it next starts (live reset through the node's interface is not built yet).
#[derive(Debug, clap::Args)]
pub struct ResetArgs {
    /// State directory written by `rockwatch monitor` or the node.
    #[arg(long = "state-dir", value_name = "DIR")]
    state_dir: PathBuf,
    /// Id of the block to reset.
    #[arg(long, value_name = "ID")]
    pbr: String,
}

pub fn run_alerts(args: AlertsArgs) -> anyhow::Result<()> {
    if !args.state_dir.is_dir() {
        bail!("{}: not a directory", args.state_dir.display());
    }
    let (records, report) = read_journal(&args.state_dir)?;
    if !report.corrupt_lines.is_empty() {
        eprintln!(
            "rockwatch: warning: {}: skipped corrupt journal lines {:?}",
            args.state_dir.display(),
            report.corrupt_lines
        );
    }
    match args.format {
        OutputFormat::Json => outln!("{}", serde_json::to_string_pretty(&records)?),
        OutputFormat::Text => {
            outln!(
                "{:<24} {:<12} {:>7} {:<18} {:<11} {:>8} {:>9}",
                "pbr",
                "station",
                "episode",
                "level",
                "mode",
                "θ/α",
                "data time (ns)"
            );
            for r in &records {
                match r {
                    JournalRecord::Alert(a) => outln!(
                        "{:<24} {:<12} {:>7} {:<18} {:<11} {:>8.3} {:>9}",
                        a.pbr_id,
                        a.station,
                        a.episode,
                        a.level.as_str(),
                        a.mode.as_str(),
                        a.theta_over_alpha,
                        a.data_time_ns
                    ),
                    JournalRecord::EpisodeEnd { pbr_id, episode } => {
                        outln!("{pbr_id:<24} {:<12} {episode:>7} episode ended", "")
                    }
                    JournalRecord::Reset { pbr_id } => {
                        outln!("{pbr_id:<24} {:<12} {:>7} reset by operator", "", "")
                    }
                }
            }
        }
    }
    Ok(())
}

pub fn run_reset(args: ResetArgs) -> anyhow::Result<()> {
    if !args.state_dir.is_dir() {
        bail!("{}: not a directory", args.state_dir.display());
    }
    let (mut journal, records, _) = Journal::open(&args.state_dir)?;
    let known = records
        .iter()
        .any(|r| matches!(r, JournalRecord::Alert(a) if a.pbr_id == args.pbr));
    if !known {
        bail!(
            "{}: no alert recorded for block {:?}; nothing to reset",
            args.state_dir.display(),
            args.pbr
        );
    }
    journal.append(&JournalRecord::Reset {
        pbr_id: args.pbr.clone(),
    })?;
    outln!("block {} reset in {}", args.pbr, args.state_dir.display());
    Ok(())
}
