//! MiniSEED 2.4 writer (pure Rust, no `unsafe`): the "Writing" half of [`crate::record::mseed`].
//!
//! [`write_mseed`] writes channels of uniformly sampled data as MiniSEED 2.4 data records:
//! a 48-byte fixed header, blockette 1000 (encoding, word order, record length) and, when a
//! record's start time needs it, blockette 1001 (microsecond offset); everything
//! big-endian; fixed record length 512 or 4096 bytes ([`RecordLength`]); data from byte 64.
//! [`encode_mseed`] is the same without I/O.
//!
//! Encodings: floating-point samples ([`Samples::Float`]) as FLOAT32 (code 4) or FLOAT64
//! (code 5, the default, exact); integer counts ([`Samples::Counts`]) as Steim-2 (code 11).
//!
//! Conventions:
//! - Times are UTC, integer ns since 1970-01-01T00:00:00Z (no leap seconds), as in the
//!   reader. MiniSEED 2 resolves 1 µs: each record's start time is rounded to the nearest
//!   microsecond, written as a BTime in units of 0.0001 s (rounded to the nearest 100 µs)
//!   plus the remainder (−50…+49 µs, libmseed's convention) in blockette 1001. Record k of a
//!   channel starts at `start + (samples before it) / rate`, computed exactly from the
//!   rational rate written in the header, so record times never drift. Years 1900–2100
//!   only (the range libmseed and our reader accept when detecting byte order).
//! - The rate is written as the SEED factor/multiplier pair that represents it exactly
//!   ([`SampleRateFactors`]); a rate that no pair represents (to 1e-12 relative) is an error.
//! - Every record has quality indicator `D`; sequence numbers count the file's records
//!   from `000001` (after `999999` they wrap to `000001`, as libmseed does).
//! - Channels are written one after another, each as consecutive records.

use std::path::Path;

use super::{days_to_year, encode_steim2, fits, v2_sample_rate, RecordError, NS_PER_S};

/// Length of every record of a file.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum RecordLength {
    /// 512 bytes (448 bytes of data: 112 FLOAT32, 56 FLOAT64 or 7 Steim frames).
    B512,
    /// 4096 bytes (4032 bytes of data: 1008 FLOAT32, 504 FLOAT64 or 63 Steim frames).
    #[default]
    B4096,
}

impl RecordLength {
    /// Record length in bytes.
    #[must_use]
    pub fn bytes(self) -> usize {
        1 << self.exponent()
    }

    /// Base-2 logarithm of the length (blockette 1000 field).
    fn exponent(self) -> u8 {
        match self {
            RecordLength::B512 => 9,
            RecordLength::B4096 => 12,
        }
    }
}

/// How floating-point samples ([`Samples::Float`]) are stored.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum FloatEncoding {
    /// IEEE single precision (SEED code 4): half the size, relative rounding ≤ 2^-24 ≈ 6e-8;
    /// values beyond ±3.4e38 are an error.
    Float32,
    /// IEEE double precision (SEED code 5): exact.
    #[default]
    Float64,
}

/// When blockette 1001 (microsecond start-time offset) is written.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Blockette1001 {
    /// Only in records whose start time is not a multiple of 100 µs.
    #[default]
    WhenNeeded,
    /// In every record (offset 0 when not needed).
    Always,
}

/// Options of [`write_mseed`]; the default is 4096-byte records, FLOAT64, blockette 1001
/// when needed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct WriteOptions {
    /// Length of every record.
    pub record_length: RecordLength,
    /// Encoding of [`Samples::Float`] channels ([`Samples::Counts`] are always Steim-2).
    pub float_encoding: FloatEncoding,
    /// When to write blockette 1001.
    pub blockette_1001: Blockette1001,
}

