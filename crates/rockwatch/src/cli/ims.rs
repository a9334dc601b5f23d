//! `rockwatch ims`: intensity measures of a record, as a table or as JSON.

use anyhow::{bail, Context};
use rockwatch_core::differentiate::differentiate;
use rockwatch_core::ims::baseline::{pre_event, remove_offset};
use rockwatch_core::ims::spectrum::format_period_s;
use rockwatch_core::ims::{compute_ims, ImOptions, ImSet, DEFAULT_SA_PERIODS_S};
use rockwatch_core::inventory::{Inventory, SensorInput};
use rockwatch_core::record::mseed::{read_mseed, Channel, GapFill};
use rockwatch_core::record::{Record, STANDARD_GRAVITY_MPS2};
use serde::ser::{Serialize, SerializeMap, Serializer};
use std::path::{Path, PathBuf};

use super::OutputFormat as Format;

/// Computes the intensity measures of a record (definitions: spec/intensity-measures.md).
///
/// The record is used as given (no baseline correction, padding or filtering) unless --demean
/// is given; spectral IMs use 5 % damping and the exact piecewise-linear SDOF solution; ASI,
/// SI and VSI integrate over the 0.10–3.00 s grid (step 0.01 s) for the eight ranges of the
/// seed's study.
///
/// A DC offset (raw records often carry one) integrates into PGV and PGD: when the mean of a
/// component's pre-event part (its first 5 %) exceeds 5 % of its PGA, a warning on stderr says
/// so and names --demean.
#[derive(Debug, clap::Args)]
pub struct ImsArgs {
    /// Record file: PEER NGA .AT2 (values in g), CSV `t,ax[,ay]` (s, m/s²), or MiniSEED
    /// (.mseed/.ms/.miniseed) with one floating-point channel in m/s². Its (first) component
    /// is the horizontal one.
    #[arg(long, value_name = "FILE")]
    pub record: PathBuf,

    /// Vertical component (AT2, CSV `t,ax` or MiniSEED), same sampling interval and length as the
    /// record; its IMs are reported too (JSON key `vertical`).
    #[arg(long, value_name = "FILE")]
    pub vertical: Option<PathBuf>,

    /// StationXML documents giving the gain of MiniSEED --record/--vertical channels, so that
    /// integer counts become m/s² (the epoch in force at the record's start; acceleration
    /// units only; its sampling rate must match). See docs/stationxml.md.
    #[arg(long, value_name = "FILE", num_args = 1..)]
    pub stationxml: Vec<PathBuf>,

    /// A velocity channel of --stationxml (input units M/S) is differentiated to acceleration
    /// (central differences on the sample grid, docs/stationxml.md) instead of refused.
    #[arg(long = "differentiate-velocity", requires = "stationxml")]
    pub differentiate_velocity: bool,

    /// Comma-separated periods (s) at which SA is reported
    /// [default: 0.1,0.2,0.3,0.5,1.0,1.5,2.0,2.5,3.0].
    #[arg(
        long,
        value_name = "T1,T2,...",
        value_delimiter = ',',
        allow_negative_numbers = true
    )]
    pub periods: Option<Vec<f64>>,

    /// Subtract from each component the mean of its pre-event part (its first 5 %, at least
    /// 20 samples) before computing the IMs: removes a DC offset, which would otherwise
    /// integrate into PGV and PGD.
    #[arg(long)]
    pub demean: bool,

    /// Output format: `text` (a table with units) or `json` (one object, SI units).
    ///
    /// JSON keys: pga (m/s²), pgv (m/s), pgd (m), cav (m/s), arias (m/s), t5, t75, t95,
    /// d5_75, d5_95 (s), a_rms (m/s²), ic (m^1.5/s^2.5), sma (m/s²), eda (m/s², 9 Hz
    /// zero-phase low-pass), tp (s), pgv_pga (s), epv (m/s), sa (object: period in s such as
    /// "0.1" → m/s²), asi (object: range such as "0.1-0.5" → m/s), si and vsi (range → m),
    /// dt (s), npts. When a vertical component is given (--vertical, or a CSV record with an
    /// `ay` column) the key `vertical` holds the same object for it.
    #[arg(long, value_enum, default_value_t = Format::Text)]
    pub format: Format,
}

