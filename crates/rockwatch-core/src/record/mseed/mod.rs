//! MiniSEED: the decoded file and its channels (this module), the reader (`reader.rs`), the
//! writer (`writer.rs`) and Steim compression (`steim.rs`); pure Rust, see
//! docs/mseed-reader.md for why no crate is used.
//!
//! [`read_mseed`] reads every data record of a file, decodes its samples (Steim-1, Steim-2,
//! INT16, INT32, FLOAT32, FLOAT64, in either byte order) and groups them by channel
//! (`NET.STA.LOC.CHA`). Each [`Channel`] holds its samples as contiguous [`Segment`]s; breaks
//! in the time series are reported as gaps and overlaps ([`Discontinuity`]).
//!
//! Units: MiniSEED stores no gain. Integer encodings hold raw digitizer counts; the caller
//! converts them with a gain in **m/s² per count** (the convention of the calibration tables
//! in `tests/data/mseed/README.md`, i.e. ObsPy's `stats.calib`): `a_mps2 = counts × gain`.
//! Times are UTC, in integer nanoseconds since 1970-01-01T00:00:00Z (`*_ns`).
//!
//! Robustness policy (every file gives a result or a [`RecordError`], never a panic or a hang):
//! - Bytes that are not a MiniSEED data record (noise between records, trailing junk, SEED
//!   control headers) are skipped; each skipped run is listed in [`MseedFile::warnings`].
//!   This is the only kind of partial read.
//! - A record whose header looks like MiniSEED but is inconsistent (bad time, bad blockette
//!   chain, truncated, unsupported encoding, Steim integrity check failure, CRC mismatch,
//!   non-finite float samples, …) is an error for the whole file, naming the record and
//!   its byte offset: a damaged record is never silently dropped or half-decoded.
//! - Text (ASCII/log) records carry no samples: they are skipped with a warning; a file with
//!   nothing else is an error.
//! - A MiniSEED 2 record without blockette 1000 (pre-SEED-2.3) has its length inferred from
//!   the position of the next record header and is decoded as Steim-1 in the header's byte
//!   order (the SEED default, as libmseed does). Steim's built-in checks (sample count and the
//!   reverse integration constant) must pass, so a wrong guess is an error, not wrong
//!   samples. A warning says so.
//!
//! Writing: [`write_mseed`] / [`encode_mseed`] write MiniSEED 2.4 (FLOAT32, FLOAT64,
//! Steim-2); they live in `writer.rs` and are re-exported here (see that module's
//! documentation and docs/mseed-writer.md).
//!
//! Layout: `reader`, `writer` and `steim` use only this parent module (which imports what
//! they share), never each other.

mod reader;
mod steim;
mod writer;

use std::fmt::Write as _;
use std::path::Path;

use super::{Record, RecordError};
use crate::azimuth::Azimuth;
use steim::{decode_steim, encode_steim2, fits, Steim};

pub use reader::{parse_mseed, read_mseed, record_stream_id};
pub use writer::{
    encode_mseed, write_mseed, Blockette1001, ChannelData, FloatEncoding, RecordLength,
    SampleRateError, SampleRateFactors, Samples, SeedId, SeedIdError, WriteOptions,
    MAX_WRITE_RATE_HZ,
};

/// Nanoseconds per second.
pub const NS_PER_S: i64 = 1_000_000_000;

/// The decoded contents of a MiniSEED file.
#[derive(Debug, Clone, PartialEq)]
pub struct MseedFile {
    /// The file the data came from (for messages).
    pub source: String,
    /// Channels in order of first appearance in the file.
    pub channels: Vec<Channel>,
    /// What was skipped or assumed while reading (skipped bytes, text records, missing
    /// blockette 1000, …). Empty for a clean file.
    pub warnings: Vec<String>,
}

/// Whether a channel's samples came from integer encodings (raw counts) or floating-point
/// encodings (often already in physical units; MiniSEED does not say which).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SampleKind {
    /// Steim-1/2, INT16 or INT32: raw digitizer counts.
    Integer,
    /// FLOAT32 or FLOAT64.
    Float,
    /// Records of both kinds.
    Mixed,
}

