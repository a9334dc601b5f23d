//! MiniSEED 2 and 3 reader (pure Rust; see docs/mseed-reader.md for why no crate is used).
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
//! Steim-2); they live in `src/mseed/writer.rs` and are re-exported here (see that module's
//! documentation and docs/mseed-writer.md).

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

use super::{Record, RecordError};

// ---------------------------------------------------------------------------------------
// Writing (MiniSEED 2.4): see src/mseed/writer.rs
// ---------------------------------------------------------------------------------------

pub mod writer;
pub use writer::{
    encode_mseed, write_mseed, Blockette1001, ChannelData, FloatEncoding, RecordLength,
    SampleRateFactors, Samples, SeedId, WriteOptions, MAX_WRITE_RATE_HZ,
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

/// One channel joined into a uniform series (see [`Channel::contiguous_samples`]) and scaled
/// to m/s².
struct Joined {
    start_ns: i64,
    samples_mps2: Vec<f64>,
}

fn join_scaled(channel: &Channel, gain: f64, fill: GapFill) -> Result<Joined, RecordError> {
    check_gain(channel, gain)?;
    let mut samples_mps2 = channel.contiguous_samples(fill)?;
    samples_mps2.iter_mut().for_each(|x| *x *= gain);
    Ok(Joined {
        start_ns: channel.start_time_ns,
        samples_mps2,
    })
}

/// Cuts channels (all at the same sampling rate) to their common time window. The channels'
/// sample instants must coincide to within 10 % of a sampling interval.
fn align(channels: &[&Channel], joined: Vec<Joined>) -> Result<(Vec<Vec<f64>>, f64), RecordError> {
    let first = channels[0];
    let err = |problem: String| RecordError::new(Path::new(&first.source), None, problem);
    let rate = first.sample_rate_hz;
    for c in channels {
        if (c.sample_rate_hz - rate).abs() > 1e-6 * rate {
            return Err(err(format!(
                "channels {} ({} Hz) and {} ({} Hz) have different sampling rates",
                first.id(),
                rate,
                c.id(),
                c.sample_rate_hz
            )));
        }
    }
    let dt_ns = NS_PER_S as f64 / rate;
    let start = joined.iter().map(|j| j.start_ns).max().unwrap_or(0);
    let mut cut = Vec::with_capacity(joined.len());
    for (c, j) in channels.iter().zip(joined) {
        let skip_f = start.saturating_sub(j.start_ns) as f64 / dt_ns;
        let skip = skip_f.round();
        if (skip_f - skip).abs() > 0.1 {
            return Err(err(format!(
                "channels {} and {} are not sampled at the same instants (offset {:.3} samples)",
                first.id(),
                c.id(),
                skip_f - skip
            )));
        }
        let skip = skip as usize;
        cut.push(j.samples_mps2.get(skip..).unwrap_or(&[]).to_vec());
    }
    let len = cut.iter().map(Vec::len).min().unwrap_or(0);
    if len == 0 {
        let ids: Vec<String> = channels.iter().map(|c| c.id()).collect();
        return Err(err(format!(
            "channels {} have no samples in common",
            ids.join(", ")
        )));
    }
    cut.iter_mut().for_each(|v| v.truncate(len));
    Ok((cut, 1.0 / rate))
}

/// Builds a [`Record`] (m/s²) from a horizontal channel and an optional vertical channel,
/// each with its gain in (m/s²)/count. Both are cut to their common time window.
pub fn record_from_channels(
    horizontal: (&Channel, f64),
    vertical: Option<(&Channel, f64)>,
    fill: GapFill,
) -> Result<Record, RecordError> {
    let mut channels = vec![horizontal.0];
    let mut joined = vec![join_scaled(horizontal.0, horizontal.1, fill)?];
    if let Some((v, gain)) = vertical {
        channels.push(v);
        joined.push(join_scaled(v, gain, fill)?);
    }
    let (mut cut, dt_s) = align(&channels, joined)?;
    let vertical_mps2 = (cut.len() > 1).then(|| cut.remove(1));
    let ids: Vec<String> = channels.iter().map(|c| c.id()).collect();
    Ok(Record {
        source: format!("{} [{}]", horizontal.0.source, ids.join(" + ")),
        dt_s,
        horizontal_mps2: cut.remove(0),
        vertical_mps2,
    })
}

/// Builds a [`Record`] (m/s²) from east, north and optional vertical channels (each with its
/// gain in (m/s²)/count). The horizontal component is the ground acceleration along the
/// azimuth `azimuth_deg` (degrees clockwise from north) of the block's +x axis:
/// `a_h = a_N·cos(az) + a_E·sin(az)`. All channels are cut to their common time window.
pub fn record_from_enz(
    east: (&Channel, f64),
    north: (&Channel, f64),
    vertical: Option<(&Channel, f64)>,
    azimuth_deg: f64,
    fill: GapFill,
) -> Result<Record, RecordError> {
    if !azimuth_deg.is_finite() {
        return Err(RecordError::new(
            Path::new(&east.0.source),
            None,
            format!("azimuth must be a finite number of degrees, got {azimuth_deg}"),
        ));
    }
    let mut channels = vec![east.0, north.0];
    let mut joined = vec![
        join_scaled(east.0, east.1, fill)?,
        join_scaled(north.0, north.1, fill)?,
    ];
    if let Some((v, gain)) = vertical {
        channels.push(v);
        joined.push(join_scaled(v, gain, fill)?);
    }
    let (cut, dt_s) = align(&channels, joined)?;
    let (sin, cos) = azimuth_deg.to_radians().sin_cos();
    let horizontal_mps2 = cut[0]
        .iter()
        .zip(&cut[1])
        .map(|(e, n)| n * cos + e * sin)
        .collect();
    let ids: Vec<String> = channels.iter().map(|c| c.id()).collect();
    Ok(Record {
        source: format!(
            "{} [{} rotated to azimuth {azimuth_deg}°]",
            east.0.source,
            ids.join(" + ")
        ),
        dt_s,
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
                    "holds {} channels ({}); a record file must hold exactly one \
                     (read it with rockwatch_core::record::mseed::read_mseed and pick channels)",
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
                "channel {} holds integer counts, not m/s²: convert it with a gain \
                 ((m/s²)/count) via rockwatch_core::record::mseed::read_mseed and Channel::to_record",
                channel.id()
            ),
        ));
    }
    let mut record = channel.to_record(1.0, GapFill::Reject)?;
    record.source = path.display().to_string();
    Ok(record)
}

