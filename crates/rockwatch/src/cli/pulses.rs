//! `rockwatch pulses`: synthetic near-fault pulses (Mavroeidis & Papageorgiou 2003 with
//! Rupakhety et al. 2011 parameters, Latin-hypercube sampled), one record file per pulse
//! (AT2, CSV or MiniSEED).

use super::OutputFormat;
use anyhow::{bail, Context};
use rockwatch_core::pulse::{sample_pulses, PulseScenario, SampledPulse};
use rockwatch_core::record::mseed::{
    write_mseed, ChannelData, FloatEncoding, SampleRateFactors, Samples, WriteOptions,
};
use rockwatch_core::record::{write_at2, write_csv};
use std::path::PathBuf;

/// File format of the written records.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum FileFormat {
    /// PEER NGA .AT2, accelerations in g.
    At2,
    /// CSV with header `t,ax` (s, m/s²).
    Csv,
    /// MiniSEED 2.4, samples in m/s² (see --mseed-encoding).
    Mseed,
}

/// Sample encoding of MiniSEED record files.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum MseedEncoding {
    /// IEEE double precision: the samples exactly.
    Float64,
    /// IEEE single precision: half the size, relative rounding <= 6e-8.
    Float32,
}

/// Generate synthetic near-fault velocity pulses and write their acceleration records.
///
/// Each pulse is the Mavroeidis & Papageorgiou (2003) velocity pulse starting at t = 0, with
/// period Tp, peak velocity Vp, oscillatory character gamma and phase nu drawn by Latin
/// hypercube from the Rupakhety et al. (2011) laws: log10 Tp ~ N(-2.87 + 0.47 Mw, 0.18),
/// log10 Vp[cm/s] ~ N(-5.17 + 1.98 M - 0.14 M² - 0.10 log10(R² + 0.56²), 0.16) with
/// M = min(Mw, 7), gamma ~ N(1.8, 0.4) truncated to gamma > 1, nu ~ U[-pi/2, pi/2]. The
/// amplitude A is solved so that the pulse's peak velocity equals Vp. The acceleration (the
/// exact derivative of the velocity) is sampled from t = 0 through the end of the pulse.
#[derive(Debug, clap::Args)]
pub struct PulsesArgs {
    /// Moment magnitude Mw, in (0, 10] (the Vp law saturates at Mw 7).
    #[arg(long, allow_negative_numbers = true)]
    pub mw: f64,

    /// Distance R (km), >= 0.
    #[arg(long = "r-km", allow_negative_numbers = true)]
    pub r_km: f64,

