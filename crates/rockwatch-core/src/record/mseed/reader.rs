//! MiniSEED 2 and 3 reading: record scanning, header parsing (both versions), sample
//! decoding and the grouping of records into channels, segments, gaps and overlaps (see the
//! parent module for the robustness policy).

use std::collections::BTreeMap;
use std::path::Path;

use super::{
    days_to_year, decode_steim, samples_to_ns, v2_sample_rate, Channel, Discontinuity, MseedFile,
    RecordError, SampleKind, Segment, Steim, NS_PER_S,
};

/// Reads and decodes a MiniSEED (2 or 3) file. See the module documentation for what is
/// skipped and what is an error.
pub fn read_mseed(path: &Path) -> Result<MseedFile, RecordError> {
    let bytes = crate::bounded_read::read_bounded(path, crate::bounded_read::MAX_DATA_FILE_BYTES)
        .map_err(|e| RecordError::new(path, None, e.to_string()))?;
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

/// The stream (`NET.STA.LOC.CHA`) a record's header names, read without decoding anything
/// else: for naming a record that cannot be decoded (a corrupt time, sample count or Steim
/// frame) in a log line. MiniSEED 2: the fixed header's codes; MiniSEED 3: the FDSN source
/// identifier. `None` when the bytes do not start like a record or the codes are not
/// printable ASCII.
#[must_use]
pub fn record_stream_id(bytes: &[u8]) -> Option<String> {
    let printable = |raw: &[u8]| -> Option<String> {
        raw.iter()
            .all(|&c| c.is_ascii_graphic() || c == b' ' || c == 0)
            .then(|| {
                raw.iter()
                    .filter(|&&c| c != 0)
                    .map(|&c| char::from(c))
                    .collect::<String>()
                    .trim()
                    .to_string()
            })
    };
    let (net, sta, loc, cha) = match signature(bytes) {
        Signature::None => return None,
        Signature::V2 => {
            let fixed = bytes.get(..20)?;
            (
                printable(&fixed[18..20])?,
                printable(&fixed[8..13])?,
                printable(&fixed[13..15])?,
                printable(&fixed[15..18])?,
            )
        }
        Signature::V3 => {
            let sid_length = usize::from(*bytes.get(33)?);
            let sid = bytes.get(V3_FIXED..V3_FIXED + sid_length)?;
            parse_fdsn_sid(&printable(sid)?).ok()?
        }
    };
    Some(format!("{net}.{sta}.{loc}.{cha}"))
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
    fn a_record_that_cannot_be_decoded_still_names_its_stream() {
        let mut v2 = b"000001D XSTN 00HN3XX".to_vec();
        v2.resize(64, 0);
        // Year 0: not decodable, but the codes are there.
        assert!(parse_mseed(&v2, Path::new("r")).is_err());
        assert_eq!(record_stream_id(&v2).as_deref(), Some("XX.XSTN.00.HN3"));
        assert_eq!(record_stream_id(b"garbage garbage garbage"), None);
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
}