/// Reads and decodes a MiniSEED (2 or 3) file. See the module documentation for what is
/// skipped and what is an error.
pub fn read_mseed(path: &Path) -> Result<MseedFile, RecordError> {
    let bytes = std::fs::read(path).map_err(|e| RecordError::new(path, None, e.to_string()))?;
    parse_mseed(&bytes, path)
}

/// Decodes MiniSEED bytes; `source` names them in messages (no I/O).
pub fn parse_mseed(bytes: &[u8], source: &Path) -> Result<MseedFile, RecordError> {
    let err = |problem: String| RecordError::new(source, None, problem);
    if bytes.is_empty() {
        return Err(err("empty file: no MiniSEED records".into()));
    }
    if bytes.len() < V3_FIXED {
        return Err(err(format!(
            "only {} bytes: too short to hold a MiniSEED record (at least {V3_FIXED})",
            bytes.len()
        )));
    }
    let mut warnings = Warnings::default();
    let records = scan_records(bytes, &mut warnings).map_err(err)?;
    let channels = assemble_channels(records, source).map_err(err)?;
    Ok(MseedFile {
        source: source.display().to_string(),
        channels,
        warnings: warnings.into_list(),
    })
}

/// Warnings, counted so that one problem repeated in many records is one line.
#[derive(Default)]
struct Warnings {
    counts: Vec<(String, usize)>,
}

impl Warnings {
    fn add(&mut self, text: String) {
        match self.counts.iter_mut().find(|(t, _)| *t == text) {
            Some((_, n)) => *n += 1,
            None => self.counts.push((text, 1)),
        }
    }

    fn into_list(self) -> Vec<String> {
        self.counts
            .into_iter()
            .map(|(t, n)| {
                if n > 1 {
                    format!("{t} ({n} records)")
                } else {
                    t
                }
            })
            .collect()
    }
}

// ---------------------------------------------------------------------------------------
// Record scanning and header parsing
// ---------------------------------------------------------------------------------------

/// One decoded data record.
struct DecodedRecord {
    index: usize,
    offset: usize,
    net: String,
    sta: String,
    loc: String,
    cha: String,
    start_ns: i64,
    sample_rate_hz: f64,
    kind: SampleKind,
    samples: Vec<f64>,
}

/// Data encodings (SEED codes, shared by MiniSEED 2 and 3).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Encoding {
    Text,
    Int16,
    Int32,
    Float32,
    Float64,
    Steim1,
    Steim2,
}

fn encoding_from_code(code: u8) -> Result<Encoding, String> {
    Ok(match code {
        0 => Encoding::Text,
        1 => Encoding::Int16,
        3 => Encoding::Int32,
        4 => Encoding::Float32,
        5 => Encoding::Float64,
        10 => Encoding::Steim1,
        11 => Encoding::Steim2,
        other => {
            let name = match other {
                2 => "INT24",
                12 => "GEOSCOPE 24-bit",
                13 => "GEOSCOPE 16-bit gain ranged, 3-bit exponent",
                14 => "GEOSCOPE 16-bit gain ranged, 4-bit exponent",
                15 => "US National Network",
                16 => "CDSN 16-bit gain ranged",
                17 => "Graefenberg 16-bit gain ranged",
                18 => "IPG Strasbourg 16-bit gain ranged",
                19 => "Steim-3",
                30 => "SRO gain ranged",
                31 => "HGLP",
                32 => "DWWSSN gain ranged",
                33 => "RSTN 16-bit gain ranged",
                _ => "unknown",
            };
            return Err(format!(
                "unsupported data encoding {other} ({name}); supported: Steim-1, Steim-2, \
                 INT16, INT32, FLOAT32, FLOAT64"
            ));
        }
    })
}

/// Where a record's samples are and how to decode them.
struct Payload<'a> {
    data: &'a [u8],
    encoding: Encoding,
    /// Byte order of INT/FLOAT samples and of Steim words.
    big_endian: bool,
    sample_count: usize,
}

/// A record header parsed by either version.
struct Header<'a> {
    length: usize,
    net: String,
    sta: String,
    loc: String,
    cha: String,
    start_ns: i64,
    sample_rate_hz: f64,
    payload: Payload<'a>,
}