/// The samples of a channel.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Samples<'a> {
    /// Floating-point values (any unit, e.g. m/s²), all finite; written as FLOAT32 or
    /// FLOAT64 ([`WriteOptions::float_encoding`]).
    Float(&'a [f64]),
    /// Integer digitizer counts, written as Steim-2. Steim-2 stores differences of at most
    /// 30 bits: consecutive samples may differ by −2^29 to 2^29 − 1 counts.
    Counts(&'a [i32]),
}

impl Samples<'_> {
    /// Number of samples.
    #[must_use]
    pub fn len(&self) -> usize {
        match self {
            Samples::Float(x) => x.len(),
            Samples::Counts(x) => x.len(),
        }
    }

    /// True when there are no samples.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// One channel to write: a contiguous, uniformly sampled series.
#[derive(Debug, Clone, PartialEq)]
pub struct ChannelData<'a> {
    /// SEED id `NET.STA.LOC.CHA` (see [`SeedId::parse`]), e.g. `XX.P0001..HNX`.
    pub id: String,
    /// Time of the first sample (ns since the Unix epoch, UTC).
    pub start_time_ns: i64,
    /// Sampling rate (Hz), > 0; must be exactly representable ([`SampleRateFactors`]).
    pub sample_rate_hz: f64,
    /// The samples, at least one.
    pub samples: Samples<'a>,
}

/// The four codes of a SEED channel id, validated for MiniSEED 2.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SeedId {
    /// Network code: 1–2 characters.
    pub net: String,
    /// Station code: 1–5 characters.
    pub sta: String,
    /// Location code: 0–2 characters.
    pub loc: String,
    /// Channel code: exactly 3 characters (band, instrument, orientation).
    pub cha: String,
}

/// Why a text is not a SEED channel id MiniSEED 2 can hold.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum SeedIdError {
    /// Not four dot-separated codes.
    #[error(
        "SEED id {id:?} must have the form NET.STA.LOC.CHA (four codes separated by \
         dots; LOC may be empty), e.g. XX.P0001..HNX"
    )]
    NotFourCodes { id: String },
    /// A code of the wrong length (`allowed`: `3` or `1 to 2`, …).
    #[error("SEED id {id:?}: {code_name} code {code:?} has {chars} characters, MiniSEED 2 allows {allowed}")]
    Length {
        id: String,
        code_name: &'static str,
        code: String,
        chars: usize,
        allowed: String,
    },
    /// A character outside A–Z, 0–9.
    #[error(
        "SEED id {id:?}: {code_name} code {code:?} contains {character:?}; codes hold only \
         upper-case letters A-Z and digits 0-9"
    )]
    Character {
        id: String,
        code_name: &'static str,
        code: String,
        character: char,
    },
}

impl SeedId {
    /// Parses `NET.STA.LOC.CHA` (four dot-separated codes; LOC may be empty). Codes hold
    /// upper-case letters A–Z and digits 0–9 only (SEED manual); lengths: NET 1–2, STA 1–5,
    /// LOC 0–2, CHA 3.
    pub fn parse(id: &str) -> Result<SeedId, SeedIdError> {
        let parts: Vec<&str> = id.split('.').collect();
        let [net, sta, loc, cha] = parts.as_slice() else {
            return Err(SeedIdError::NotFourCodes { id: id.to_owned() });
        };
        for (name, code, min, max) in [
            ("network", net, 1, 2),
            ("station", sta, 1, 5),
            ("location", loc, 0, 2),
            ("channel", cha, 3, 3),
        ] {
            if !(min..=max).contains(&code.len()) {
                let size = if min == max {
                    format!("{min}")
                } else {
                    format!("{min} to {max}")
                };
                return Err(SeedIdError::Length {
                    id: id.to_owned(),
                    code_name: name,
                    code: code.to_string(),
                    chars: code.chars().count(),
                    allowed: size,
                });
            }
            if let Some(c) = code
                .chars()
                .find(|c| !(c.is_ascii_uppercase() || c.is_ascii_digit()))
            {
                return Err(SeedIdError::Character {
                    id: id.to_owned(),
                    code_name: name,
                    code: code.to_string(),
                    character: c,
                });
            }
        }
        Ok(SeedId {
            net: net.to_string(),
            sta: sta.to_string(),
            loc: loc.to_string(),
            cha: cha.to_string(),
        })
    }
}

/// Highest rate written (Hz): above 1 MHz a sampling interval is shorter than MiniSEED 2's
/// 1 µs time resolution.
pub const MAX_WRITE_RATE_HZ: f64 = 1.0e6;