/// One channel (`NET.STA.LOC.CHA`) of a MiniSEED file.
#[derive(Debug, Clone, PartialEq)]
pub struct Channel {
    /// The file the channel came from (for messages).
    pub source: String,
    /// Network code (trailing blanks removed).
    pub net: String,
    /// Station code.
    pub sta: String,
    /// Location code (often empty).
    pub loc: String,
    /// Channel code (e.g. `HNE`); FDSN source identifiers whose band/source/subsource codes
    /// are not single characters give `B_S_SS`.
    pub cha: String,
    /// Nominal sampling rate (Hz), > 0.
    pub sample_rate_hz: f64,
    /// Time of the first sample (ns since the Unix epoch, UTC).
    pub start_time_ns: i64,
    /// Integer (counts) or floating-point samples.
    pub sample_kind: SampleKind,
    /// Contiguous runs of samples, in time order (sample units: counts for integer encodings,
    /// as stored for float encodings, or m/s² after [`Channel::counts_to_mps2`]).
    pub segments: Vec<Segment>,
    /// Missing data between consecutive segments.
    pub gaps: Vec<Discontinuity>,
    /// Segments that start before the previous one ended.
    pub overlaps: Vec<Discontinuity>,
}

/// A contiguous run of uniformly sampled values.
#[derive(Debug, Clone, PartialEq)]
pub struct Segment {
    /// Time of the first sample (ns since the Unix epoch, UTC).
    pub start_time_ns: i64,
    /// The samples, one every `1 / sample_rate_hz` seconds.
    pub samples: Vec<f64>,
}

/// A break between segment `after_segment` and the next one.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Discontinuity {
    /// Index (in [`Channel::segments`]) of the segment before the break.
    pub after_segment: usize,
    /// When the next sample was due: start of segment `after_segment` + its length × dt
    /// (ns since the epoch).
    pub expected_ns: i64,
    /// When the next segment actually starts (ns since the epoch).
    pub actual_ns: i64,
    /// Size of the break (s), ≥ 0: `|actual − expected|`.
    pub size_s: f64,
    /// Size of the break in sample intervals (`size_s × sample_rate_hz`), ≥ 0.
    pub size_samples: f64,
}

/// What to do with gaps and overlaps when a channel is turned into one uniform series.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GapFill {
    /// Any gap or overlap is an error.
    Reject,
    /// Gaps are filled with zeros; in an overlap the earlier samples are kept.
    Zeros,
    /// Gaps are filled by linear interpolation between the samples on either side; in an
    /// overlap the earlier samples are kept.
    Linear,
}

impl Channel {
    /// `NET.STA.LOC.CHA`.
    #[must_use]
    pub fn id(&self) -> String {
        format!("{}.{}.{}.{}", self.net, self.sta, self.loc, self.cha)
    }

    /// Sampling interval (s).
    #[must_use]
    pub fn dt_s(&self) -> f64 {
        1.0 / self.sample_rate_hz
    }

    /// Total number of samples over all segments.
    #[must_use]
    pub fn sample_count(&self) -> usize {
        self.segments.iter().map(|s| s.samples.len()).sum()
    }

    /// Time just after the last sample of the last segment (ns since the epoch).
    #[must_use]
    pub fn end_time_ns(&self) -> i64 {
        self.segments
            .iter()
            .map(|s| {
                s.start_time_ns
                    .saturating_add(samples_to_ns(s.samples.len(), self.sample_rate_hz))
            })
            .max()
            .unwrap_or(self.start_time_ns)
    }

    /// Converts counts to m/s²: returns a copy with every sample multiplied by
    /// `mps2_per_count` (gain in (m/s²)/count, finite and > 0; use 1.0 for data already
    /// in m/s²).
    pub fn counts_to_mps2(&self, mps2_per_count: f64) -> Result<Channel, RecordError> {
        check_gain(self, mps2_per_count)?;
        let mut out = self.clone();
        for segment in &mut out.segments {
            segment
                .samples
                .iter_mut()
                .for_each(|x| *x *= mps2_per_count);
        }
        Ok(out)
    }