fn scan_records(bytes: &[u8], warnings: &mut Warnings) -> Result<Vec<DecodedRecord>, String> {
    let mut records = Vec::new();
    let mut offset = 0;
    let mut skipped_from: Option<usize> = None;
    let mut control_headers = 0usize;
    let mut text_ids: Vec<String> = Vec::new();
    let mut empty_records = 0usize;
    let mut index = 0usize; // 1-based number of the record being read
    while offset < bytes.len() {
        let rest = &bytes[offset..];
        let kind = signature(rest);
        if kind == Signature::None {
            if skipped_from.is_none() {
                skipped_from = Some(offset);
            }
            if let Some(&b) = rest.get(6) {
                if rest.len() >= 8 && is_seq(&rest[..6]) && b"VAST".contains(&b) {
                    control_headers += 1;
                }
            }
            offset += 1;
            continue;
        }
        if let Some(from) = skipped_from.take() {
            warnings.add(format!(
                "skipped {} bytes at byte {from} that are not MiniSEED data records",
                offset - from
            ));
        }
        index += 1;
        let at = |problem: String| format!("record {index} at byte {offset}: {problem}");
        let header = match kind {
            Signature::V3 => parse_v3(rest).map_err(at)?,
            _ => parse_v2(rest, warnings).map_err(at)?,
        };
        let length = header.length;
        match decode_record(header, index, offset, warnings).map_err(at)? {
            Decoded::Samples(record) => records.push(record),
            Decoded::Text(id) => {
                if !text_ids.contains(&id) {
                    text_ids.push(id);
                }
            }
            Decoded::Empty => empty_records += 1,
        }
        offset += length;
    }
    if let Some(from) = skipped_from {
        warnings.add(format!(
            "skipped {} bytes at byte {from} that are not MiniSEED data records",
            bytes.len() - from
        ));
    }
    if records.is_empty() && !text_ids.is_empty() {
        return Err(format!(
            "no samples: the file holds only text (ASCII/log) records ({}), not a time series",
            text_ids.join(", ")
        ));
    }
    if records.is_empty() && empty_records > 0 {
        return Err(format!(
            "no samples: all {empty_records} data record(s) hold 0 samples"
        ));
    }
    if records.is_empty() {
        let mut problem = String::from("no MiniSEED data records found");
        if control_headers > 0 {
            problem.push_str(
                " (found SEED control headers: this looks like a full SEED volume, which is \
                 not supported)",
            );
        }
        return Err(problem);
    }
    Ok(records)
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Signature {
    None,
    V2,
    V3,
}

/// Six characters of a MiniSEED 2 sequence number: digits, blanks or NULs.
fn is_seq(b: &[u8]) -> bool {
    b.iter().all(|&c| c.is_ascii_digit() || c == b' ' || c == 0)
}

/// Whether `b` starts like a MiniSEED record: version 3 (`MS\x03`) or a version 2 fixed
/// header (sequence number, data-quality indicator D/R/Q/M, blank or NUL).
fn signature(b: &[u8]) -> Signature {
    if b.len() >= 3 && b[0] == b'M' && b[1] == b'S' && b[2] == 3 {
        return Signature::V3;
    }
    if b.len() >= 8 && is_seq(&b[..6]) && b"DRQM".contains(&b[6]) && (b[7] == b' ' || b[7] == 0) {
        return Signature::V2;
    }
    Signature::None
}

fn u16_at(b: &[u8], at: usize, big_endian: bool) -> Option<u16> {
    let bytes: [u8; 2] = b.get(at..at + 2)?.try_into().ok()?;
    Some(if big_endian {
        u16::from_be_bytes(bytes)
    } else {
        u16::from_le_bytes(bytes)
    })
}

fn u64_at(b: &[u8], at: usize, big_endian: bool) -> Option<u64> {
    let bytes: [u8; 8] = b.get(at..at + 8)?.try_into().ok()?;
    Some(if big_endian {
        u64::from_be_bytes(bytes)
    } else {
        u64::from_le_bytes(bytes)
    })
}

/// A fixed-width code field: trailing blanks/NULs removed; bytes that are not printable
/// ASCII are dropped (with a warning).
fn code_field(raw: &[u8], what: &str, warnings: &mut Warnings) -> String {
    let mut out = String::with_capacity(raw.len());
    for &c in raw {
        if c.is_ascii_graphic() || c == b' ' {
            out.push(char::from(c));
        } else if c != 0 {
            warnings.add(format!(
                "{what} code contains the non-ASCII byte 0x{c:02X}, which was dropped"
            ));
        }
    }
    out.trim().to_string()
}

/// Days from 1970-01-01 to `year`-01-01 (proleptic Gregorian).
fn days_to_year(year: i64) -> i64 {
    let y = year - 1;
    let days_before = |y: i64| y * 365 + y.div_euclid(4) - y.div_euclid(100) + y.div_euclid(400);
    days_before(y) - days_before(1969)
}

fn is_leap(year: i64) -> bool {
    (year % 4 == 0 && year % 100 != 0) || year % 400 == 0
}

/// UTC time from year, day of year (1-based), hour, minute, second (≤ 60 for a leap second)
/// and nanoseconds, as ns since the epoch. Checks every field's range.
fn time_ns(year: i64, doy: i64, hour: i64, min: i64, sec: i64, ns: i64) -> Result<i64, String> {
    // i64 nanoseconds since 1970 reach from 1677 to 2262.
    if !(1678..=2261).contains(&year) {
        return Err(format!(
            "invalid start time: year {year} (supported 1678-2261)"
        ));
    }
    let days_in_year = if is_leap(year) { 366 } else { 365 };
    if !(1..=days_in_year).contains(&doy) {
        return Err(format!("invalid start time: day of year {doy} in {year}"));
    }
    if !(0..=23).contains(&hour) || !(0..=59).contains(&min) || !(0..=60).contains(&sec) {
        return Err(format!(
            "invalid start time: {hour:02}:{min:02}:{sec:02} (hour 0-23, minute 0-59, second 0-60)"
        ));
    }
    if !(0..NS_PER_S).contains(&ns) {
        return Err(format!(
            "invalid start time: fraction of a second {ns} ns is not below 1 s"
        ));
    }
    let days = days_to_year(year) + doy - 1;
    Ok(((days * 24 + hour) * 60 + min) * 60 * NS_PER_S + sec * NS_PER_S + ns)
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

/// Smallest and largest MiniSEED 2 record lengths accepted (bytes): 2^7 to 2^20.
const V2_MIN_RECORD_EXP: u8 = 7;
const V2_MAX_RECORD_EXP: u8 = 20;

fn parse_v2<'a>(b: &'a [u8], warnings: &mut Warnings) -> Result<Header<'a>, String> {
    let fixed: &[u8; 48] = b.get(..48).and_then(|h| h.try_into().ok()).ok_or_else(|| {
        format!(
            "the file ends inside a MiniSEED 2 record header ({} of 48 bytes)",
            b.len()
        )
    })?;
    // Byte order: the one in which year and day of year are plausible.
    let plausible = |be: bool| {
        let year = u16_at(fixed, 20, be).unwrap_or(0);
        let doy = u16_at(fixed, 22, be).unwrap_or(0);
        (1900..=2100).contains(&year) && (1..=366).contains(&doy)
    };
    let be = if plausible(true) {
        true
    } else if plausible(false) {
        false
    } else {
        return Err(format!(
            "invalid start time: year/day of year {}/{} (big-endian) or {}/{} (little-endian)",
            u16::from_be_bytes([fixed[20], fixed[21]]),
            u16::from_be_bytes([fixed[22], fixed[23]]),
            u16::from_le_bytes([fixed[20], fixed[21]]),
            u16::from_le_bytes([fixed[22], fixed[23]]),
        ));
    };
    let r16 = |at: usize| {
        let bytes = [fixed[at], fixed[at + 1]];
        if be {
            u16::from_be_bytes(bytes)
        } else {
            u16::from_le_bytes(bytes)
        }
    };
    let sta = code_field(&fixed[8..13], "station", warnings);
    let loc = code_field(&fixed[13..15], "location", warnings);
    let cha = code_field(&fixed[15..18], "channel", warnings);
    let net = code_field(&fixed[18..20], "network", warnings);

    let fract = r16(28);
    if fract > 9999 {
        return Err(format!(
            "invalid start time: fractional seconds field {fract} (units of 0.0001 s, max 9999)"
        ));
    }
    let mut start_ns = time_ns(
        i64::from(r16(20)),
        i64::from(r16(22)),
        i64::from(fixed[24]),
        i64::from(fixed[25]),
        i64::from(fixed[26]),
        i64::from(fract) * 100_000,
    )?;
    let sample_count = usize::from(r16(30));
    let factor = r16(32) as i16;
    let multiplier = r16(34) as i16;
    let activity_flags = fixed[36];
    let declared_blockettes = fixed[39];
    let raw_correction = [fixed[40], fixed[41], fixed[42], fixed[43]];
    let time_correction = if be {
        i32::from_be_bytes(raw_correction)
    } else {
        i32::from_le_bytes(raw_correction)
    };
    let data_offset = usize::from(r16(44));
    let first_blockette = usize::from(r16(46));

    // Walk the blockette chain. Offsets must increase, so the walk always ends.
    let mut b1000: Option<(u8, u8, u8)> = None; // (encoding, word order, length exponent)
    let mut b100_rate: Option<f32> = None;
    let mut microseconds: i64 = 0;
    let mut parsed = 0usize;
    let mut at = first_blockette;
    let mut previous = 0usize;
    while at != 0 {
        if at < 48 || at <= previous {
            return Err(format!(
                "invalid blockette chain: blockette at byte {at} after one at byte {previous}"
            ));
        }
        let (kind, next) = match (u16_at(b, at, be), u16_at(b, at + 2, be)) {
            (Some(kind), Some(next)) => (kind, usize::from(next)),
            _ => {
                return Err(format!(
                    "blockette offset {at} is beyond the end of the file"
                ))
            }
        };
        let field = |i: usize| {
            b.get(at + i).copied().ok_or_else(|| {
                format!("blockette {kind} at byte {at} is cut off by the end of the file")
            })
        };
        match kind {
            1000 => b1000 = Some((field(4)?, field(5)?, field(6)?)),
            1001 => microseconds = i64::from(field(5)? as i8),
            100 => {
                let raw = [field(4)?, field(5)?, field(6)?, field(7)?];
                b100_rate = Some(if be {
                    f32::from_be_bytes(raw)
                } else {
                    f32::from_le_bytes(raw)
                });
            }
            _ => {}
        }
        parsed += 1;
        previous = at;
        at = next;
    }
    if parsed != usize::from(declared_blockettes) {
        warnings.add(format!(
            "fixed header says {declared_blockettes} blockettes, but {parsed} were found"
        ));
    }

    let (length, encoding_code, data_be) = match b1000 {
        Some((encoding, word_order, exponent)) => {
            if !(V2_MIN_RECORD_EXP..=V2_MAX_RECORD_EXP).contains(&exponent) {
                return Err(format!(
                    "invalid record length 2^{exponent} in blockette 1000 (allowed 2^{V2_MIN_RECORD_EXP} to 2^{V2_MAX_RECORD_EXP})"
                ));
            }
            let data_be = match word_order {
                0 => false,
                1 => true,
                other => {
                    warnings.add(format!(
                        "invalid word order {other} in blockette 1000; the header's byte order was used"
                    ));
                    be
                }
            };
            (1usize << exponent, encoding, data_be)
        }
        None => {
            let length = infer_v2_length(b).ok_or_else(|| {
                "no blockette 1000, and the record length could not be inferred (no next record \
                 header at a power-of-two offset, and the rest of the file is not a \
                 power-of-two length)"
                    .to_string()
            })?;
            warnings.add(format!(
                "record without blockette 1000: length {length} bytes inferred, Steim-1 in \
                 the header's byte order assumed (checked by Steim's integrity checks)"
            ));
            (length, 10, be)
        }
    };
    if b.len() < length {
        return Err(format!(
            "the file ends inside the record: it is {length} bytes long but only {} remain",
            b.len()
        ));
    }
    if previous + 4 > length {
        return Err(format!(
            "blockette at byte {previous} lies outside the {length}-byte record"
        ));
    }
    let record = &b[..length];
    let data = if sample_count == 0 {
        &record[length..]
    } else {
        if data_offset < 48 || data_offset >= length {
            return Err(format!(
                "data offset {data_offset} is outside the {length}-byte record"
            ));
        }
        &record[data_offset..]
    };
    // Time correction (units of 0.0001 s) is added unless activity flag bit 1 says it
    // already was.
    if activity_flags & 0x02 == 0 {
        start_ns += i64::from(time_correction) * 100_000;
    }
    start_ns += microseconds * 1_000;
    let sample_rate_hz = match b100_rate {
        Some(rate) if rate.is_finite() && rate > 0.0 => f64::from(rate),
        _ => v2_sample_rate(factor, multiplier),
    };
    Ok(Header {
        length,
        net,
        sta,
        loc,
        cha,
        start_ns,
        sample_rate_hz,
        payload: Payload {
            data,
            encoding: encoding_from_code(encoding_code)?,
            big_endian: data_be,
            sample_count,
        },
    })
}