/// Largest relative difference between a requested rate and the factor/multiplier rate
/// written for it. `1/dt` of a decimal `dt` (e.g. 1/0.003 vs 1000/3) differs from the exact
/// ratio by a few ulp (~1e-16); 1e-12 leaves room for rates that went through decimal text
/// with 12 or more significant digits while rejecting rates that are only close to one
/// SEED can represent.
const RATE_TOLERANCE: f64 = 1e-12;

/// A sampling rate MiniSEED 2 cannot hold.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum SampleRateError {
    #[error("sampling rate {rate_hz} Hz: must be a finite number > 0")]
    NotPositive { rate_hz: f64 },
    #[error(
        "sampling rate {rate_hz} Hz is above {MAX_WRITE_RATE_HZ} Hz: the sampling \
         interval would be shorter than MiniSEED 2's 1 µs time resolution"
    )]
    TooHigh { rate_hz: f64 },
    /// No factor/multiplier pair represents the rate; `nearest` is the closest ratio p/q.
    #[error(
        "sampling rate {rate_hz} Hz (interval {} s) cannot be written exactly in \
         MiniSEED 2, whose rate is a product or ratio of two integers up to 32767{}",
        1.0 / rate_hz,
        nearest_hint(*nearest)
    )]
    NotRepresentable {
        rate_hz: f64,
        nearest: Option<(i64, i64)>,
    },
}

/// `; the nearest ratio is p/q = … Hz`, or nothing.
fn nearest_hint(nearest: Option<(i64, i64)>) -> String {
    match nearest {
        Some((p, q)) => format!(
            "; the nearest ratio is {p}/{q} = {} Hz",
            p as f64 / q as f64
        ),
        None => String::new(),
    }
}

/// SEED's sample-rate factor and multiplier (fixed header fields 32 and 34): for factor
/// F and multiplier M, the rate is F·M (F > 0, M > 0), F/−M (F > 0, M < 0), M/−F (F < 0,
/// M > 0: −F is the period in s) or 1/(F·M) (both < 0).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SampleRateFactors {
    /// Sample-rate factor (fixed header bytes 32–33).
    pub factor: i16,
    /// Sample-rate multiplier (fixed header bytes 34–35).
    pub multiplier: i16,
}

impl SampleRateFactors {
    /// The pair that represents `rate_hz` exactly (to 1e-12 relative), preferring in order:
    /// an integer rate (F = rate, M = 1; up to 32767 Hz), an integer period (F = −period,
    /// M = 1; up to 32767 s), the ratio p/q with the smallest q (F = p, M = −q; p, q ≤ 32767,
    /// e.g. 1000/3 Hz for dt = 0.003 s), a product F·M for larger integer rates and a
    /// product period for longer ones. The error names the rate and the nearest ratio.
    pub fn from_rate_hz(rate_hz: f64) -> Result<SampleRateFactors, SampleRateError> {
        if !(rate_hz.is_finite() && rate_hz > 0.0) {
            return Err(SampleRateError::NotPositive { rate_hz });
        }
        if rate_hz > MAX_WRITE_RATE_HZ {
            return Err(SampleRateError::TooHigh { rate_hz });
        }
        let close = |value: f64| (value - rate_hz).abs() <= RATE_TOLERANCE * rate_hz;
        let max = f64::from(i16::MAX);
        let pair = |factor: i64, multiplier: i64| SampleRateFactors {
            factor: factor as i16,
            multiplier: multiplier as i16,
        };
        // Ratio p/q with the smallest denominator; also remembers the nearest ratio.
        let mut nearest: Option<(f64, i64, i64)> = None;
        for q in 1..=i64::from(i16::MAX) {
            let p = (rate_hz * q as f64).round();
            if !(1.0..=max).contains(&p) {
                if p > max {
                    break; // larger q only makes p larger
                }
                continue;
            }
            let value = p / q as f64;
            let p = p as i64;
            if close(value) {
                return Ok(match (p, q) {
                    (p, 1) => pair(p, 1),
                    (1, q) => pair(-q, 1),
                    (p, q) => pair(p, -q),
                });
            }
            let error = (value - rate_hz).abs();
            if nearest.is_none_or(|(e, _, _)| error < e) {
                nearest = Some((error, p, q));
            }
        }
        // Integer rates above 32767 Hz as a product F·M, and integer periods above 32767 s
        // as a product of two negative numbers.
        for (value, negative) in [(rate_hz, false), (1.0 / rate_hz, true)] {
            let n = value.round();
            if n > max && n <= max * max && close(if negative { 1.0 / n } else { n }) {
                let n = n as i64;
                let smallest = (n + i64::from(i16::MAX) - 1) / i64::from(i16::MAX);
                if let Some(f) = (smallest..=i64::from(i16::MAX)).find(|f| n % f == 0) {
                    return Ok(if negative {
                        pair(-f, -(n / f))
                    } else {
                        pair(f, n / f)
                    });
                }
            }
        }
        Err(SampleRateError::NotRepresentable {
            rate_hz,
            nearest: nearest.map(|(_, p, q)| (p, q)),
        })
    }