    /// Number of pulses to generate (1 to 1 000 000).
    #[arg(long, default_value_t = 250,
          value_parser = clap::value_parser!(u32).range(1..=1_000_000))]
    pub count: u32,

    /// Random seed (u64): the same seed and arguments give the same pulses on every
    /// platform. The draws also depend on --count (it sets the Latin-hypercube strata).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,

    /// Sampling interval of the written records (s), > 0.
    #[arg(long, default_value_t = 0.005, allow_negative_numbers = true)]
    pub dt: f64,

    /// Seconds of zero acceleration appended after each pulse (s), >= 0.
    #[arg(long = "pad-s", default_value_t = 0.0, allow_negative_numbers = true)]
    pub pad_s: f64,

    /// Directory for the record files (created if missing; existing files of the same name
    /// are overwritten). Files are named pulse_M<mw>_R<r>_<id>.AT2 (or .csv, .mseed), id
    /// from 1.
    #[arg(long)]
    pub out: PathBuf,

    /// Format of the record FILES: at2 (PEER NGA .AT2 in g, readable by any AT2 reader),
    /// csv (header t,ax; time in s, acceleration in m/s²) or mseed (MiniSEED 2.4, one
    /// channel of acceleration in m/s², 4096-byte big-endian records, quality D). MiniSEED
    /// files are timed from the Unix epoch (sample 0 at 1970-01-01T00:00:00Z) and named
    /// XX.P<id>..<B>NX: network XX (synthetic data), station P + the pulse id's last four
    /// digits (P0001 ...; ids from 10000 also put id / 10000 mod 100 as a two-digit
    /// location code), channel band code by sampling rate per the SEED manual (F >= 1000 Hz,
    /// C >= 250, H >= 80, B >= 10, M > 1, L >= 0.1, V >= 0.01, U below), instrument N
    /// (accelerometer) and orientation X (the block's +x axis, not a compass direction).
    /// The sampling rate 1/--dt must be one MiniSEED 2 can represent exactly (e.g. 200,
    /// 100, 1000/3 Hz).
    #[arg(long = "file-format", value_enum)]
    pub file_format: Option<FileFormat>,

    /// Sample encoding of --file-format mseed files: float64 (exact) or float32 (half the
    /// size, relative rounding <= 6e-8).
    #[arg(long = "mseed-encoding", value_enum, default_value_t = MseedEncoding::Float64)]
    pub mseed_encoding: MseedEncoding,

    /// Format of the summary printed on STANDARD OUTPUT (not of the files): text (a table)
    /// or json: {"pulses": [{"id", "mw", "r_km", "tp_s", "vp_mps", "gamma", "nu_rad",
    /// "a_mps", "duration_s", "pga_mps2", "file"}, ...]} with tp_s the pulse period (s),
    /// vp_mps the peak velocity (m/s), a_mps the M&P amplitude A (m/s), duration_s the pulse
    /// duration gamma·Tp (s), pga_mps2 the largest |acceleration| of the written samples
    /// (m/s²) and file the path of the record file. For compatibility, `--format at2|csv|mseed`
    /// is also accepted: it sets the file format (as --file-format) and prints the text table.
    #[arg(long, value_enum, default_value_t = PulsesFormat::Text)]
    pub format: PulsesFormat,
}

/// `--format`: the summary's format, or (the short form) the files' format.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum PulsesFormat {
    Text,
    Json,
    At2,
    Csv,
    Mseed,
}

impl PulsesArgs {
    /// (file format, stdout format) after reconciling --format and --file-format.
    fn formats(&self) -> anyhow::Result<(FileFormat, OutputFormat)> {
        let short = match self.format {
            PulsesFormat::Text | PulsesFormat::Json => None,
            PulsesFormat::At2 => Some(FileFormat::At2),
            PulsesFormat::Csv => Some(FileFormat::Csv),
            PulsesFormat::Mseed => Some(FileFormat::Mseed),
        };
        let file = match (short, self.file_format) {
            (Some(a), Some(b)) if a != b => {
                bail!("--format and --file-format name different file formats")
            }
            (a, b) => a.or(b).unwrap_or(FileFormat::At2),
        };
        let stdout = if self.format == PulsesFormat::Json {
            OutputFormat::Json
        } else {
            OutputFormat::Text
        };
        Ok((file, stdout))
    }
}

/// One line of the summary (also the JSON element).
#[derive(Debug, serde::Serialize)]
struct PulseSummary {
    id: usize,
    mw: f64,
    r_km: f64,
    tp_s: f64,
    vp_mps: f64,
    gamma: f64,
    nu_rad: f64,
    a_mps: f64,
    duration_s: f64,
    pga_mps2: f64,
    file: String,
}

#[derive(Debug, serde::Serialize)]
struct Summary {
    pulses: Vec<PulseSummary>,
}

/// A pulse set to generate, its flags checked.
struct PulsesPlan {
    scenario: PulseScenario,
    count: usize,
    seed: u64,
    /// Sampling interval of the records (s).
    dt_s: f64,
    /// Zeros appended after each pulse (s).
    pad_s: f64,
    out_dir: PathBuf,
    file_format: FileFormat,
    mseed_encoding: FloatEncoding,
    stdout_format: OutputFormat,
}