/// Length of a MiniSEED 2 record without blockette 1000: the smallest power of two (≥ 128)
/// at which the next record header starts, or the rest of the file if that is a power of
/// two.
fn infer_v2_length(b: &[u8]) -> Option<usize> {
    for exp in V2_MIN_RECORD_EXP..=V2_MAX_RECORD_EXP {
        let length = 1usize << exp;
        if length > b.len() {
            break;
        }
        if length == b.len() || signature(&b[length..]) != Signature::None {
            return Some(length);
        }
    }
    None
}

/// Length of the MiniSEED 3 fixed header (bytes).
const V3_FIXED: usize = 40;

fn parse_v3(b: &[u8]) -> Result<Header<'_>, String> {
    let fixed: &[u8; V3_FIXED] = b
        .get(..V3_FIXED)
        .and_then(|h| h.try_into().ok())
        .ok_or_else(|| {
            format!(
                "the file ends inside a MiniSEED 3 record header ({} of {V3_FIXED} bytes)",
                b.len()
            )
        })?;
    let le16 = |at: usize| u16::from_le_bytes([fixed[at], fixed[at + 1]]);
    let le32 =
        |at: usize| u32::from_le_bytes([fixed[at], fixed[at + 1], fixed[at + 2], fixed[at + 3]]);
    let nanosecond = le32(4);
    let start_ns = time_ns(
        i64::from(le16(8)),
        i64::from(le16(10)),
        i64::from(fixed[12]),
        i64::from(fixed[13]),
        i64::from(fixed[14]),
        i64::from(nanosecond),
    )?;
    let encoding_code = fixed[15];
    let rate_or_period = f64::from_bits(u64_at(fixed, 16, false).unwrap_or(0));
    let sample_count = le32(24) as usize;
    let crc_stored = le32(28);
    let sid_length = usize::from(fixed[33]);
    let extra_length = usize::from(le16(34));
    let data_length = le32(36) as usize;
    let length = V3_FIXED + sid_length + extra_length + data_length;
    if b.len() < length {
        return Err(format!(
            "the file ends inside the record: it is {length} bytes long but only {} remain",
            b.len()
        ));
    }
    let record = &b[..length];
    let crc = crc32c_with_zeroed_field(record, 28);
    if crc != crc_stored {
        return Err(format!(
            "CRC mismatch (stored 0x{crc_stored:08X}, computed 0x{crc:08X}): the record is corrupt"
        ));
    }
    let sid_bytes = &record[V3_FIXED..V3_FIXED + sid_length];
    let sid = std::str::from_utf8(sid_bytes)
        .map_err(|_| "source identifier is not valid UTF-8".to_string())?;
    let (net, sta, loc, cha) = parse_fdsn_sid(sid)?;
    let sample_rate_hz = if rate_or_period > 0.0 {
        rate_or_period
    } else if rate_or_period < 0.0 {
        -1.0 / rate_or_period
    } else {
        0.0
    };
    Ok(Header {
        length,
        net,
        sta,
        loc,
        cha,
        start_ns,
        sample_rate_hz,
        payload: Payload {
            data: &record[V3_FIXED + sid_length + extra_length..],
            encoding: encoding_from_code(encoding_code)?,
            // MiniSEED 3: Steim frames are big-endian, all other payloads little-endian.
            big_endian: matches!(encoding_code, 10 | 11),
            sample_count,
        },
    })
}