    /// The rate (Hz) these factors represent (as every MiniSEED reader computes it).
    #[must_use]
    pub fn rate_hz(self) -> f64 {
        v2_sample_rate(self.factor, self.multiplier)
    }

    /// The rate as an exact fraction `(numerator, denominator)` in Hz, both > 0.
    fn as_fraction(self) -> (i64, i64) {
        let (f, m) = (i64::from(self.factor), i64::from(self.multiplier));
        match (f > 0, m > 0) {
            (true, true) => (f * m, 1),
            (true, false) => (f, -m),
            (false, true) => (m, -f),
            (false, false) => (1, f * m),
        }
    }
}

/// A SEED BTime (fixed header bytes 20–29) plus the blockette 1001 microsecond offset.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct SeedTime {
    year: u16,
    day_of_year: u16,
    hour: u8,
    minute: u8,
    second: u8,
    /// Units of 0.0001 s, 0–9999.
    fract_1e4: u16,
    /// Microseconds to add to the BTime, −50…+49.
    microseconds: i8,
}

/// Splits a time (ns since the epoch) into BTime + µs offset: rounded to the nearest µs, then
/// the BTime is the nearest multiple of 100 µs and the offset the rest (−50…+49 µs).
fn seed_time(t_ns: i64) -> Result<SeedTime, String> {
    let t_us = t_ns.div_euclid(1_000) + i64::from(t_ns.rem_euclid(1_000) >= 500);
    let btime_us = (t_us + 50).div_euclid(100) * 100;
    let microseconds = (t_us - btime_us) as i8; // in −50..=49 by construction
    let seconds = btime_us.div_euclid(1_000_000);
    let fract_1e4 = (btime_us.rem_euclid(1_000_000) / 100) as u16;
    let days = seconds.div_euclid(86_400);
    let second_of_day = seconds.rem_euclid(86_400);
    // Year containing `days` (days since 1970-01-01): estimate, then correct.
    let mut year = 1970 + days.div_euclid(365);
    while days_to_year(year) > days {
        year -= 1;
    }
    while days_to_year(year + 1) <= days {
        year += 1;
    }
    if !(1900..=2100).contains(&year) {
        return Err(format!(
            "time {} is in year {year}; MiniSEED 2 readers (libmseed, ours) accept years \
             1900-2100",
            super::format_time_ns(t_ns)
        ));
    }
    Ok(SeedTime {
        year: year as u16,
        day_of_year: (days - days_to_year(year) + 1) as u16,
        hour: (second_of_day / 3600) as u8,
        minute: (second_of_day / 60 % 60) as u8,
        second: (second_of_day % 60) as u8,
        fract_1e4,
        microseconds,
    })
}

/// Where the data section starts in every record (bytes): fixed header (48) + blockette
/// 1000 (8) + room for blockette 1001 (8); a multiple of 64 as Steim frames require.
const DATA_OFFSET: usize = 64;

/// A channel checked and ready to encode.
struct Prepared<'a> {
    id: SeedId,
    factors: SampleRateFactors,
    start_time_ns: i64,
    samples: Samples<'a>,
}