/// Runs `rockwatch ims`.
pub fn run(args: ImsArgs) -> anyhow::Result<()> {
    let inventory = match args.stationxml.as_slice() {
        [] => None,
        files => Some(Inventory::read_all(files)?),
    };
    let differentiate = args.differentiate_velocity;
    let mut record = read_record(&args.record, inventory.as_ref(), differentiate)
        .context("cannot read the record")?;
    if let Some(path) = &args.vertical {
        let vertical = read_record(path, inventory.as_ref(), differentiate)
            .context("cannot read the vertical record")?;
        record
            .attach_vertical_record(vertical, path)
            .context("cannot use the vertical record")?;
    }
    let options = ImOptions {
        periods_s: args
            .periods
            .clone()
            .unwrap_or_else(|| DEFAULT_SA_PERIODS_S.to_vec()),
        ..ImOptions::default()
    };
    let source = record.source.clone();
    // The vertical's own file names it; a CSV record's second column is the record's.
    let vertical_source = args
        .vertical
        .as_ref()
        .map_or_else(|| source.clone(), |p| p.display().to_string());
    let dt_s = record.dt_s;
    check_baseline(
        &source,
        "horizontal",
        &mut record.horizontal_mps2,
        dt_s,
        args.demean,
    );
    if let Some(v) = &mut record.vertical_mps2 {
        check_baseline(&vertical_source, "vertical", v, dt_s, args.demean);
    }
    let horizontal = compute_ims(&record.horizontal_mps2, record.dt_s, &options)
        .with_context(|| format!("{source}: cannot compute the intensity measures"))?;
    let vertical = match &record.vertical_mps2 {
        Some(v) => Some(compute_ims(v, record.dt_s, &options).with_context(|| {
            format!("{vertical_source}: cannot compute the vertical intensity measures")
        })?),
        None => None,
    };
    let text = match args.format {
        Format::Json => {
            let output = JsonIms {
                ims: &horizontal,
                vertical: vertical.as_ref(),
            };
            serde_json::to_string_pretty(&output)? + "\n"
        }
        Format::Text => {
            let mut text = text_table(&source, "horizontal", &horizontal);
            if let Some(v) = &vertical {
                text.push('\n');
                text.push_str(&text_table(&vertical_source, "vertical", v));
            }
            text
        }
    };
    write_stdout(&text)
}

/// Reports a DC offset of one component on stderr, and removes it with `demean`.
fn check_baseline(source: &str, component: &str, a: &mut [f64], dt_s: f64, demean: bool) {
    let Some(pre) = pre_event(a, dt_s) else {
        return;
    };
    if demean {
        remove_offset(a, pre.mean);
    } else if pre.is_offset() {
        eprintln!(
            "rockwatch: warning: {source} ({component}): its first {:.2} s average {:.4} m/s², {:.0} % of its PGA: a DC offset, which integrates into PGV and PGD; --demean removes it",
            pre.duration_s,
            pre.mean,
            100.0 * pre.mean.abs() / pre.peak
        );
    }
}

/// Reads a record; with an inventory, a MiniSEED file must hold one channel, calibrated to
/// m/s² with its gain from the inventory (integer counts or floats alike); a velocity channel
/// is differentiated first when `differentiate_velocity`, else refused.
fn read_record(
    path: &Path,
    inventory: Option<&Inventory>,
    differentiate_velocity: bool,
) -> anyhow::Result<Record> {
    let is_mseed = matches!(
        path.extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase)
            .as_deref(),
        Some("mseed" | "ms" | "miniseed")
    );
    let (Some(inventory), true) = (inventory, is_mseed) else {
        return Ok(Record::read(path)?);
    };
    let file = read_mseed(path)?;
    let [channel] = file.channels.as_slice() else {
        let ids: Vec<String> = file.channels.iter().map(Channel::id).collect();
        bail!(
            "{}: holds {} channels ({}); a record file must hold exactly one",
            path.display(),
            ids.len(),
            ids.join(", ")
        );
    };
    let start_ns = channel.segments.first().map_or(0, |s| s.start_time_ns);
    let calibration = inventory
        .calibration_at_with(
            &channel.id(),
            i128::from(start_ns),
            channel.sample_rate_hz,
            differentiate_velocity,
        )
        .with_context(|| path.display().to_string())?;
    let gain = calibration.gain_mps2_per_count;
    // The gain's magnitude through the reader's conversion, then its sign (reversed polarity).
    let mut record = channel.to_record(gain.abs(), GapFill::Reject)?;
    if calibration.input == SensorInput::Velocity {
        // m/s → m/s² on the sample grid (the core's scheme, docs/stationxml.md).
        record.horizontal_mps2 = differentiate(&record.horizontal_mps2, 1.0 / record.dt_s);
        if record.horizontal_mps2.is_empty() {
            bail!("{}: one sample cannot be differentiated", path.display());
        }
    }
    if gain < 0.0 {
        record.horizontal_mps2.iter_mut().for_each(|a| *a = -*a);
    }
    record.source = path.display().to_string();
    Ok(record)
}

/// Writes to standard output; a closed pipe (e.g. `| head`) is not an error.
fn write_stdout(text: &str) -> anyhow::Result<()> {
    use std::io::Write;
    let mut stdout = std::io::stdout().lock();
    match stdout
        .write_all(text.as_bytes())
        .and_then(|()| stdout.flush())
    {
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Ok(()),
        result => result.context("cannot write to standard output"),
    }
}