/// Generates the pulses, writes one file each, prints the summary.
pub fn run(args: PulsesArgs) -> anyhow::Result<()> {
    let plan = parse(&args)?;
    let pulses = execute(&plan)?;
    match plan.stdout_format {
        OutputFormat::Json => {
            outln!("{}", serde_json::to_string_pretty(&Summary { pulses })?);
        }
        OutputFormat::Text => print_table(&pulses),
    }
    Ok(())
}

/// Checks the flags.
fn parse(args: &PulsesArgs) -> anyhow::Result<PulsesPlan> {
    let scenario = PulseScenario::new(args.mw, args.r_km).context("invalid scenario")?;
    if !(args.dt.is_finite() && args.dt > 0.0) {
        bail!("--dt must be a positive number of seconds, got {}", args.dt);
    }
    if !(args.pad_s.is_finite() && args.pad_s >= 0.0) {
        bail!(
            "--pad-s must be a number of seconds >= 0, got {}",
            args.pad_s
        );
    }
    let (file_format, stdout_format) = args.formats()?;
    if file_format == FileFormat::Mseed {
        SampleRateFactors::from_rate_hz(1.0 / args.dt).map_err(|e| {
            anyhow::anyhow!("--dt {} s cannot be written as MiniSEED: {e}", args.dt)
        })?;
    }
    Ok(PulsesPlan {
        scenario,
        count: args.count as usize,
        seed: args.seed,
        dt_s: args.dt,
        pad_s: args.pad_s,
        out_dir: args.out.clone(),
        file_format,
        mseed_encoding: match args.mseed_encoding {
            MseedEncoding::Float64 => FloatEncoding::Float64,
            MseedEncoding::Float32 => FloatEncoding::Float32,
        },
        stdout_format,
    })
}

/// Samples the pulses and writes one record file each.
fn execute(plan: &PulsesPlan) -> anyhow::Result<Vec<PulseSummary>> {
    let sampled =
        sample_pulses(&plan.scenario, plan.count, plan.seed).context("generating pulses")?;
    std::fs::create_dir_all(&plan.out_dir)
        .with_context(|| format!("cannot create output directory {}", plan.out_dir.display()))?;
    sampled
        .iter()
        .enumerate()
        .map(|(index, item)| write_pulse(plan, index + 1, item))
        .collect()
}

/// Writes the record file of pulse `id` (from 1).
fn write_pulse(plan: &PulsesPlan, id: usize, item: &SampledPulse) -> anyhow::Result<PulseSummary> {
    let (mw, r_km) = (plan.scenario.mw(), plan.scenario.r_km());
    let width = plan.count.to_string().len().max(4);
    let extension = match plan.file_format {
        FileFormat::At2 => "AT2",
        FileFormat::Csv => "csv",
        FileFormat::Mseed => "mseed",
    };
    let (p, pulse) = (&item.parameters, &item.pulse);
    let mut record = pulse
        .to_record_padded(plan.dt_s, plan.pad_s)
        .with_context(|| format!("sampling pulse {id}"))?;
    let name = format!("pulse_M{mw}_R{r_km}_{id:0width$}.{extension}");
    let path = plan.out_dir.join(&name);
    record.source = path.display().to_string();
    match plan.file_format {
        FileFormat::At2 => {
            let description = format!(
                "Synthetic Mavroeidis-Papageorgiou pulse {id}: Mw {} R {} km seed {} \
                 Tp {:.6} s Vp {:.6} m/s gamma {:.6} nu {:.6} rad A {:.6} m/s",
                mw,
                r_km,
                plan.seed,
                p.tp_s,
                p.vp_mps,
                p.gamma,
                p.nu_rad,
                pulse.amplitude_mps()
            );
            write_at2(
                &path,
                &record,
                [
                    "PEER NGA STRONG MOTION DATABASE RECORD (synthetic, rockwatch pulses)",
                    &description,
                    "ACCELERATION TIME SERIES IN UNITS OF G",
                ],
            )?;
        }
        FileFormat::Csv => write_csv(&path, &record)?,
        FileFormat::Mseed => {
            let options = WriteOptions {
                float_encoding: plan.mseed_encoding,
                ..WriteOptions::default()
            };
            let channel = ChannelData {
                id: pulse_seed_id(id, 1.0 / plan.dt_s),
                start_time_ns: 0,
                sample_rate_hz: 1.0 / plan.dt_s,
                samples: Samples::Float(&record.horizontal_mps2),
            };
            write_mseed(&path, &[channel], options)?;
        }
    }
    let pga_mps2 = record
        .horizontal_mps2
        .iter()
        .fold(0.0_f64, |m, a| m.max(a.abs()));
    Ok(PulseSummary {
        id,
        mw,
        r_km,
        tp_s: p.tp_s,
        vp_mps: p.vp_mps,
        gamma: p.gamma,
        nu_rad: p.nu_rad,
        a_mps: pulse.amplitude_mps(),
        duration_s: pulse.duration_s(),
        pga_mps2,
        file: path.display().to_string(),
    })
}

