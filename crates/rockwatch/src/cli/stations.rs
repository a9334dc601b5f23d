//! `rockwatch stations`: what StationXML documents say about each channel epoch and whether
//! rockwatch can use it (gain in (m/s²)/count, or the reason why not).

use std::path::PathBuf;

use anyhow::Context as _;
use rockwatch_core::inventory::{ChannelEpoch, Inventory, Unusable};
use rockwatch_core::utc::{format_utc_ns, parse_utc_ns};

use super::OutputFormat;

/// Show the channel epochs of StationXML documents and whether each is usable.
///
/// A channel is usable when its InstrumentSensitivity takes an acceleration (M/S**2, nm/s**2,
/// …) to counts and it has an azimuth, a dip and a sampling rate of at least 50 Hz (slower
/// channels — LN?, LH?, BN? at 40 Hz — lose the peaks of the ground acceleration that rocks a
/// block: docs/stationxml.md, "Sampling rate"); the gain applied to its
/// counts is then `to_mps2(input units) / sensitivity` in (m/s²)/count. Velocity channels
/// (M/S, …) are usable only differentiated to acceleration (`[inventory]
/// differentiate_velocity = true` of acquire, `--differentiate-velocity` of monitor, replay,
/// ims): listed as "with differentiation", `"usable": false` and
/// `"usable_with_differentiation": true`. Other units are unusable with the reason (see
/// docs/stationxml.md).
///
/// JSON: `{"channels": [{"id": "NET.STA.LOC.CHA", "start": ISO|null, "end": ISO|null,
/// "sample_rate_hz", "azimuth_deg", "dip_deg", "sensitivity", "sensitivity_frequency_hz",
/// "input_units", "gain_mps2_per_count": number|null, "usable": bool, "reason":
/// string|null, "usable_with_differentiation": bool}]}`; values missing from the document are
/// null, times are ISO 8601 UTC.
#[derive(Debug, clap::Args)]
pub struct StationsArgs {
    /// FDSN StationXML documents (1.0–1.2), read in order.
    #[arg(long, value_name = "FILE", num_args = 1.., required = true)]
    stationxml: Vec<PathBuf>,
    /// Only the epochs in force at this time (ISO 8601, e.g. 2024-05-01T12:00:00Z; no zone =
    /// UTC). Default: every epoch.
    #[arg(long, value_name = "ISO_TIME")]
    at: Option<String>,
    /// Output: a table (`text`) or one JSON object (`json`).
    #[arg(long, value_enum, default_value_t = OutputFormat::Text)]
    format: OutputFormat,
}

pub fn run(args: StationsArgs) -> anyhow::Result<()> {
    let at = match &args.at {
        Some(text) => Some(
            parse_utc_ns(text).with_context(|| format!("--at {text:?} is not an ISO 8601 time"))?,
        ),
        None => None,
    };
    let inventory = Inventory::read_all(&args.stationxml)?;
    let epochs: Vec<&ChannelEpoch> = inventory
        .channels
        .iter()
        .filter(|c| at.is_none_or(|t| c.contains(t)))
        .collect();
    match args.format {
        OutputFormat::Json => {
            let channels: Vec<serde_json::Value> = epochs.iter().map(|c| epoch_json(c)).collect();
            outln!("{}", serde_json::json!({ "channels": channels }));
        }
        OutputFormat::Text => print_table(&epochs),
    }
    Ok(())
}

/// Why `c` cannot be used, if it cannot: a velocity channel's reason is that of its
/// differentiated use when that fails too (a 1 Hz velocity channel is refused for its rate,
/// which differentiation does not mend).
fn unusable(c: &ChannelEpoch) -> Option<Unusable> {
    match (c.calibration(), c.calibration_with(true)) {
        (Ok(_), _) => None,
        (Err(Unusable::Velocity { .. }), Err(why)) | (Err(why), _) => Some(why),
    }
}

fn epoch_json(c: &ChannelEpoch) -> serde_json::Value {
    let reason = unusable(c);
    let s = c.sensitivity.as_ref();
    serde_json::json!({
        "id": c.id(),
        "start": c.start_ns.map(format_utc_ns),
        "end": c.end_ns.map(format_utc_ns),
        "sample_rate_hz": c.sample_rate_hz,
        "azimuth_deg": c.azimuth_deg,
        "dip_deg": c.dip_deg,
        "sensitivity": s.map(|s| s.value),
        "sensitivity_frequency_hz": s.and_then(|s| s.frequency_hz),
        "input_units": s.map(|s| s.input_units.clone()),
        "gain_mps2_per_count": c.gain_mps2_per_count().ok(),
        "usable": reason.is_none(),
        "reason": reason.map(|e| e.to_string()),
        "usable_with_differentiation": c.calibration_with(true).is_ok(),
    })
}

fn print_table(epochs: &[&ChannelEpoch]) {
    let opt = |v: Option<f64>| v.map_or_else(|| "-".to_string(), |v| format!("{v}"));
    let day =
        |t: Option<i128>| t.map_or_else(|| "-".to_string(), |t| format_utc_ns(t)[..19].to_string());
    outln!(
        "{:<20} {:<19} {:<19} {:>8} {:>7} {:>6} {:>13} {:<8} {:>12}  usable",
        "channel",
        "start",
        "end",
        "rate Hz",
        "az °",
        "dip °",
        "sensitivity",
        "units",
        "gain m/s²/c"
    );
    for c in epochs {
        let s = c.sensitivity.as_ref();
        let usable = match (unusable(c), c.calibration_with(true)) {
            (None, _) => "yes".to_string(),
            (Some(_), Ok(_)) => {
                "with differentiation only: velocity channel (differentiate_velocity / --differentiate-velocity)".to_string()
            }
            (Some(reason), Err(_)) => format!("no: {reason}"),
        };
        outln!(
            "{:<20} {:<19} {:<19} {:>8} {:>7} {:>6} {:>13} {:<8} {:>12}  {usable}",
            c.id(),
            day(c.start_ns),
            c.end_ns
                .map_or_else(|| "open".to_string(), |t| day(Some(t))),
            opt(c.sample_rate_hz),
            opt(c.azimuth_deg),
            opt(c.dip_deg),
            opt(s.map(|s| s.value)),
            s.map_or("-", |s| s.input_units.as_str()),
            c.gain_mps2_per_count()
                .map_or_else(|_| "-".to_string(), |g| format!("{g:.4e}")),
        );
    }
    outln!("{} channel epochs", epochs.len());
}