/// Splits `FDSN:NET_STA_LOC_BAND_SOURCE_SUBSOURCE` into SEED codes.
fn parse_fdsn_sid(sid: &str) -> Result<(String, String, String, String), String> {
    let body = sid
        .strip_prefix("FDSN:")
        .ok_or_else(|| format!("source identifier {sid:?} is not an FDSN source identifier"))?;
    let parts: Vec<&str> = body.split('_').collect();
    match parts.as_slice() {
        [net, sta, loc, band, source, subsource] => {
            let cha = if band.len() == 1 && source.len() == 1 && subsource.len() == 1 {
                format!("{band}{source}{subsource}")
            } else {
                format!("{band}_{source}_{subsource}")
            };
            Ok((net.to_string(), sta.to_string(), loc.to_string(), cha))
        }
        _ => Err(format!(
            "source identifier {sid:?} does not have the form FDSN:NET_STA_LOC_B_S_SS"
        )),
    }
}

/// CRC-32C (Castagnoli, reflected polynomial 0x82F63B78) lookup table.
const CRC32C_TABLE: [u32; 256] = {
    let mut table = [0u32; 256];
    let mut i = 0;
    while i < 256 {
        let mut crc = i as u32;
        let mut bit = 0;
        while bit < 8 {
            crc = if crc & 1 != 0 {
                (crc >> 1) ^ 0x82F6_3B78
            } else {
                crc >> 1
            };
            bit += 1;
        }
        table[i] = crc;
        i += 1;
    }
    table
};

fn crc32c_update(mut crc: u32, bytes: &[u8]) -> u32 {
    for &byte in bytes {
        crc = CRC32C_TABLE[((crc ^ u32::from(byte)) & 0xFF) as usize] ^ (crc >> 8);
    }
    crc
}

/// CRC-32C of `bytes`.
#[cfg(test)]
fn crc32c(bytes: &[u8]) -> u32 {
    !crc32c_update(!0, bytes)
}