    /// Joins the segments into one uniform series starting at [`Channel::start_time_ns`],
    /// handling gaps and overlaps as `fill` says. Sample units are unchanged.
    pub fn contiguous_samples(&self, fill: GapFill) -> Result<Vec<f64>, RecordError> {
        let err = |problem: String| RecordError::new(Path::new(&self.source), None, problem);
        if fill == GapFill::Reject && !(self.gaps.is_empty() && self.overlaps.is_empty()) {
            let mut text = format!(
                "channel {} has {} gap(s) and {} overlap(s)",
                self.id(),
                self.gaps.len(),
                self.overlaps.len()
            );
            for (kind, d) in self
                .gaps
                .iter()
                .map(|d| ("gap", d))
                .chain(self.overlaps.iter().map(|d| ("overlap", d)))
                .take(5)
            {
                let _ = write!(
                    text,
                    "; {kind} of {:.6} s ({:.1} samples) at {}",
                    d.size_s,
                    d.size_samples,
                    format_time_ns(d.expected_ns)
                );
            }
            text.push_str("; ask for gap filling to join the segments");
            return Err(err(text));
        }
        let mut out: Vec<f64> = Vec::with_capacity(self.sample_count());
        for segment in &self.segments {
            let offset_ns = segment.start_time_ns.saturating_sub(self.start_time_ns);
            let position = (offset_ns as f64 * self.sample_rate_hz / NS_PER_S as f64).round();
            if !(position >= 0.0 && position + (segment.samples.len() as f64) <= MAX_FILLED_SAMPLES)
            {
                return Err(err(format!(
                    "channel {}: filling the gaps up to the segment at {} would need {position} \
                     samples (more than {MAX_FILLED_SAMPLES})",
                    self.id(),
                    format_time_ns(segment.start_time_ns)
                )));
            }
            let position = position as usize;
            if position >= out.len() {
                let missing = position - out.len();
                let before = out.last().copied();
                let after = segment.samples.first().copied().unwrap_or(0.0);
                for k in 0..missing {
                    let value = match (fill, before) {
                        (GapFill::Linear, Some(b)) => {
                            b + (after - b) * (k + 1) as f64 / (missing + 1) as f64
                        }
                        (GapFill::Linear, None) => after,
                        _ => 0.0,
                    };
                    out.push(value);
                }
                out.extend_from_slice(&segment.samples);
            } else {
                // Overlap: keep the earlier samples, append only what extends past them.
                let already = out.len() - position;
                if let Some(rest) = segment.samples.get(already..) {
                    out.extend_from_slice(rest);
                }
            }
        }
        Ok(out)
    }

    /// Turns this channel into a horizontal-only [`Record`] in m/s², with the gain
    /// `mps2_per_count` ((m/s²)/count, > 0; 1.0 for data already in m/s²).
    pub fn to_record(&self, mps2_per_count: f64, fill: GapFill) -> Result<Record, RecordError> {
        record_from_channels((self, mps2_per_count), None, fill)
    }
}

/// Most samples a gap-filled series may have (2^27, 1 GiB of f64): a larger gap is an error.
const MAX_FILLED_SAMPLES: f64 = 134_217_728.0;

fn check_gain(channel: &Channel, mps2_per_count: f64) -> Result<(), RecordError> {
    if mps2_per_count.is_finite() && mps2_per_count > 0.0 {
        Ok(())
    } else {
        Err(RecordError::new(
            Path::new(&channel.source),
            None,
            format!(
                "channel {}: gain must be a finite number of (m/s²)/count > 0, got {mps2_per_count}",
                channel.id()
            ),
        ))
    }
}