/// Writes `channels` to `path` as MiniSEED 2.4 (see the module documentation). Errors name
/// the file, the channel and the problem; nothing is written unless every channel is valid.
pub fn write_mseed(
    path: &Path,
    channels: &[ChannelData<'_>],
    options: WriteOptions,
) -> Result<(), RecordError> {
    let bytes = encode_mseed(channels, options, path)?;
    std::fs::write(path, bytes).map_err(|e| RecordError::new(path, None, e.to_string()))
}

/// Encodes `channels` as MiniSEED 2.4 bytes (no I/O); `destination` names the output in
/// messages.
pub fn encode_mseed(
    channels: &[ChannelData<'_>],
    options: WriteOptions,
    destination: &Path,
) -> Result<Vec<u8>, RecordError> {
    let err = |problem: String| RecordError::new(destination, None, problem);
    if channels.is_empty() {
        return Err(err(
            "no channels to write: a MiniSEED file needs at least one record".into(),
        ));
    }
    let mut prepared: Vec<Prepared<'_>> = Vec::with_capacity(channels.len());
    for channel in channels {
        let p =
            prepare(channel, options).map_err(|e| err(format!("channel {}: {e}", channel.id)))?;
        if let Some(other) = prepared
            .iter()
            .find(|o| o.id == p.id && o.factors != p.factors)
        {
            return Err(err(format!(
                "channel {} appears twice with different sampling rates ({} Hz and {} Hz)",
                channel.id,
                other.factors.rate_hz(),
                p.factors.rate_hz()
            )));
        }
        prepared.push(p);
    }
    let record_bytes = options.record_length.bytes();
    let mut out = Vec::new();
    let mut sequence = 0u32;
    for channel in &prepared {
        encode_channel(channel, options, &mut out, &mut sequence)
            .map_err(|e| err(format!("channel {}: {e}", channels_id(channel))))?;
    }
    debug_assert_eq!(out.len() % record_bytes, 0);
    Ok(out)
}

fn channels_id(c: &Prepared<'_>) -> String {
    format!("{}.{}.{}.{}", c.id.net, c.id.sta, c.id.loc, c.id.cha)
}

/// Validates one channel: id, rate, samples.
fn prepare<'a>(channel: &ChannelData<'a>, options: WriteOptions) -> Result<Prepared<'a>, String> {
    let id = SeedId::parse(&channel.id).map_err(|e| e.to_string())?;
    let factors =
        SampleRateFactors::from_rate_hz(channel.sample_rate_hz).map_err(|e| e.to_string())?;
    if channel.samples.is_empty() {
        return Err("no samples: a channel needs at least one".into());
    }
    match channel.samples {
        Samples::Float(values) => {
            let limit = match options.float_encoding {
                FloatEncoding::Float32 => f64::from(f32::MAX),
                FloatEncoding::Float64 => f64::MAX,
            };
            if let Some(i) = values
                .iter()
                .position(|x| !(x.is_finite() && x.abs() <= limit))
            {
                return Err(if values[i].is_finite() {
                    format!(
                        "sample {i} = {} is beyond the FLOAT32 range (±{}); write FLOAT64",
                        values[i],
                        f32::MAX
                    )
                } else {
                    format!("sample {i} is {} (not a finite number)", values[i])
                });
            }
        }
        Samples::Counts(values) => {
            for (i, pair) in values.windows(2).enumerate() {
                let difference = i64::from(pair[1]) - i64::from(pair[0]);
                if !fits(difference, 30) {
                    return Err(format!(
                        "samples {i} and {} differ by {difference} counts; Steim-2 stores \
                         differences of at most 30 bits (-2^29 to 2^29-1)",
                        i + 1
                    ));
                }
            }
        }
    }
    Ok(Prepared {
        id,
        factors,
        start_time_ns: channel.start_time_ns,
        samples: channel.samples,
    })
}

/// Time of sample `index` of a channel (ns since the epoch), exact for the rational rate
/// `numerator/denominator` Hz (rounded to the nearest ns).
fn sample_time_ns(
    start_ns: i64,
    index: usize,
    (numerator, denominator): (i64, i64),
) -> Result<i64, String> {
    let numerator = i128::from(numerator);
    let offset = (2 * index as i128 * i128::from(denominator) * i128::from(NS_PER_S) + numerator)
        / (2 * numerator);
    i64::try_from(i128::from(start_ns) + offset)
        .map_err(|_| format!("sample {index} lies beyond the year 2262"))
}