/// CRC-32C of `record` with the 4-byte field at `field` taken as zero (MiniSEED 3).
fn crc32c_with_zeroed_field(record: &[u8], field: usize) -> u32 {
    let (head, rest) = record.split_at(field.min(record.len()));
    let tail = rest.get(4..).unwrap_or(&[]);
    let crc = crc32c_update(!0, head);
    let crc = crc32c_update(crc, &[0; 4]);
    !crc32c_update(crc, tail)
}

// ---------------------------------------------------------------------------------------
// Sample decoding
// ---------------------------------------------------------------------------------------

/// What a data record yielded.
enum Decoded {
    Samples(DecodedRecord),
    /// A text (ASCII/log) record of this channel id.
    Text(String),
    /// A record with 0 samples.
    Empty,
}

fn decode_record(
    header: Header<'_>,
    index: usize,
    offset: usize,
    warnings: &mut Warnings,
) -> Result<Decoded, String> {
    let id = format!(
        "{}.{}.{}.{}",
        header.net, header.sta, header.loc, header.cha
    );
    let payload = &header.payload;
    if payload.encoding == Encoding::Text {
        warnings.add(format!(
            "skipped text (ASCII/log) records of {id}: they hold no samples"
        ));
        return Ok(Decoded::Text(id));
    }
    if payload.sample_count == 0 {
        return Ok(Decoded::Empty);
    }
    if !(header.sample_rate_hz.is_finite() && header.sample_rate_hz > 0.0) {
        return Err(format!(
            "{id}: sampling rate {} Hz (must be > 0 for {} samples)",
            header.sample_rate_hz, payload.sample_count
        ));
    }
    let kind = match payload.encoding {
        Encoding::Float32 | Encoding::Float64 => SampleKind::Float,
        _ => SampleKind::Integer,
    };
    let samples = decode_samples(payload).map_err(|e| format!("{id}: {e}"))?;
    Ok(Decoded::Samples(DecodedRecord {
        index,
        offset,
        net: header.net,
        sta: header.sta,
        loc: header.loc,
        cha: header.cha,
        start_ns: header.start_ns,
        sample_rate_hz: header.sample_rate_hz,
        kind,
        samples,
    }))
}

fn decode_samples(payload: &Payload<'_>) -> Result<Vec<f64>, String> {
    let n = payload.sample_count;
    let data = payload.data;
    let be = payload.big_endian;
    let need = |width: usize, name: &str| -> Result<(), String> {
        if n.checked_mul(width)
            .is_some_and(|bytes| bytes <= data.len())
        {
            Ok(())
        } else {
            Err(format!(
                "{n} {name} samples need {} bytes but the data section has {}",
                n.saturating_mul(width),
                data.len()
            ))
        }
    };
    match payload.encoding {
        Encoding::Int16 => {
            need(2, "INT16")?;
            Ok(data
                .chunks_exact(2)
                .take(n)
                .map(|c| {
                    let raw = [c[0], c[1]];
                    f64::from(if be {
                        i16::from_be_bytes(raw)
                    } else {
                        i16::from_le_bytes(raw)
                    })
                })
                .collect())
        }
        Encoding::Int32 => {
            need(4, "INT32")?;
            Ok(data
                .chunks_exact(4)
                .take(n)
                .map(|c| {
                    let raw = [c[0], c[1], c[2], c[3]];
                    f64::from(if be {
                        i32::from_be_bytes(raw)
                    } else {
                        i32::from_le_bytes(raw)
                    })
                })
                .collect())
        }
        Encoding::Float32 => {
            need(4, "FLOAT32")?;
            let samples: Vec<f64> = data
                .chunks_exact(4)
                .take(n)
                .map(|c| {
                    let raw = [c[0], c[1], c[2], c[3]];
                    f64::from(if be {
                        f32::from_be_bytes(raw)
                    } else {
                        f32::from_le_bytes(raw)
                    })
                })
                .collect();
            check_finite(&samples)?;
            Ok(samples)
        }
        Encoding::Float64 => {
            need(8, "FLOAT64")?;
            let samples: Vec<f64> = data
                .chunks_exact(8)
                .take(n)
                .map(|c| {
                    let raw = [c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7]];
                    if be {
                        f64::from_be_bytes(raw)
                    } else {
                        f64::from_le_bytes(raw)
                    }
                })
                .collect();
            check_finite(&samples)?;
            Ok(samples)
        }
        Encoding::Steim1 => decode_steim(data, be, Steim::One, n),
        Encoding::Steim2 => decode_steim(data, be, Steim::Two, n),
        Encoding::Text => Ok(Vec::new()),
    }
}