/// Largest offset (in sampling intervals) between the sample instants of channels that
/// [`align_channels`] accepts as simultaneous.
///
/// Why 0.1: channels of one instrument are sampled at the same instants, and their time
/// stamps agree to the stamp resolution (MiniSEED 2: 100 µs, or 1 µs with blockette 1001;
/// MiniSEED 3: 1 ns), which is at most 0.02 of a sample at the 200 Hz of strong-motion data.
/// A larger offset means the channels were not sampled together, and combining them (e.g.
/// rotating east/north to a block's axis) would skew one component by that fraction of a
/// sample: a phase error of 2π·f·offset·dt, 18° at the Nyquist frequency for 0.1 sample and
/// 90° for the half sample a nearest-sample match would allow, but at most 3.6° for 0.1
/// sample at the ≤ 10 Hz that rock blocks respond to at 100 Hz sampling.
pub const MAX_ALIGNMENT_OFFSET_SAMPLES: f64 = 0.1;

/// Largest relative difference between the sampling rates of aligned channels: 1e-6 accepts
/// the same nominal rate written as a SEED factor/multiplier or as a FLOAT32 blockette 100
/// (relative rounding 6e-8) and refuses channels at genuinely different rates.
pub const MAX_ALIGNMENT_RATE_DIFFERENCE: f64 = 1e-6;

/// Channels joined into uniform series, scaled, and cut to their common time window
/// (see [`align_channels`]).
#[derive(Debug, Clone, PartialEq)]
pub struct AlignedChannels {
    /// Time of the first common sample (ns since the Unix epoch, UTC): the latest start.
    pub start_time_ns: i64,
    /// The common sampling rate (Hz): the first channel's.
    pub sample_rate_hz: f64,
    /// One series per channel, in the order given, all of the same length (≥ 1), in the
    /// channel's units times its gain.
    pub samples: Vec<Vec<f64>>,
}

impl AlignedChannels {
    /// Sampling interval (s).
    #[must_use]
    pub fn dt_s(&self) -> f64 {
        1.0 / self.sample_rate_hz
    }
}

/// The one channel-alignment routine (records from MiniSEED channels, and the replay's
/// station traces): joins each channel's segments ([`Channel::contiguous_samples`] with
/// `fill`), multiplies it by its gain ((m/s²)/count, finite and > 0; 1.0 keeps the stored
/// units), and cuts all of them to their common time window, from the latest start to the
/// earliest end, skipping whole samples.
///
/// Refused, naming the channels: sampling rates that differ by more than
/// [`MAX_ALIGNMENT_RATE_DIFFERENCE`] (relative); sample instants that differ by more than
/// [`MAX_ALIGNMENT_OFFSET_SAMPLES`] of a sampling interval (after the whole-sample skip);
/// no sample in common. `channels` must not be empty.
pub fn align_channels(
    channels: &[(&Channel, f64)],
    fill: GapFill,
) -> Result<AlignedChannels, RecordError> {
    let Some(&(first, _)) = channels.first() else {
        return Err(RecordError::new(
            Path::new(""),
            None,
            "no channels to align",
        ));
    };
    let err = |problem: String| RecordError::new(Path::new(&first.source), None, problem);
    let mut joined = Vec::with_capacity(channels.len());
    for &(c, gain) in channels {
        check_gain(c, gain)?;
        let mut samples = c.contiguous_samples(fill)?;
        samples.iter_mut().for_each(|x| *x *= gain);
        joined.push(samples);
    }
    let rate = first.sample_rate_hz;
    for (c, _) in channels {
        if (c.sample_rate_hz - rate).abs() > MAX_ALIGNMENT_RATE_DIFFERENCE * rate {
            return Err(err(format!(
                "channels {} ({} Hz) and {} ({} Hz) have different sampling rates",
                first.id(),
                rate,
                c.id(),
                c.sample_rate_hz
            )));
        }
    }
    // The window starts with the channel that starts last.
    let latest = channels
        .iter()
        .map(|&(c, _)| c)
        .max_by_key(|c| c.start_time_ns)
        .unwrap_or(first);
    let start_time_ns = latest.start_time_ns;
    let dt_ns = NS_PER_S as f64 / rate;
    for ((c, _), samples) in channels.iter().zip(&mut joined) {
        let skip_f = start_time_ns.saturating_sub(c.start_time_ns) as f64 / dt_ns;
        let skip = skip_f.round();
        if (skip_f - skip).abs() > MAX_ALIGNMENT_OFFSET_SAMPLES {
            return Err(err(format!(
                "channels {} and {} are not sampled at the same instants (offset {:.3} \
                 samples; at most {MAX_ALIGNMENT_OFFSET_SAMPLES} allowed)",
                latest.id(),
                c.id(),
                skip_f - skip
            )));
        }
        samples.drain(..(skip as usize).min(samples.len()));
    }
    let len = joined.iter().map(Vec::len).min().unwrap_or(0);
    if len == 0 {
        let ids: Vec<String> = channels.iter().map(|(c, _)| c.id()).collect();
        return Err(err(format!(
            "channels {} have no samples in common",
            ids.join(", ")
        )));
    }
    joined.iter_mut().for_each(|v| v.truncate(len));
    Ok(AlignedChannels {
        start_time_ns,
        sample_rate_hz: rate,
        samples: joined,
    })
}