/// SEED id of pulse `id` (from 1) sampled at `rate_hz`: `XX.P<last four digits of id>.<loc>.
/// <band>NX`, with loc empty for ids below 10000 and otherwise the two digits of
/// id / 10000 mod 100 (unique for ids 1 to 1 000 000); band per the SEED manual's rate
/// ranges (broadband family).
fn pulse_seed_id(id: usize, rate_hz: f64) -> String {
    let location = if id < 10_000 {
        String::new()
    } else {
        format!("{:02}", (id / 10_000) % 100)
    };
    let band = match rate_hz {
        r if r >= 1000.0 => 'F',
        r if r >= 250.0 => 'C',
        r if r >= 80.0 => 'H',
        r if r >= 10.0 => 'B',
        r if r > 1.0 => 'M',
        r if r >= 0.1 => 'L',
        r if r >= 0.01 => 'V',
        _ => 'U',
    };
    format!("XX.P{:04}.{location}.{band}NX", id % 10_000)
}

fn print_table(pulses: &[PulseSummary]) {
    outln!(
        "{:>6} {:>8} {:>9} {:>7} {:>8} {:>9} {:>8} {:>10}  file",
        "id",
        "Tp s",
        "Vp m/s",
        "gamma",
        "nu rad",
        "A m/s",
        "dur s",
        "PGA m/s²"
    );
    for p in pulses {
        outln!(
            "{:>6} {:>8.3} {:>9.4} {:>7.3} {:>8.3} {:>9.4} {:>8.3} {:>10.4}  {}",
            p.id,
            p.tp_s,
            p.vp_mps,
            p.gamma,
            p.nu_rad,
            p.a_mps,
            p.duration_s,
            p.pga_mps2,
            p.file
        );
    }
    if let Some(first) = pulses.first() {
        outln!(
            "{} pulses for Mw {} at R {} km",
            pulses.len(),
            first.mw,
            first.r_km
        );
    }
}

#[cfg(test)]
mod tests {
    use super::pulse_seed_id;

    #[test]
    fn pulse_seed_ids_follow_the_documented_scheme() {
        assert_eq!(pulse_seed_id(1, 200.0), "XX.P0001..HNX");
        assert_eq!(pulse_seed_id(9999, 100.0), "XX.P9999..HNX");
        assert_eq!(pulse_seed_id(12_345, 50.0), "XX.P2345.01.BNX");
        assert_eq!(pulse_seed_id(1_000_000, 500.0), "XX.P0000.00.CNX");
        assert_eq!(pulse_seed_id(7, 0.05), "XX.P0007..VNX");
    }

    #[test]
    fn pulse_seed_ids_are_unique_over_the_allowed_count() {
        let mut seen = std::collections::HashSet::new();
        for id in 1..=1_000_000 {
            assert!(seen.insert(pulse_seed_id(id, 200.0)), "duplicate at {id}");
        }
    }
}