/// Appends one channel's records to `out`.
fn encode_channel(
    channel: &Prepared<'_>,
    options: WriteOptions,
    out: &mut Vec<u8>,
    sequence: &mut u32,
) -> Result<(), String> {
    let record_bytes = options.record_length.bytes();
    let fraction = channel.factors.as_fraction();
    let total = channel.samples.len();
    let mut done = 0usize;
    let mut previous_count: Option<i32> = None;
    while done < total {
        let start = out.len();
        out.resize(start + record_bytes, 0);
        let record = &mut out[start..];
        let time = seed_time(sample_time_ns(channel.start_time_ns, done, fraction)?)
            .map_err(|e| format!("record starting at sample {done}: {e}"))?;
        let data = &mut record[DATA_OFFSET..];
        let (count, encoding_code, frames) = match channel.samples {
            Samples::Float(values) => {
                let rest = &values[done..];
                match options.float_encoding {
                    FloatEncoding::Float32 => {
                        let n = rest.len().min(data.len() / 4);
                        for (slot, &x) in data.chunks_exact_mut(4).zip(&rest[..n]) {
                            slot.copy_from_slice(&(x as f32).to_be_bytes());
                        }
                        (n, 4, 0)
                    }
                    FloatEncoding::Float64 => {
                        let n = rest.len().min(data.len() / 8);
                        for (slot, &x) in data.chunks_exact_mut(8).zip(&rest[..n]) {
                            slot.copy_from_slice(&x.to_be_bytes());
                        }
                        (n, 5, 0)
                    }
                }
            }
            Samples::Counts(values) => {
                let rest = &values[done..];
                let (n, frames) = encode_steim2(rest, previous_count, data);
                previous_count = rest.get(n.wrapping_sub(1)).copied();
                (n, 11, frames)
            }
        };
        if count == 0 {
            // Cannot happen for validated input (every record holds at least one sample);
            // guards against an endless loop.
            return Err(format!(
                "record starting at sample {done} could hold no sample"
            ));
        }
        *sequence = if *sequence >= 999_999 {
            1
        } else {
            *sequence + 1
        };
        let b1001 = match options.blockette_1001 {
            Blockette1001::Always => true,
            Blockette1001::WhenNeeded => time.microseconds != 0,
        };
        write_header(
            record,
            &Header {
                sequence: *sequence,
                id: &channel.id,
                time,
                sample_count: count as u16,
                factors: channel.factors,
                encoding_code,
                length_exponent: options.record_length.exponent(),
                b1001,
                steim_frames: frames as u8,
            },
        );
        done += count;
    }
    Ok(())
}

/// What goes into one record's fixed header and blockettes.
struct Header<'a> {
    sequence: u32,
    id: &'a SeedId,
    time: SeedTime,
    sample_count: u16,
    factors: SampleRateFactors,
    encoding_code: u8,
    length_exponent: u8,
    b1001: bool,
    steim_frames: u8,
}