/// Builds a [`Record`] (m/s²) from a horizontal channel and an optional vertical channel,
/// each with its gain in (m/s²)/count. Both are cut to their common time window
/// ([`align_channels`]).
pub fn record_from_channels(
    horizontal: (&Channel, f64),
    vertical: Option<(&Channel, f64)>,
    fill: GapFill,
) -> Result<Record, RecordError> {
    let channels: Vec<(&Channel, f64)> = std::iter::once(horizontal).chain(vertical).collect();
    let aligned = align_channels(&channels, fill)?;
    let dt_s = aligned.dt_s();
    let mut cut = aligned.samples;
    let vertical_mps2 = (cut.len() > 1).then(|| cut.remove(1));
    let ids: Vec<String> = channels.iter().map(|(c, _)| c.id()).collect();
    Ok(Record {
        source: format!("{} [{}]", horizontal.0.source, ids.join(" + ")),
        dt_s,
        horizontal_mps2: cut.remove(0),
        vertical_mps2,
    })
}

/// Builds a [`Record`] (m/s²) from east, north and optional vertical channels (each with its
/// gain in (m/s²)/count). The horizontal component is the ground acceleration along the
/// block's +x axis `azimuth`: `a_h = a_E·sin(az) + a_N·cos(az)` ([`Azimuth::component`]).
/// All channels are cut to their common time window ([`align_channels`]).
pub fn record_from_enz(
    east: (&Channel, f64),
    north: (&Channel, f64),
    vertical: Option<(&Channel, f64)>,
    azimuth: Azimuth,
    fill: GapFill,
) -> Result<Record, RecordError> {
    let channels: Vec<(&Channel, f64)> = [east, north].into_iter().chain(vertical).collect();
    let aligned = align_channels(&channels, fill)?;
    let cut = &aligned.samples;
    let horizontal_mps2 = cut[0]
        .iter()
        .zip(&cut[1])
        .map(|(&e, &n)| azimuth.component(e, n))
        .collect();
    let ids: Vec<String> = channels.iter().map(|(c, _)| c.id()).collect();
    Ok(Record {
        source: format!(
            "{} [{} rotated to azimuth {}°]",
            east.0.source,
            ids.join(" + "),
            azimuth.degrees()
        ),
        dt_s: aligned.dt_s(),
        horizontal_mps2,
        vertical_mps2: cut.get(2).cloned(),
    })
}