fn check_finite(samples: &[f64]) -> Result<(), String> {
    match samples.iter().position(|x| !x.is_finite()) {
        Some(i) => Err(format!(
            "sample {i} is {} (not a finite number): wrong byte order or corrupt data",
            samples[i]
        )),
        None => Ok(()),
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Steim {
    One,
    Two,
}

/// Sign-extends the low `bits` bits of `v`.
fn sign_extend(v: u32, bits: u32) -> i32 {
    let shift = 32 - bits;
    ((v << shift) as i32) >> shift
}

/// Decodes Steim-1 or Steim-2 frames (64 bytes each) into `n` samples. Frame 0 holds the
/// forward (X0, first sample) and reverse (Xn, last sample) integration constants; the
/// record's first difference refers to the previous record and is not used. Both the
/// sample count and Xn are checked.
fn decode_steim(
    data: &[u8],
    big_endian: bool,
    version: Steim,
    n: usize,
) -> Result<Vec<f64>, String> {
    let name = match version {
        Steim::One => "Steim-1",
        Steim::Two => "Steim-2",
    };
    let frames = data.len() / 64;
    let max_per_frame = match version {
        Steim::One => 15 * 4,
        Steim::Two => 15 * 7,
    };
    if frames == 0 {
        return Err(format!(
            "{name}: data section of {} bytes holds no 64-byte frame",
            data.len()
        ));
    }
    if n > frames * max_per_frame {
        return Err(format!(
            "{name}: header says {n} samples, but {frames} frames hold at most {}",
            frames * max_per_frame
        ));
    }
    let word_bytes = |i: usize| -> [u8; 4] {
        data.get(4 * i..4 * i + 4)
            .and_then(|w| w.try_into().ok())
            .unwrap_or([0; 4])
    };
    let word = |i: usize| {
        let b = word_bytes(i);
        if big_endian {
            u32::from_be_bytes(b)
        } else {
            u32::from_le_bytes(b)
        }
    };
    let x0 = word(1) as i32;
    let xn = word(2) as i32;
    let mut out: Vec<f64> = Vec::with_capacity(n);
    let mut last = x0;
    let mut first_difference = true;
    // Differences of one word; at most 7 (Steim-2, code 3, sub-code 2).
    let mut differences = [0i32; 7];
    'frames: for frame in 0..frames {
        let control = word(frame * 16);
        let first_word = if frame == 0 { 3 } else { 1 };
        for w in first_word..16 {
            let nibble = (control >> (30 - 2 * w)) & 3;
            let raw = word_bytes(frame * 16 + w);
            let value = word(frame * 16 + w);
            // Byte-wide differences are stored in memory order and Steim-1 16-bit ones as
            // two values in the data byte order (libmseed's reading of little-endian Steim);
            // everything else is a bit field of the whole 32-bit word.
            let count = match (version, nibble) {
                (_, 0) => continue,
                (_, 1) => {
                    for (d, &b) in differences.iter_mut().zip(&raw) {
                        *d = i32::from(b as i8);
                    }
                    4
                }
                (Steim::One, 2) => {
                    for (k, d) in differences.iter_mut().take(2).enumerate() {
                        let pair = [raw[2 * k], raw[2 * k + 1]];
                        *d = i32::from(if big_endian {
                            i16::from_be_bytes(pair)
                        } else {
                            i16::from_le_bytes(pair)
                        });
                    }
                    2
                }
                (Steim::One, _) => {
                    differences[0] = value as i32;
                    1
                }
                (Steim::Two, _) => {
                    // (count, bits per difference) of the packed differences.
                    let (count, bits) = match (nibble, value >> 30) {
                        (2, 1) => (1, 30),
                        (2, 2) => (2, 15),
                        (2, 3) => (3, 10),
                        (3, 0) => (5, 6),
                        (3, 1) => (6, 5),
                        (3, 2) => (7, 4),
                        (code, sub) => {
                            return Err(format!(
                                "{name}: invalid sub-code {sub} for code {code} in frame {frame}, word {w}"
                            ))
                        }
                    };
                    let mask = (1u32 << bits) - 1;
                    for (k, d) in differences.iter_mut().take(count).enumerate() {
                        let shift = bits * (count - 1 - k) as u32;
                        *d = sign_extend((value >> shift) & mask, bits);
                    }
                    count
                }
            };
            for &difference in &differences[..count] {
                if first_difference {
                    first_difference = false;
                    out.push(f64::from(x0));
                } else {
                    last = last
                        .checked_add(difference)
                        .ok_or_else(|| format!("{name}: sample {} overflows 32 bits", out.len()))?;
                    out.push(f64::from(last));
                }
                if out.len() == n {
                    break 'frames;
                }
            }
        }
    }
    if out.len() != n {
        return Err(format!(
            "{name}: only decoded {} of the {n} samples the header announces",
            out.len()
        ));
    }
    if last != xn {
        return Err(format!(
            "{name} integrity check failed: last decoded sample {last} differs from the \
             reverse integration constant {xn} (corrupt data or wrong byte order)"
        ));
    }
    Ok(out)
}

// ---------------------------------------------------------------------------------------
// Channels, segments, gaps
// ---------------------------------------------------------------------------------------

fn samples_to_ns(count: usize, rate_hz: f64) -> i64 {
    (count as f64 * NS_PER_S as f64 / rate_hz).round() as i64
}

fn assemble_channels(records: Vec<DecodedRecord>, source: &Path) -> Result<Vec<Channel>, String> {
    let mut order: Vec<(String, String, String, String)> = Vec::new();
    let mut groups: BTreeMap<(String, String, String, String), Vec<DecodedRecord>> =
        BTreeMap::new();
    for record in records {
        let key = (
            record.net.clone(),
            record.sta.clone(),
            record.loc.clone(),
            record.cha.clone(),
        );
        if !groups.contains_key(&key) {
            order.push(key.clone());
        }
        groups.entry(key).or_default().push(record);
    }
    let mut channels = Vec::with_capacity(order.len());
    for key in order {
        let Some(mut group) = groups.remove(&key) else {
            continue;
        };
        group.sort_by_key(|r| r.start_ns);
        let (net, sta, loc, cha) = key;
        let id = format!("{net}.{sta}.{loc}.{cha}");
        let first = &group[0];
        let rate = first.sample_rate_hz;
        if let Some(other) = group
            .iter()
            .find(|r| (r.sample_rate_hz - rate).abs() > 1e-4 * rate)
        {
            return Err(format!(
                "channel {id}: record {} at byte {} has sampling rate {} Hz, but record {} at \
                 byte {} has {} Hz",
                other.index, other.offset, other.sample_rate_hz, first.index, first.offset, rate
            ));
        }
        let mut kind = first.kind;
        let tolerance_ns = 0.5 * NS_PER_S as f64 / rate;
        let mut segments: Vec<Segment> = Vec::new();
        let mut gaps = Vec::new();
        let mut overlaps = Vec::new();
        for record in group {
            if record.kind != kind {
                kind = SampleKind::Mixed;
            }
            if let Some(current) = segments.last_mut() {
                let expected = current
                    .start_time_ns
                    .saturating_add(samples_to_ns(current.samples.len(), rate));
                let difference = record.start_ns.saturating_sub(expected);
                if (difference as f64).abs() <= tolerance_ns {
                    current.samples.extend_from_slice(&record.samples);
                    continue;
                }
                let size_s = (difference as f64 / NS_PER_S as f64).abs();
                let break_ = Discontinuity {
                    after_segment: segments.len() - 1,
                    expected_ns: expected,
                    actual_ns: record.start_ns,
                    size_s,
                    size_samples: size_s * rate,
                };
                if difference > 0 {
                    gaps.push(break_);
                } else {
                    overlaps.push(break_);
                }
            }
            segments.push(Segment {
                start_time_ns: record.start_ns,
                samples: record.samples,
            });
        }
        channels.push(Channel {
            source: source.display().to_string(),
            net,
            sta,
            loc,
            cha,
            sample_rate_hz: rate,
            start_time_ns: segments.first().map_or(0, |s| s.start_time_ns),
            sample_kind: kind,
            segments,
            gaps,
            overlaps,
        });
    }
    Ok(channels)
}

/// Formats ns since the epoch as ISO 8601 UTC (`YYYY-MM-DDThh:mm:ss.fffffffffZ`).
#[must_use]
pub fn format_time_ns(t_ns: i64) -> String {
    let secs = t_ns.div_euclid(NS_PER_S);
    let ns = t_ns.rem_euclid(NS_PER_S);
    let days = secs.div_euclid(86_400);
    let rem = secs.rem_euclid(86_400);
    // Civil date from days since 1970-01-01 (Howard Hinnant's algorithm).
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    format!(
        "{year:04}-{month:02}-{day:02}T{:02}:{:02}:{:02}.{ns:09}Z",
        rem / 3600,
        rem / 60 % 60,
        rem % 60
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crc32c_of_check_string_is_the_published_value() {
        // RFC 3720 / iSCSI check value of CRC-32C over "123456789".
        assert_eq!(crc32c(b"123456789"), 0xE306_9283);
    }

    #[test]
    fn time_of_known_instants_matches_unix_time() {
        // `date -u -d 1996-08-10T18:12:24Z +%s` = 839700744; 1996-08-10 is day 223.
        assert_eq!(
            time_ns(1996, 223, 18, 12, 24, 0),
            Ok(839_700_744 * NS_PER_S)
        );
        assert_eq!(time_ns(1970, 1, 0, 0, 0, 0), Ok(0));
        // 2000-03-01 (day 61 of a leap year) = 951868800.
        assert_eq!(time_ns(2000, 61, 0, 0, 0, 0), Ok(951_868_800 * NS_PER_S));
        assert!(time_ns(2001, 366, 0, 0, 0, 0).is_err());
        assert!(time_ns(2001, 1, 24, 0, 0, 0).is_err());
    }

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
    fn fdsn_sid_splits_into_seed_codes() {
        assert_eq!(
            parse_fdsn_sid("FDSN:XX_TEST__B_H_Z"),
            Ok(("XX".into(), "TEST".into(), "".into(), "BHZ".into()))
        );
        assert_eq!(
            parse_fdsn_sid("FDSN:XX_TEST_00_B_HH_Z").map(|c| c.3),
            Ok("B_HH_Z".into())
        );
        assert!(parse_fdsn_sid("XX.TEST..BHZ").is_err());
    }

    /// Builds big-endian Steim frames by hand: control word, then data words.
    fn frame(control: u32, words: &[u32]) -> Vec<u8> {
        let mut f = control.to_be_bytes().to_vec();
        for w in words {
            f.extend_from_slice(&w.to_be_bytes());
        }
        f.resize(64, 0);
        f
    }

    #[test]
    fn steim1_hand_built_frame_decodes() {
        // Samples 10, 11, 9, 9, 1009: differences (·), 1, −2, 0, 1000.
        // Word 3: four 8-bit differences (0, 1, −2, 0), code 1; word 4: one 32-bit (1000), code 3.
        let control = (1 << (30 - 2 * 3)) | (3 << (30 - 2 * 4));
        let words = [10, 1009, 0x0001_FE00, 1000];
        let data = frame(control, &words);
        let got = decode_steim(&data, true, Steim::One, 5).unwrap();
        assert_eq!(got, vec![10.0, 11.0, 9.0, 9.0, 1009.0]);
    }

    #[test]
    fn steim2_seven_four_bit_differences_decode() {
        // Code 3, sub-code 2: seven 4-bit differences 0, 1, 2, 3, −1, −2, −8.
        let diffs: [i32; 7] = [0, 1, 2, 3, -1, -2, -8];
        let mut word = 2u32 << 30;
        for (k, d) in diffs.iter().enumerate() {
            word |= ((*d as u32) & 0xF) << (4 * (6 - k));
        }
        let mut expected = vec![100.0];
        let mut x = 100;
        for d in &diffs[1..] {
            x += d;
            expected.push(f64::from(x));
        }
        let control = 3 << (30 - 2 * 3);
        let data = frame(control, &[100, x as u32, word]);
        assert_eq!(decode_steim(&data, true, Steim::Two, 7).unwrap(), expected);
    }

    #[test]
    fn steim_wrong_reverse_constant_is_an_error() {
        let control = 1 << (30 - 2 * 3);
        let data = frame(control, &[10, 99, 0x0001_0101]);
        let err = decode_steim(&data, true, Steim::One, 4).unwrap_err();
        assert!(err.contains("integrity check"), "{err}");
    }

    #[test]
    fn steim_too_few_differences_is_an_error() {
        let control = 1 << (30 - 2 * 3);
        let data = frame(control, &[10, 12, 0x0001_0100]);
        let err = decode_steim(&data, true, Steim::One, 9).unwrap_err();
        assert!(err.contains("only decoded 4"), "{err}");
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
}