/// Writes the fixed header (bytes 0–47), blockette 1000 (48–55) and optionally blockette
/// 1001 (56–63) into `record` (field offsets per the SEED 2.4 manual, chapter 8).
fn write_header(record: &mut [u8], h: &Header<'_>) {
    let put = |record: &mut [u8], at: usize, bytes: &[u8]| {
        record[at..at + bytes.len()].copy_from_slice(bytes);
    };
    let code = |text: &str, width: usize| {
        let mut field = vec![b' '; width];
        field[..text.len()].copy_from_slice(text.as_bytes());
        field
    };
    put(record, 0, format!("{:06}", h.sequence).as_bytes());
    put(record, 6, b"D ");
    put(record, 8, &code(&h.id.sta, 5));
    put(record, 13, &code(&h.id.loc, 2));
    put(record, 15, &code(&h.id.cha, 3));
    put(record, 18, &code(&h.id.net, 2));
    let t = h.time;
    put(record, 20, &t.year.to_be_bytes());
    put(record, 22, &t.day_of_year.to_be_bytes());
    put(record, 24, &[t.hour, t.minute, t.second, 0]);
    put(record, 28, &t.fract_1e4.to_be_bytes());
    put(record, 30, &h.sample_count.to_be_bytes());
    put(record, 32, &h.factors.factor.to_be_bytes());
    put(record, 34, &h.factors.multiplier.to_be_bytes());
    // Activity, I/O and data-quality flags: none.
    put(record, 36, &[0, 0, 0]);
    put(record, 39, &[1 + u8::from(h.b1001)]);
    put(record, 40, &0i32.to_be_bytes()); // time correction
    put(record, 44, &(DATA_OFFSET as u16).to_be_bytes());
    put(record, 46, &48u16.to_be_bytes()); // first blockette
                                           // Blockette 1000: type, next blockette, encoding, word order (1 = big-endian),
                                           // record length exponent, reserved.
    put(record, 48, &1000u16.to_be_bytes());
    put(record, 50, &(if h.b1001 { 56u16 } else { 0 }).to_be_bytes());
    put(record, 52, &[h.encoding_code, 1, h.length_exponent, 0]);
    if h.b1001 {
        // Blockette 1001: type, next (none), timing quality (0: not given), µs offset,
        // reserved, Steim frame count.
        put(record, 56, &1001u16.to_be_bytes());
        put(record, 58, &0u16.to_be_bytes());
        put(
            record,
            60,
            &[0, h.time.microseconds as u8, 0, h.steim_frames],
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn common_rates_get_the_conventional_factors() {
        let f = |rate: f64| {
            let s = SampleRateFactors::from_rate_hz(rate).unwrap();
            (s.factor, s.multiplier)
        };
        assert_eq!(f(200.0), (200, 1));
        assert_eq!(f(100.0), (100, 1));
        assert_eq!(f(1.0 / 0.005), (200, 1));
        assert_eq!(f(1.0 / 0.003), (1000, -3));
        assert_eq!(f(0.1), (-10, 1)); // period 10 s
        assert_eq!(f(0.4), (2, -5)); // period 2.5 s
        assert_eq!(f(50_000.0), (2, 25_000)); // 2 · 25000
        assert_eq!(f(1.0 / 100_000.0), (-4, -25_000)); // period 4 · 25000 s
    }

    #[test]
    fn unrepresentable_rates_are_errors() {
        for rate in [
            0.0,
            -1.0,
            f64::NAN,
            f64::INFINITY,
            2.0e6,
            81.000_012_3,
            40_000.0 / 3.0,
        ] {
            assert!(SampleRateFactors::from_rate_hz(rate).is_err(), "{rate}");
        }
        let e = SampleRateFactors::from_rate_hz(81.000_012_3)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("cannot be written exactly") && e.contains("nearest"),
            "{e}"
        );
    }

    #[test]
    fn seed_time_rounds_to_100_us_with_offset_in_minus_50_to_49() {
        // 2024-02-29T23:59:59.999950Z: rounds up into 2024-03-01 (day 61) 00:00:00.0000,
        // offset −50 µs. 2024-02-29T00:00:00Z = 1709164800 s.
        let t = (1_709_164_800 + 86_399) * NS_PER_S + 999_950_000;
        let s = seed_time(t).unwrap();
        assert_eq!(
            (
                s.year,
                s.day_of_year,
                s.hour,
                s.minute,
                s.second,
                s.fract_1e4,
                s.microseconds
            ),
            (2024, 61, 0, 0, 0, 0, -50)
        );
        // …049 µs → .0000 + 49; 1 ns below 0.5 µs rounds down.
        let s = seed_time(1_709_164_800 * NS_PER_S + 49_499).unwrap();
        assert_eq!((s.day_of_year, s.fract_1e4, s.microseconds), (60, 0, 49));
        assert!(seed_time(-2_240_524_800 * NS_PER_S).is_err()); // 1899-01-01
        assert!(seed_time(-2_208_988_800 * NS_PER_S).is_ok()); // 1900-01-01
    }
}