/// The JSON object of one component (keys in the documented order).
struct JsonIms<'a> {
    ims: &'a ImSet,
    vertical: Option<&'a ImSet>,
}

/// A JSON object whose keys keep the given order.
struct OrderedMap(Vec<(String, f64)>);

impl Serialize for OrderedMap {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let mut map = serializer.serialize_map(Some(self.0.len()))?;
        for (key, value) in &self.0 {
            map.serialize_entry(key, value)?;
        }
        map.end()
    }
}

impl Serialize for JsonIms<'_> {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let ims = self.ims;
        let mut map = serializer.serialize_map(None)?;
        for (key, value) in [
            ("pga", ims.pga_mps2),
            ("pgv", ims.pgv_mps),
            ("pgd", ims.pgd_m),
            ("cav", ims.cav_mps),
            ("arias", ims.arias_mps),
            ("t5", ims.t5_s),
            ("t75", ims.t75_s),
            ("t95", ims.t95_s),
            ("d5_75", ims.d5_75_s),
            ("d5_95", ims.d5_95_s),
            ("a_rms", ims.a_rms_mps2),
            ("ic", ims.ic),
            ("sma", ims.sma_mps2),
            ("eda", ims.eda_mps2),
            ("tp", ims.tp_s),
            ("pgv_pga", ims.pgv_pga_s),
            ("epv", ims.epv_mps),
        ] {
            map.serialize_entry(key, &value)?;
        }
        let sa = ims
            .spectral
            .iter()
            .map(|p| (format_period_s(p.period_s), p.sa_mps2))
            .collect();
        map.serialize_entry("sa", &OrderedMap(sa))?;
        let by_range = |f: fn(&rockwatch_core::ims::SpectralIntensities) -> f64| {
            OrderedMap(
                ims.study_intensities
                    .iter()
                    .map(|si| (si.range.label(), f(si)))
                    .collect(),
            )
        };
        map.serialize_entry("asi", &by_range(|si| si.asi_mps))?;
        map.serialize_entry("si", &by_range(|si| si.si_m))?;
        map.serialize_entry("vsi", &by_range(|si| si.vsi_m))?;
        map.serialize_entry("dt", &ims.dt_s)?;
        map.serialize_entry("npts", &ims.npts)?;
        if let Some(ims) = self.vertical {
            let vertical = JsonIms {
                ims,
                vertical: None,
            };
            map.serialize_entry("vertical", &vertical)?;
        }
        map.end()
    }
}

/// The text table of one component.
fn text_table(source: &str, component: &str, ims: &ImSet) -> String {
    use std::fmt::Write;
    let mut out = String::new();
    let g = STANDARD_GRAVITY_MPS2;
    let _ = writeln!(
        out,
        "{source} ({component}): {} samples, dt = {} s, damping {} %",
        ims.npts,
        ims.dt_s,
        100.0 * ims.damping
    );
    let mut row = |name: &str, value: f64, unit: &str, note: String| {
        let line = format!("  {name:<16} {value:>14.6} {unit:<12} {note}");
        let _ = writeln!(out, "{}", line.trim_end());
    };
    let in_g = |a: f64| format!("({:.4} g)", a / g);
    row("PGA", ims.pga_mps2, "m/s2", in_g(ims.pga_mps2));
    row("PGV", ims.pgv_mps, "m/s", String::new());
    row("PGD", ims.pgd_m, "m", String::new());
    row("CAV", ims.cav_mps, "m/s", String::new());
    row("Arias", ims.arias_mps, "m/s", String::new());
    row("t5", ims.t5_s, "s", String::new());
    row("t75", ims.t75_s, "s", String::new());
    row("t95", ims.t95_s, "s", String::new());
    row("D5-75", ims.d5_75_s, "s", String::new());
    row("D5-95", ims.d5_95_s, "s", String::new());
    row("a_rms", ims.a_rms_mps2, "m/s2", in_g(ims.a_rms_mps2));
    row("Ic", ims.ic, "m^1.5/s^2.5", String::new());
    row("SMA", ims.sma_mps2, "m/s2", in_g(ims.sma_mps2));
    row("EDA (9 Hz)", ims.eda_mps2, "m/s2", in_g(ims.eda_mps2));
    row("Tp", ims.tp_s, "s", String::new());
    row("PGV/PGA", ims.pgv_pga_s, "s", String::new());
    row("EPV", ims.epv_mps, "m/s", String::new());
    for p in &ims.spectral {
        let name = format!("SA({} s)", format_period_s(p.period_s));
        row(&name, p.sa_mps2, "m/s2", in_g(p.sa_mps2));
    }
    for si in &ims.study_intensities {
        let label = si.range.label();
        row(&format!("ASI {label}"), si.asi_mps, "m/s", String::new());
        row(&format!("SI {label}"), si.si_m, "m", String::new());
        row(&format!("VSI {label}"), si.vsi_m, "m", String::new());
    }
    out
}