/// Reads a MiniSEED file holding exactly one channel of floating-point samples, taken to be
/// in m/s², as a horizontal [`Record`] (used by `Record::read` for `.mseed`, `.ms` and
/// `.miniseed`). Integer (count) data need a gain: use [`read_mseed`] and
/// [`Channel::to_record`]. Gaps and overlaps are an error.
pub fn read_single_channel_record(path: &Path) -> Result<Record, RecordError> {
    let file = read_mseed(path)?;
    let channel = match file.channels.as_slice() {
        [one] => one,
        many => {
            let ids: Vec<String> = many.iter().map(Channel::id).collect();
            return Err(RecordError::new(
                path,
                None,
                format!(
                    "holds {} channels ({}); this command takes one channel per file: \
                     `rockwatch monitor --mseed FILE` reads a station's three channels, or \
                     write each channel to its own file (ObsPy: `st.select(channel=...)`)",
                    many.len(),
                    ids.join(", ")
                ),
            ));
        }
    };
    if channel.sample_kind != SampleKind::Float {
        return Err(RecordError::new(
            path,
            None,
            format!(
                "channel {} holds integer counts, not m/s², and no gain is known for it: give \
                 the station's StationXML (--stationxml FILE), or the station's \
                 `gain_mps2_per_count` in the configuration (rockwatch monitor --config), or \
                 convert the file to m/s² (counts × gain in (m/s²)/count)",
                channel.id()
            ),
        ));
    }
    let mut record = channel.to_record(1.0, GapFill::Reject)?;
    record.source = path.display().to_string();
    Ok(record)
}

/// Days from 1970-01-01 to `year`-01-01 (proleptic Gregorian).
fn days_to_year(year: i64) -> i64 {
    let y = year - 1;
    let days_before = |y: i64| y * 365 + y.div_euclid(4) - y.div_euclid(100) + y.div_euclid(400);
    days_before(y) - days_before(1969)
}

/// MiniSEED 2 nominal sampling rate from the fixed header's factor and multiplier (SEED
/// manual: positive = multiply, negative = divide).
fn v2_sample_rate(factor: i16, multiplier: i16) -> f64 {
    let (f, m) = (f64::from(factor), f64::from(multiplier));
    match (factor, multiplier) {
        (0, _) | (_, 0) => 0.0,
        (1.., 1..) => f * m,
        (1.., _) => -f / m,
        (_, 1..) => -m / f,
        _ => 1.0 / (f * m),
    }
}

fn samples_to_ns(count: usize, rate_hz: f64) -> i64 {
    (count as f64 * NS_PER_S as f64 / rate_hz).round() as i64
}

/// Formats ns since the epoch as ISO 8601 UTC (`YYYY-MM-DDThh:mm:ss.fffffffffZ`); see
/// [`format_utc_ns`](crate::utc::format_utc_ns).
#[must_use]
pub fn format_time_ns(t_ns: i64) -> String {
    crate::utc::format_utc_ns(i128::from(t_ns))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn format_time_round_trips_known_instant() {
        assert_eq!(
            format_time_ns(839_700_744 * NS_PER_S + 5),
            "1996-08-10T18:12:24.000000005Z"
        );
        assert_eq!(format_time_ns(-1), "1969-12-31T23:59:59.999999999Z");
    }

    #[test]
    fn sample_rate_factor_multiplier_follows_seed_manual() {
        assert_eq!(v2_sample_rate(20, 1), 20.0);
        assert_eq!(v2_sample_rate(-10, 1), 0.1); // period 10 s
        assert_eq!(v2_sample_rate(-10, -1), 0.1);
        assert_eq!(v2_sample_rate(1, -10), 0.1);
        assert_eq!(v2_sample_rate(0, 1), 0.0);
    }

    #[test]
    fn gap_fill_linear_interpolates_between_neighbours() {
        let channel = Channel {
            source: "test".into(),
            net: "XX".into(),
            sta: "S".into(),
            loc: String::new(),
            cha: "HNZ".into(),
            sample_rate_hz: 10.0,
            start_time_ns: 0,
            sample_kind: SampleKind::Float,
            segments: vec![
                Segment {
                    start_time_ns: 0,
                    samples: vec![0.0, 1.0],
                },
                // Next sample due at 0.2 s; this one starts at 0.5 s: 3 missing samples.
                Segment {
                    start_time_ns: 500_000_000,
                    samples: vec![5.0, 6.0],
                },
            ],
            gaps: vec![Discontinuity {
                after_segment: 0,
                expected_ns: 200_000_000,
                actual_ns: 500_000_000,
                size_s: 0.3,
                size_samples: 3.0,
            }],
            overlaps: vec![],
        };
        assert!(channel.contiguous_samples(GapFill::Reject).is_err());
        assert_eq!(
            channel.contiguous_samples(GapFill::Linear).unwrap(),
            vec![0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0]
        );
        assert_eq!(
            channel.contiguous_samples(GapFill::Zeros).unwrap(),
            vec![0.0, 1.0, 0.0, 0.0, 0.0, 5.0, 6.0]
        );
    }

    /// A one-segment 100 Hz float channel `cha` starting at `start_ns`.
    fn channel_at(cha: &str, start_ns: i64, samples: Vec<f64>) -> Channel {
        Channel {
            source: "test".into(),
            net: "XX".into(),
            sta: "S".into(),
            loc: String::new(),
            cha: cha.into(),
            sample_rate_hz: 100.0,
            start_time_ns: start_ns,
            sample_kind: SampleKind::Float,
            segments: vec![Segment {
                start_time_ns: start_ns,
                samples,
            }],
            gaps: vec![],
            overlaps: vec![],
        }
    }

    #[test]
    fn alignment_accepts_offsets_up_to_a_tenth_of_a_sample_and_refuses_beyond() {
        // dt = 10 ms; the north channel starts 2 samples plus a fraction later.
        let east = channel_at("HNE", 0, (0..10).map(f64::from).collect());
        let dt_ns = 10_000_000;
        let north_at = |fraction: f64| {
            let start = 2 * dt_ns + (fraction * dt_ns as f64).round() as i64;
            channel_at("HNN", start, vec![-1.0; 10])
        };
        // Inside: ±0.09 sample counts as simultaneous; the common window starts at the later
        // channel and skips 2 east samples.
        for fraction in [0.09, -0.09] {
            let north = north_at(fraction);
            let aligned = align_channels(&[(&east, 2.0), (&north, 1.0)], GapFill::Reject).unwrap();
            assert_eq!(aligned.start_time_ns, north.start_time_ns);
            assert_eq!(aligned.sample_rate_hz, 100.0);
            assert_eq!(
                aligned.samples[0],
                vec![4.0, 6.0, 8.0, 10.0, 12.0, 14.0, 16.0, 18.0]
            );
            assert_eq!(aligned.samples[1], vec![-1.0; 8]);
        }
        // Outside: 0.11 sample is refused, naming both channels and the offset.
        let north = north_at(0.11);
        let e = align_channels(&[(&east, 1.0), (&north, 1.0)], GapFill::Reject).unwrap_err();
        assert_eq!(
            e.to_string(),
            "test: channels XX.S..HNN and XX.S..HNE are not sampled at the same instants \
             (offset 0.110 samples; at most 0.1 allowed)"
        );
    }

    #[test]
    fn alignment_refuses_different_rates_and_disjoint_windows() {
        let east = channel_at("HNE", 0, vec![0.0; 10]);
        let mut north = channel_at("HNN", 0, vec![0.0; 10]);
        north.sample_rate_hz = 100.0 * (1.0 + 2.0 * MAX_ALIGNMENT_RATE_DIFFERENCE);
        let e = align_channels(&[(&east, 1.0), (&north, 1.0)], GapFill::Reject).unwrap_err();
        assert!(e.to_string().contains("different sampling rates"), "{e}");
        north.sample_rate_hz = 100.0 * (1.0 + 0.5 * MAX_ALIGNMENT_RATE_DIFFERENCE);
        assert!(align_channels(&[(&east, 1.0), (&north, 1.0)], GapFill::Reject).is_ok());
        let late = channel_at("HNN", 1_000_000_000, vec![0.0; 10]);
        let e = align_channels(&[(&east, 1.0), (&late, 1.0)], GapFill::Reject).unwrap_err();
        assert!(e.to_string().contains("no samples in common"), "{e}");
    }
}
