//! MiniSEED 2.4 writer: round trips through our reader, headers checked byte by byte against
//! the SEED 2.4 manual's field offsets (parsed here independently of the crate), an
//! independent read by ObsPy (when installed), and `rockwatch pulses --file-format mseed`
//! end to end.

use rockwatch_core::record::mseed::{
    encode_mseed, read_mseed, write_mseed, Blockette1001, ChannelData, FloatEncoding, RecordLength,
    SampleKind, Samples, WriteOptions, NS_PER_S,
};
use rockwatch_core::record::Record;
use rockwatch_test_harness::rockwatch_bin;
use std::path::{Path, PathBuf};
use std::process::Command;

// ---------------------------------------------------------------------------------------
// An independent MiniSEED 2 header parser (SEED 2.4 manual, chapter 8: fixed section of
// data header and blockettes 1000/1001), big-endian only.
// ---------------------------------------------------------------------------------------

#[derive(Debug, Clone, PartialEq)]
struct Hdr {
    sequence: String,
    quality: u8,
    reserved: u8,
    sta: String,
    loc: String,
    cha: String,
    net: String,
    year: u16,
    doy: u16,
    hour: u8,
    minute: u8,
    second: u8,
    fract: u16,
    nsamples: u16,
    factor: i16,
    multiplier: i16,
    flags: [u8; 3],
    nblockettes: u8,
    time_correction: i32,
    data_offset: u16,
    first_blockette: u16,
    /// (encoding, word order, record length exponent)
    b1000: (u8, u8, u8),
    /// (timing quality, µs offset, Steim frames)
    b1001: Option<(u8, i8, u8)>,
}

fn be16(b: &[u8], at: usize) -> u16 {
    u16::from_be_bytes([b[at], b[at + 1]])
}

fn text(b: &[u8]) -> String {
    String::from_utf8(b.to_vec())
        .unwrap()
        .trim_end()
        .to_string()
}

fn parse_header(r: &[u8]) -> Hdr {
    let first_blockette = be16(r, 46);
    assert_eq!(first_blockette, 48);
    assert_eq!(be16(r, 48), 1000, "blockette 1000 first");
    let next = be16(r, 50);
    let b1001 = match next {
        0 => None,
        56 => {
            assert_eq!(be16(r, 56), 1001);
            assert_eq!(be16(r, 58), 0, "blockette 1001 is the last");
            assert_eq!(r[62], 0, "reserved byte");
            Some((r[60], r[61] as i8, r[63]))
        }
        other => panic!("unexpected next blockette offset {other}"),
    };
    Hdr {
        sequence: text(&r[0..6]),
        quality: r[6],
        reserved: r[7],
        sta: text(&r[8..13]),
        loc: text(&r[13..15]),
        cha: text(&r[15..18]),
        net: text(&r[18..20]),
        year: be16(r, 20),
        doy: be16(r, 22),
        hour: r[24],
        minute: r[25],
        second: r[26],
        fract: be16(r, 28),
        nsamples: be16(r, 30),
        factor: be16(r, 32) as i16,
        multiplier: be16(r, 34) as i16,
        flags: [r[36], r[37], r[38]],
        nblockettes: r[39],
        time_correction: i32::from_be_bytes([r[40], r[41], r[42], r[43]]),
        data_offset: be16(r, 44),
        first_blockette,
        b1000: (r[52], r[53], r[54]),
        b1001,
    }
}

/// Naive UTC ns since the epoch of a header's start time (BTime + µs offset): counts days
/// year by year (not the crate's algorithm).
fn header_time_ns(h: &Hdr) -> i64 {
    let leap = |y: i64| (y % 4 == 0 && y % 100 != 0) || y % 400 == 0;
    let mut days: i64 = 0;
    if h.year >= 1970 {
        for y in 1970..i64::from(h.year) {
            days += if leap(y) { 366 } else { 365 };
        }
    } else {
        for y in i64::from(h.year)..1970 {
            days -= if leap(y) { 366 } else { 365 };
        }
    }
    days += i64::from(h.doy) - 1;
    let seconds =
        days * 86_400 + i64::from(h.hour) * 3600 + i64::from(h.minute) * 60 + i64::from(h.second);
    let us = i64::from(h.fract) * 100 + h.b1001.map_or(0, |b| i64::from(b.1));
    seconds * NS_PER_S + us * 1_000
}

/// Rounds ns to the nearest µs (half up), MiniSEED 2's resolution.
fn round_to_us(t_ns: i64) -> i64 {
    (t_ns + 500).div_euclid(1_000) * 1_000
}

/// 2023-06-15T08:30:12.345678Z (`date -u -d 2023-06-15T08:30:12Z +%s` = 1686817812).
const T_2023: i64 = 1_686_817_812 * NS_PER_S + 345_678_000;

/// Deterministic test signal with a wide dynamic range (no randomness crate needed).
fn signal(n: usize, seed: u64) -> Vec<f64> {
    let mut state = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
    (0..n)
        .map(|i| {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            let u = (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
            let scale = [1e-6, 1.0, 9.81, 1e5][i % 4];
            u * scale
        })
        .collect()
}

/// Random walk of counts whose steps cycle through every Steim-2 width (4 to 30 bits).
fn counts(n: usize, start: i32) -> Vec<i32> {
    let steps = [
        3,
        -8,
        15,
        -31,
        100,
        -128,
        500,
        -16_000,
        536_870_911,
        -536_870_912,
        7,
    ];
    let mut x = start;
    (0..n)
        .map(|i| {
            let value = x;
            let step = steps[(i * 7 + i / 11) % steps.len()];
            // Stay inside i32: turn back (by half a step) near the ends.
            x = match x.checked_add(step) {
                Some(v) => v,
                None => x - step / 2,
            };
            value
        })
        .collect()
}

fn write_tmp(channels: &[ChannelData<'_>], options: WriteOptions) -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("out.mseed");
    write_mseed(&path, channels, options).unwrap();
    (dir, path)
}

/// Samples per record for FLOAT32/FLOAT64: (record length − 64-byte header) / width.
fn float_capacity(length: RecordLength, encoding: FloatEncoding) -> usize {
    let width = match encoding {
        FloatEncoding::Float32 => 4,
        FloatEncoding::Float64 => 8,
    };
    (length.bytes() - 64) / width
}

/// Checks every record header of a single-channel file: sequence numbers from 1, quality
/// D, codes, sample counts (full records then the rest), rate factors, encoding, record
/// length, and start times against `start + samples_before / rate` with the rate given as
/// the exact fraction `num/den` Hz. Returns the headers.
#[allow(clippy::too_many_arguments)]
fn check_headers(
    bytes: &[u8],
    record_length: RecordLength,
    id: (&str, &str, &str, &str),
    start_ns: i64,
    (num, den): (i64, i64),
    factors: (i16, i16),
    encoding: u8,
    total: usize,
) -> Vec<Hdr> {
    let rl = record_length.bytes();
    assert_eq!(bytes.len() % rl, 0, "whole records");
    let mut headers = Vec::new();
    let mut before = 0usize;
    for (k, record) in bytes.chunks(rl).enumerate() {
        let h = parse_header(record);
        assert_eq!(h.sequence, format!("{:06}", k + 1));
        assert_eq!((h.quality, h.reserved), (b'D', b' '));
        assert_eq!(
            (
                h.net.as_str(),
                h.sta.as_str(),
                h.loc.as_str(),
                h.cha.as_str()
            ),
            id
        );
        assert_eq!((h.factor, h.multiplier), factors);
        assert_eq!(h.b1000, (encoding, 1, rl.trailing_zeros() as u8));
        assert_eq!(h.flags, [0, 0, 0]);
        assert_eq!(h.time_correction, 0);
        assert_eq!(h.data_offset, 64);
        assert_eq!(
            usize::from(h.nblockettes),
            1 + usize::from(h.b1001.is_some())
        );
        assert!(h.fract <= 9999);
        if let Some((_, us, _)) = h.b1001 {
            assert!((-50..=49).contains(&us), "µs offset {us}");
        }
        let offset =
            (before as i128 * den as i128 * NS_PER_S as i128 * 2 + num as i128) / (2 * num as i128);
        let expected = round_to_us(start_ns + offset as i64);
        assert_eq!(header_time_ns(&h), expected, "record {}", k + 1);
        before += usize::from(h.nsamples);
        headers.push(h);
    }
    assert_eq!(before, total, "sample counts add up");
    headers
}

// ---------------------------------------------------------------------------------------
// Round trips through our reader
// ---------------------------------------------------------------------------------------

/// A rate as given (Hz), the exact fraction num/den (Hz), expected factor and multiplier.
type RateCase = (f64, (i64, i64), (i16, i16));

const RATES: [RateCase; 6] = [
    (200.0, (200, 1), (200, 1)),
    (100.0, (100, 1), (100, 1)),
    (1.0 / 0.005, (200, 1), (200, 1)),
    (1.0 / 0.003, (1000, 3), (1000, -3)),
    (0.1, (1, 10), (-10, 1)),
    (0.4, (2, 5), (2, -5)),
];

#[test]
fn float_round_trip_at_several_rates_lengths_and_record_sizes() {
    for (rate, fraction, factors) in RATES {
        for record_length in [RecordLength::B512, RecordLength::B4096] {
            for float_encoding in [FloatEncoding::Float64, FloatEncoding::Float32] {
                let cap = float_capacity(record_length, float_encoding);
                // One sample, an empty tail, exactly full, one over, several full records,
                // and several records plus a tail.
                for n in [1, cap - 1, cap, cap + 1, 3 * cap, 3 * cap + 7] {
                    let samples = signal(n, n as u64);
                    let options = WriteOptions {
                        record_length,
                        float_encoding,
                        ..WriteOptions::default()
                    };
                    let channel = ChannelData {
                        id: "XX.P0001.00.HNX".into(),
                        start_time_ns: T_2023,
                        sample_rate_hz: rate,
                        samples: Samples::Float(&samples),
                    };
                    let (_dir, path) = write_tmp(&[channel], options);
                    let bytes = std::fs::read(&path).unwrap();
                    let context =
                        format!("{rate} Hz, {record_length:?}, {float_encoding:?}, n={n}");
                    assert_eq!(
                        bytes.len(),
                        n.div_ceil(cap) * record_length.bytes(),
                        "{context}"
                    );
                    let code = match float_encoding {
                        FloatEncoding::Float32 => 4,
                        FloatEncoding::Float64 => 5,
                    };
                    check_headers(
                        &bytes,
                        record_length,
                        ("XX", "P0001", "00", "HNX"),
                        T_2023,
                        fraction,
                        factors,
                        code,
                        n,
                    );
                    let file = read_mseed(&path).unwrap();
                    assert!(file.warnings.is_empty(), "{context}: {:?}", file.warnings);
                    let [c] = file.channels.as_slice() else {
                        panic!("{context}: one channel")
                    };
                    assert_eq!(c.id(), "XX.P0001.00.HNX");
                    assert_eq!(c.sample_rate_hz, fraction.0 as f64 / fraction.1 as f64);
                    assert_eq!(c.start_time_ns, T_2023);
                    assert_eq!(c.sample_kind, SampleKind::Float);
                    assert!(c.gaps.is_empty() && c.overlaps.is_empty(), "{context}");
                    assert_eq!(c.segments.len(), 1, "{context}");
                    let expected: Vec<f64> = match float_encoding {
                        FloatEncoding::Float64 => samples.clone(),
                        FloatEncoding::Float32 => {
                            samples.iter().map(|&x| f64::from(x as f32)).collect()
                        }
                    };
                    assert_same_samples(&c.segments[0].samples, &expected, &context);
                    // Unused bytes after the last sample are zero.
                    let last = bytes.len() - record_length.bytes();
                    let used = 64 + (n - (n - 1) / cap * cap) * (cap_width(float_encoding));
                    assert!(bytes[last + used..].iter().all(|&b| b == 0), "{context}");
                }
            }
        }
    }
}

fn cap_width(e: FloatEncoding) -> usize {
    match e {
        FloatEncoding::Float32 => 4,
        FloatEncoding::Float64 => 8,
    }
}

/// Steim-2 data words per record: 13 in frame 0 (after control, X0, Xn), 15 in the others.
fn steim_words(length: RecordLength) -> usize {
    let frames = (length.bytes() - 64) / 64;
    13 + 15 * (frames - 1)
}

#[test]
fn steim2_round_trip_of_counts_with_every_difference_width() {
    for record_length in [RecordLength::B512, RecordLength::B4096] {
        for (n, start) in [
            (1, 5),
            (2, -7),
            (1000, 0),
            (20_000, i32::MAX - 100),
            (5_000, i32::MIN + 3),
        ] {
            let data = counts(n, start);
            let channel = ChannelData {
                id: "XX.STA..HHZ".into(),
                start_time_ns: T_2023,
                sample_rate_hz: 100.0,
                samples: Samples::Counts(&data),
            };
            let options = WriteOptions {
                record_length,
                blockette_1001: Blockette1001::Always,
                ..WriteOptions::default()
            };
            let (_dir, path) = write_tmp(&[channel], options);
            let bytes = std::fs::read(&path).unwrap();
            let headers = check_headers(
                &bytes,
                record_length,
                ("XX", "STA", "", "HHZ"),
                T_2023,
                (100, 1),
                (100, 1),
                11,
                n,
            );
            for (h, record) in headers.iter().zip(bytes.chunks(record_length.bytes())) {
                // Blockette 1001's frame count covers the non-empty frames exactly.
                let frames = usize::from(h.b1001.unwrap().2);
                assert!(frames >= 1 && 64 + frames * 64 <= record.len());
                assert!(record[64 + frames * 64..].iter().all(|&b| b == 0));
                assert!(record[64 + (frames - 1) * 64..64 + frames * 64]
                    .iter()
                    .any(|&b| b != 0));
                // A 30-bit difference takes a word to itself, a 4-bit one a seventh: the
                // count lies between one and seven samples per data word.
                let words = steim_words(record_length);
                assert!(usize::from(h.nsamples) <= 7 * words);
            }
            let file = read_mseed(&path).unwrap();
            let [c] = file.channels.as_slice() else {
                panic!("one channel")
            };
            assert_eq!(c.sample_kind, SampleKind::Integer);
            assert_eq!(c.segments.len(), 1);
            let expected: Vec<f64> = data.iter().map(|&x| f64::from(x)).collect();
            assert_same_samples(
                &c.segments[0].samples,
                &expected,
                &format!("{record_length:?} n={n}"),
            );
        }
    }
}

#[test]
fn steim2_packs_seven_small_differences_per_word() {
    // Differences within ±7 fit 4 bits: every data word holds 7 samples, so a record holds
    // 7 × (13 + 15 × (frames − 1)) samples: 721 (512 B, 7 frames), 6601 (4096 B, 63 frames).
    for (record_length, per_record) in [(RecordLength::B512, 721), (RecordLength::B4096, 6601)] {
        assert_eq!(per_record, 7 * steim_words(record_length));
        let data: Vec<i32> = (0..2 * per_record + 3)
            .map(|i| [0, 7, -1, 6, -2, 5, 0][i % 7] + 1000)
            .collect();
        let channel = ChannelData {
            id: "XX.STA..HHZ".into(),
            start_time_ns: T_2023,
            sample_rate_hz: 100.0,
            samples: Samples::Counts(&data),
        };
        let options = WriteOptions {
            record_length,
            ..WriteOptions::default()
        };
        let bytes = encode_mseed(&[channel], options, Path::new("mem")).unwrap();
        let rl = record_length.bytes();
        let counts: Vec<u16> = bytes.chunks(rl).map(|r| parse_header(r).nsamples).collect();
        assert_eq!(counts, vec![per_record as u16, per_record as u16, 3]);
        // First record, frame 0: control word has code 3 for words 3..=15 (0x03FF_FFFF),
        // X0 = 1000, Xn = last sample of the record.
        let r = &bytes[..rl];
        assert_eq!(&r[64..68], &0x03FF_FFFFu32.to_be_bytes());
        assert_eq!(&r[68..72], &1000i32.to_be_bytes());
        assert_eq!(&r[72..76], &data[per_record - 1].to_be_bytes());
        let file = rockwatch_core::record::mseed::parse_mseed(&bytes, Path::new("mem")).unwrap();
        let expected: Vec<f64> = data.iter().map(|&x| f64::from(x)).collect();
        assert_same_samples(&file.channels[0].segments[0].samples, &expected, "steim2");
    }
}

#[test]
fn start_times_with_sub_millisecond_parts_round_trip_to_the_microsecond() {
    // 2023-12-31T23:59:59Z = 1704067199 s; 2024-01-01 is day 1 of 2024.
    let new_year_eve = 1_704_067_199 * NS_PER_S;
    // (start ns, expected BTime (year, doy, h, m, s, fract), expected µs offset)
    type BTime = (u16, u16, u8, u8, u8, u16);
    let cases: [(i64, BTime, Option<i8>); 7] = [
        (new_year_eve, (2023, 365, 23, 59, 59, 0), None),
        (new_year_eve + 1_000, (2023, 365, 23, 59, 59, 0), Some(1)),
        (new_year_eve + 49_000, (2023, 365, 23, 59, 59, 0), Some(49)),
        (new_year_eve + 50_000, (2023, 365, 23, 59, 59, 1), Some(-50)),
        (
            new_year_eve + 123_400_000,
            (2023, 365, 23, 59, 59, 1234),
            None,
        ),
        // .123456789 s rounds to .123457 = .1235 − 43 µs.
        (
            new_year_eve + 123_456_789,
            (2023, 365, 23, 59, 59, 1235),
            Some(-43),
        ),
        // .999950 s carries into the next year: 2024-001 00:00:00.0000 − 50 µs.
        (new_year_eve + 999_950_000, (2024, 1, 0, 0, 0, 0), Some(-50)),
    ];
    for (start, btime, offset) in cases {
        let samples = signal(1200, 3);
        let channel = ChannelData {
            id: "XX.P0001..HNX".into(),
            start_time_ns: start,
            sample_rate_hz: 200.0,
            samples: Samples::Float(&samples),
        };
        let (_dir, path) = write_tmp(&[channel], WriteOptions::default());
        let bytes = std::fs::read(&path).unwrap();
        let h = parse_header(&bytes[..4096]);
        assert_eq!(
            (h.year, h.doy, h.hour, h.minute, h.second, h.fract),
            btime,
            "start {start}"
        );
        assert_eq!(h.b1001.map(|b| b.1), offset, "start {start}");
        // Later records: 504 samples at 200 Hz = 2.52 s later, same sub-ms part.
        check_headers(
            &bytes,
            RecordLength::B4096,
            ("XX", "P0001", "", "HNX"),
            start,
            (200, 1),
            (200, 1),
            5,
            1200,
        );
        let file = read_mseed(&path).unwrap();
        assert_eq!(file.channels[0].start_time_ns, round_to_us(start));
        assert_eq!(file.channels[0].segments.len(), 1);
        assert_same_samples(
            &file.channels[0].segments[0].samples,
            &samples,
            "start time",
        );
    }
}

#[test]
fn record_start_times_follow_the_exact_rational_rate() {
    // 1000/3 Hz: 504 samples last 1.512 s exactly, so record k starts at start + 1.512·k s
    // (no drift, although 1/rate = 0.003 s is not exact in binary).
    let samples = signal(504 * 40 + 1, 9);
    let channel = ChannelData {
        id: "XX.P0001..CNX".into(),
        start_time_ns: T_2023,
        sample_rate_hz: 1.0 / 0.003,
        samples: Samples::Float(&samples),
    };
    let bytes = encode_mseed(&[channel], WriteOptions::default(), Path::new("mem")).unwrap();
    for (k, record) in bytes.chunks(4096).enumerate() {
        let h = parse_header(record);
        assert_eq!(header_time_ns(&h), T_2023 + k as i64 * 1_512_000_000);
    }
}

#[test]
fn two_channels_share_one_sequence_and_read_back_separately() {
    let east = signal(700, 1);
    let north = signal(300, 2);
    let channels = [
        ChannelData {
            id: "XX.P0001..HNE".into(),
            start_time_ns: T_2023,
            sample_rate_hz: 200.0,
            samples: Samples::Float(&east),
        },
        ChannelData {
            id: "XX.P0001..HNN".into(),
            start_time_ns: T_2023 + 5_000_000,
            sample_rate_hz: 200.0,
            samples: Samples::Float(&north),
        },
    ];
    let (_dir, path) = write_tmp(&channels, WriteOptions::default());
    let bytes = std::fs::read(&path).unwrap();
    let headers: Vec<Hdr> = bytes.chunks(4096).map(parse_header).collect();
    let summary: Vec<(&str, &str, u16)> = headers
        .iter()
        .map(|h| (h.sequence.as_str(), h.cha.as_str(), h.nsamples))
        .collect();
    assert_eq!(
        summary,
        vec![
            ("000001", "HNE", 504),
            ("000002", "HNE", 196),
            ("000003", "HNN", 300)
        ]
    );
    let file = read_mseed(&path).unwrap();
    let ids: Vec<String> = file.channels.iter().map(|c| c.id()).collect();
    assert_eq!(ids, ["XX.P0001..HNE", "XX.P0001..HNN"]);
    assert_same_samples(&file.channels[0].segments[0].samples, &east, "east");
    assert_same_samples(&file.channels[1].segments[0].samples, &north, "north");
    assert_eq!(file.channels[1].start_time_ns, T_2023 + 5_000_000);
}

// ---------------------------------------------------------------------------------------
// One header, byte by byte
// ---------------------------------------------------------------------------------------

#[test]
fn header_bytes_match_the_seed_manual_layout_computed_by_hand() {
    // 2024-03-01T12:34:56.789012Z: 2024-03-01 is day 31 + 29 + 1 = 61 of a leap year;
    // `date -u -d 2024-03-01T12:34:56Z +%s` = 1709296496. .789012 s = BTime .7890 (7890 =
    // 0x1ED2) + 12 µs in blockette 1001. 200 Hz: factor 200 (0x00C8), multiplier 1.
    let start = 1_709_296_496 * NS_PER_S + 789_012_000;
    let samples = [1.5_f64, -2.25, 1e-3];
    let channel = ChannelData {
        id: "XX.P0001.00.HNX".into(),
        start_time_ns: start,
        sample_rate_hz: 200.0,
        samples: Samples::Float(&samples),
    };
    let bytes = encode_mseed(&[channel], WriteOptions::default(), Path::new("mem")).unwrap();
    assert_eq!(bytes.len(), 4096);
    let mut expected: Vec<u8> = Vec::new();
    expected.extend_from_slice(b"000001"); // 0: sequence number
    expected.push(b'D'); // 6: data quality indicator
    expected.push(b' '); // 7: reserved
    expected.extend_from_slice(b"P0001"); // 8: station (5)
    expected.extend_from_slice(b"00"); // 13: location (2)
    expected.extend_from_slice(b"HNX"); // 15: channel (3)
    expected.extend_from_slice(b"XX"); // 18: network (2)
    expected.extend_from_slice(&[0x07, 0xE8]); // 20: year 2024
    expected.extend_from_slice(&[0x00, 0x3D]); // 22: day 61
    expected.extend_from_slice(&[12, 34, 56, 0]); // 24: hour, minute, second, unused
    expected.extend_from_slice(&[0x1E, 0xD2]); // 28: 0.0001 s units: 7890
    expected.extend_from_slice(&[0x00, 0x03]); // 30: number of samples
    expected.extend_from_slice(&[0x00, 0xC8]); // 32: sample rate factor 200
    expected.extend_from_slice(&[0x00, 0x01]); // 34: multiplier 1
    expected.extend_from_slice(&[0, 0, 0]); // 36: activity, I/O, data quality flags
    expected.push(2); // 39: number of blockettes
    expected.extend_from_slice(&[0, 0, 0, 0]); // 40: time correction
    expected.extend_from_slice(&[0x00, 0x40]); // 44: beginning of data: 64
    expected.extend_from_slice(&[0x00, 0x30]); // 46: first blockette: 48
    expected.extend_from_slice(&[0x03, 0xE8, 0x00, 0x38]); // 48: B1000, next at 56
    expected.extend_from_slice(&[5, 1, 12, 0]); // 52: FLOAT64, big-endian, 2^12, reserved
    expected.extend_from_slice(&[0x03, 0xE9, 0x00, 0x00]); // 56: B1001, last
    expected.extend_from_slice(&[0, 12, 0, 0]); // 60: timing quality, 12 µs, reserved, frames
    assert_eq!(expected.len(), 64);
    // 64: 1.5 = 0x3FF8000000000000, −2.25 = 0xC002000000000000 (IEEE 754), then 1e-3.
    expected.extend_from_slice(&[0x3F, 0xF8, 0, 0, 0, 0, 0, 0]);
    expected.extend_from_slice(&[0xC0, 0x02, 0, 0, 0, 0, 0, 0]);
    expected.extend_from_slice(&0x3F50_624D_D2F1_A9FCu64.to_be_bytes());
    expected.resize(4096, 0);
    assert_eq!(&bytes[..64], &expected[..64], "header");
    assert_eq!(bytes, expected);
}

// ---------------------------------------------------------------------------------------
// Errors
// ---------------------------------------------------------------------------------------

fn write_error(channels: &[ChannelData<'_>], options: WriteOptions) -> String {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.mseed");
    let err = write_mseed(&path, channels, options).unwrap_err();
    assert!(!path.exists(), "nothing is written on error");
    let text = err.to_string();
    assert!(text.contains("bad.mseed"), "names the file: {text}");
    text
}

#[test]
fn invalid_ids_rates_samples_and_times_are_clear_errors() {
    let make = |id: &str, rate: f64, samples: Samples<'static>, start: i64| ChannelData {
        id: id.into(),
        start_time_ns: start,
        sample_rate_hz: rate,
        samples,
    };
    let ok_samples: Samples<'static> = Samples::Float(&[0.5, 1.0]);
    let cases: Vec<(ChannelData<'static>, &str)> = vec![
        (
            make("XX.P0001.HNX", 200.0, ok_samples, 0),
            "NET.STA.LOC.CHA",
        ),
        (make("XX.P0001..HN", 200.0, ok_samples, 0), "channel code"),
        (
            make("XX.TOOLONG..HNX", 200.0, ok_samples, 0),
            "station code",
        ),
        (make(".P0001..HNX", 200.0, ok_samples, 0), "network code"),
        (
            make("XX.P0001.000.HNX", 200.0, ok_samples, 0),
            "location code",
        ),
        (make("xx.P0001..HNX", 200.0, ok_samples, 0), "upper-case"),
        (make("XX.P 01..HNX", 200.0, ok_samples, 0), "upper-case"),
        (
            make("XX.P0001..HNX", 0.0, ok_samples, 0),
            "finite number > 0",
        ),
        (
            make("XX.P0001..HNX", f64::NAN, ok_samples, 0),
            "finite number > 0",
        ),
        (
            make("XX.P0001..HNX", 81.000_012_3, ok_samples, 0),
            "cannot be written exactly",
        ),
        (make("XX.P0001..HNX", 2.0e6, ok_samples, 0), "1 µs"),
        (
            make("XX.P0001..HNX", 200.0, Samples::Float(&[]), 0),
            "no samples",
        ),
        (
            make("XX.P0001..HNX", 200.0, Samples::Float(&[1.0, f64::NAN]), 0),
            "sample 1 is NaN",
        ),
        (
            make("XX.P0001..HNX", 200.0, Samples::Counts(&[0, 1 << 29]), 0),
            "Steim-2",
        ),
        // 1899-12-31T23:59:59Z and 2101-01-01T00:00:00Z.
        (
            make(
                "XX.P0001..HNX",
                200.0,
                ok_samples,
                -2_208_988_801 * NS_PER_S,
            ),
            "1900-2100",
        ),
        (
            make("XX.P0001..HNX", 200.0, ok_samples, 4_133_980_800 * NS_PER_S),
            "1900-2100",
        ),
    ];
    for (channel, needle) in cases {
        let text = write_error(std::slice::from_ref(&channel), WriteOptions::default());
        assert!(
            text.contains(needle),
            "{}: expected {needle:?} in {text}",
            channel.id
        );
        assert!(text.contains(&channel.id), "names the channel: {text}");
    }
    let text = write_error(
        &[make("XX.P0001..HNX", 200.0, Samples::Float(&[1e39]), 0)],
        WriteOptions {
            float_encoding: FloatEncoding::Float32,
            ..WriteOptions::default()
        },
    );
    assert!(text.contains("FLOAT32 range"), "{text}");
    assert!(write_error(&[], WriteOptions::default()).contains("no channels"));
    let text = write_error(
        &[
            make("XX.P0001..HNX", 200.0, ok_samples, 0),
            make("XX.P0001..HNX", 100.0, ok_samples, 0),
        ],
        WriteOptions::default(),
    );
    assert!(text.contains("different sampling rates"), "{text}");
}

#[test]
fn last_record_ending_after_2100_is_an_error() {
    // Starts 2100-12-31T23:59:59Z (4133980799 s); the second record (504 samples at
    // 200 Hz = 2.52 s later) starts in 2101.
    let samples = vec![0.0; 600];
    let channel = ChannelData {
        id: "XX.P0001..HNX".into(),
        start_time_ns: 4_133_980_799 * NS_PER_S,
        sample_rate_hz: 200.0,
        samples: Samples::Float(&samples),
    };
    let text = write_error(&[channel], WriteOptions::default());
    assert!(
        text.contains("sample 504") && text.contains("2101"),
        "{text}"
    );
}

// ---------------------------------------------------------------------------------------
// ObsPy, when installed: `pip install obspy`
// ---------------------------------------------------------------------------------------

const OBSPY_SCRIPT: &str = r#"
import json, sys, warnings
import obspy
out = []
for path in sys.argv[1:]:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        st = obspy.read(path, format="MSEED")
    traces = []
    for tr in st:
        traces.append({
            "id": tr.id,
            "rate": tr.stats.sampling_rate,
            "start_ns": tr.stats.starttime.ns,
            "data": [repr(float(x)) for x in tr.data],
            "encoding": tr.stats.mseed.encoding,
            "record_length": tr.stats.mseed.record_length,
            "byteorder": tr.stats.mseed.byteorder,
            "dataquality": tr.stats.mseed.dataquality,
        })
    out.append({"traces": traces, "warnings": [str(w.message) for w in caught]})
print(json.dumps(out))
"#;

/// Runs the ObsPy reader on `files`; None (with a printed reason) when python3 or ObsPy is
/// missing — except under CI (`CI` set), whose `.ci/run` installs ObsPy: there a missing
/// ObsPy fails the test instead of skipping it.
fn obspy_read(files: &[PathBuf]) -> Option<serde_json::Value> {
    let probe = Command::new("python3")
        .args(["-c", "import obspy"])
        .output();
    match probe {
        Err(e) => {
            let reason =
                format!("python3 not available ({e}); install python3 and `pip install obspy`");
            assert!(std::env::var_os("CI").is_none(), "{reason}");
            println!("SKIPPED: {reason}");
            return None;
        }
        Ok(o) if !o.status.success() => {
            let reason = format!(
                "ObsPy not importable ({}); run `pip install obspy`",
                String::from_utf8_lossy(&o.stderr)
                    .lines()
                    .last()
                    .unwrap_or("")
            );
            assert!(std::env::var_os("CI").is_none(), "{reason}");
            println!("SKIPPED: {reason}");
            return None;
        }
        Ok(_) => {}
    }
    let output = Command::new("python3")
        .arg("-c")
        .arg(OBSPY_SCRIPT)
        .args(files)
        .output()
        .unwrap();
    assert!(
        output.status.success(),
        "ObsPy failed: {}",
        String::from_utf8_lossy(&output.stderr)
    );
    Some(serde_json::from_slice(&output.stdout).unwrap())
}

#[test]
fn obspy_reads_our_files_with_the_same_ids_rates_times_and_samples() {
    let dir = tempfile::tempdir().unwrap();
    let floats = signal(1500, 11);
    let ints = counts(3000, -12_345);
    // (file, channel, options, expected encoding name, expected samples, start ns, rate)
    struct Case {
        name: &'static str,
        id: &'static str,
        rate_hz: f64,
        start_ns: i64,
        options: WriteOptions,
        counts: bool,
        encoding: &'static str,
    }
    let cases = [
        Case {
            name: "f64_4096.mseed",
            id: "XX.P0001..HNX",
            rate_hz: 200.0,
            start_ns: T_2023,
            options: WriteOptions::default(),
            counts: false,
            encoding: "FLOAT64",
        },
        Case {
            name: "f32_512.mseed",
            id: "XX.P0002.00.CNX",
            rate_hz: 1.0 / 0.003,
            start_ns: T_2023 + 123_456_789,
            options: WriteOptions {
                record_length: RecordLength::B512,
                float_encoding: FloatEncoding::Float32,
                ..WriteOptions::default()
            },
            counts: false,
            encoding: "FLOAT32",
        },
        Case {
            name: "f64_period.mseed",
            id: "XX.LONG..LNX",
            rate_hz: 0.1,
            start_ns: 1_704_067_199 * NS_PER_S + 999_950_000,
            options: WriteOptions::default(),
            counts: false,
            encoding: "FLOAT64",
        },
        Case {
            name: "steim2_4096.mseed",
            id: "XX.STA.10.HHZ",
            rate_hz: 100.0,
            start_ns: T_2023 + 49_000,
            options: WriteOptions::default(),
            counts: true,
            encoding: "STEIM2",
        },
        Case {
            name: "steim2_512.mseed",
            id: "XX.STA.10.HHN",
            rate_hz: 100.0,
            start_ns: T_2023,
            options: WriteOptions {
                record_length: RecordLength::B512,
                ..WriteOptions::default()
            },
            counts: true,
            encoding: "STEIM2",
        },
    ];
    let mut files = Vec::new();
    for case in &cases {
        let path = dir.path().join(case.name);
        let samples = if case.counts {
            Samples::Counts(&ints)
        } else {
            Samples::Float(&floats)
        };
        let channel = ChannelData {
            id: case.id.into(),
            start_time_ns: case.start_ns,
            sample_rate_hz: case.rate_hz,
            samples,
        };
        write_mseed(&path, &[channel], case.options).unwrap();
        files.push(path);
    }
    let Some(json) = obspy_read(&files) else {
        return;
    };
    for (case, result) in cases.iter().zip(json.as_array().unwrap()) {
        let name = case.name;
        assert_eq!(
            result["warnings"].as_array().unwrap().len(),
            0,
            "{name}: {result}"
        );
        let traces = result["traces"].as_array().unwrap();
        assert_eq!(traces.len(), 1, "{name}: one trace (no gaps)");
        let t = &traces[0];
        assert_eq!(t["id"].as_str().unwrap(), case.id, "{name}");
        // ObsPy computes the rate from factor/multiplier in double precision.
        let rate = t["rate"].as_f64().unwrap();
        assert!(
            (rate - case.rate_hz).abs() <= 1e-12 * case.rate_hz,
            "{name}: {rate}"
        );
        assert_eq!(
            t["start_ns"].as_i64().unwrap(),
            round_to_us(case.start_ns),
            "{name}"
        );
        assert_eq!(t["encoding"].as_str().unwrap(), case.encoding, "{name}");
        assert_eq!(
            t["record_length"].as_u64().unwrap() as usize,
            case.options.record_length.bytes(),
            "{name}"
        );
        assert_eq!(t["byteorder"].as_str().unwrap(), ">", "{name}");
        assert_eq!(t["dataquality"].as_str().unwrap(), "D", "{name}");
        // Python's repr is the shortest string that reads back as the same double, and
        // Rust's parse rounds correctly: the comparison is exact.
        let data: Vec<f64> = t["data"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_str().unwrap().parse().unwrap())
            .collect();
        let expected: Vec<f64> = match (case.counts, case.options.float_encoding) {
            (true, _) => ints.iter().map(|&x| f64::from(x)).collect(),
            (false, FloatEncoding::Float64) => floats.clone(),
            (false, FloatEncoding::Float32) => {
                floats.iter().map(|&x| f64::from(x as f32)).collect()
            }
        };
        assert_same_samples(&data, &expected, name);
    }
}

// ---------------------------------------------------------------------------------------
// rockwatch pulses --file-format mseed, end to end
// ---------------------------------------------------------------------------------------

/// Exact equality of two sample vectors, reporting the first difference (not the vectors).
fn assert_same_samples(got: &[f64], expected: &[f64], context: &str) {
    assert_eq!(got.len(), expected.len(), "{context}: sample count");
    if let Some(i) = (0..got.len()).find(|&i| got[i] != expected[i]) {
        panic!(
            "{context}: sample {i} is {} but {} was written",
            got[i], expected[i]
        );
    }
}

fn pulses_json(out: &Path, extra: &[&str]) -> serde_json::Value {
    let mut args = vec![
        "pulses",
        "--mw",
        "7",
        "--r-km",
        "10",
        "--seed",
        "5",
        "--out",
        out.to_str().unwrap(),
        "--format",
        "json",
    ];
    if !extra.contains(&"--count") {
        args.extend_from_slice(&["--count", "3"]);
    }
    args.extend_from_slice(extra);
    let output = rockwatch_bin!().output(&args);
    assert!(
        output.status.success(),
        "stderr: {}",
        String::from_utf8_lossy(&output.stderr)
    );
    serde_json::from_slice(&output.stdout).unwrap()
}

fn files_of(json: &serde_json::Value) -> Vec<PathBuf> {
    json["pulses"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| PathBuf::from(p["file"].as_str().unwrap()))
        .collect()
}

#[test]
fn pulses_mseed_files_hold_the_same_samples_as_csv_files() {
    let dir = tempfile::tempdir().unwrap();
    let csv = files_of(&pulses_json(
        &dir.path().join("csv"),
        &["--file-format", "csv"],
    ));
    let f64_json = pulses_json(&dir.path().join("f64"), &["--file-format", "mseed"]);
    let f64_files = files_of(&f64_json);
    let f32_files = files_of(&pulses_json(
        &dir.path().join("f32"),
        &["--file-format", "mseed", "--mseed-encoding", "float32"],
    ));
    assert_eq!(csv.len(), 3);
    for (i, ((csv, f64_file), f32_file)) in csv.iter().zip(&f64_files).zip(&f32_files).enumerate() {
        assert_eq!(f64_file.extension().unwrap(), "mseed");
        // CSV round-trips exactly, so its samples are the pulse's samples.
        let reference = Record::read(csv).unwrap();
        let record = Record::read(f64_file).unwrap();
        assert_eq!(record.dt_s, 0.005);
        assert_same_samples(
            &record.horizontal_mps2,
            &reference.horizontal_mps2,
            "float64",
        );
        let single = Record::read(f32_file).unwrap();
        let rounded: Vec<f64> = reference
            .horizontal_mps2
            .iter()
            .map(|&x| f64::from(x as f32))
            .collect();
        assert_same_samples(&single.horizontal_mps2, &rounded, "float32");
        // Naming: XX.P000<id>..HNX (200 Hz is band H), timed from the epoch.
        let file = read_mseed(f64_file).unwrap();
        let c = &file.channels[0];
        assert_eq!(c.id(), format!("XX.P{:04}..HNX", i + 1));
        assert_eq!(c.start_time_ns, 0);
        assert_eq!(c.sample_rate_hz, 200.0);
        let pga = record
            .horizontal_mps2
            .iter()
            .fold(0.0_f64, |m, a| m.max(a.abs()));
        assert_eq!(pga, f64_json["pulses"][i]["pga_mps2"].as_f64().unwrap());
    }
}

#[test]
fn ims_reads_a_pulses_mseed_file_like_its_csv_twin() {
    let dir = tempfile::tempdir().unwrap();
    let extra = ["--count", "1", "--dt", "0.01"];
    let csv = files_of(&pulses_json(
        &dir.path().join("csv"),
        &[&extra[..], &["--file-format", "csv"]].concat(),
    ));
    let mseed = files_of(&pulses_json(
        &dir.path().join("ms"),
        &[&extra[..], &["--file-format", "mseed"]].concat(),
    ));
    let ims = |file: &Path| -> serde_json::Value {
        let output = rockwatch_bin!().output(&[
            "ims",
            "--record",
            file.to_str().unwrap(),
            "--format",
            "json",
        ]);
        assert!(
            output.status.success(),
            "stderr: {}",
            String::from_utf8_lossy(&output.stderr)
        );
        serde_json::from_slice(&output.stdout).unwrap()
    };
    let (from_csv, from_mseed) = (ims(&csv[0]), ims(&mseed[0]));
    assert_eq!(from_mseed["npts"], from_csv["npts"]);
    assert_eq!(from_mseed["pga"], from_csv["pga"]);
    // Same samples; the CSV reader derives dt from the time column, (t_last − t0)/(n − 1),
    // which can differ from 0.01 by an ulp or so, so time-integrated IMs agree to ~1e-12.
    fn compare(a: &serde_json::Value, b: &serde_json::Value, key: &str) {
        match (a, b) {
            (serde_json::Value::Object(x), serde_json::Value::Object(y)) => {
                assert_eq!(x.len(), y.len(), "{key}");
                for (k, v) in x {
                    compare(v, &y[k], &format!("{key}.{k}"));
                }
            }
            (serde_json::Value::Number(x), serde_json::Value::Number(y)) => {
                let (x, y) = (x.as_f64().unwrap(), y.as_f64().unwrap());
                assert!(
                    (x - y).abs() <= 1e-9 * x.abs().max(y.abs()),
                    "{key}: {x} vs {y}"
                );
            }
            _ => assert_eq!(a, b, "{key}"),
        }
    }
    compare(&from_mseed, &from_csv, "ims");
}

#[test]
fn pulses_mseed_band_code_follows_the_rate_and_bad_rates_fail_early() {
    let dir = tempfile::tempdir().unwrap();
    let files = files_of(&pulses_json(
        &dir.path().join("b"),
        &["--count", "1", "--dt", "0.02", "--file-format", "mseed"],
    ));
    let file = read_mseed(&files[0]).unwrap();
    assert_eq!(file.channels[0].id(), "XX.P0001..BNX");

    let out = dir.path().join("bad");
    let output = rockwatch_bin!().output(&[
        "pulses",
        "--mw",
        "7",
        "--r-km",
        "10",
        "--count",
        "2",
        "--out",
        out.to_str().unwrap(),
        "--dt",
        "0.0123456789",
        "--file-format",
        "mseed",
    ]);
    assert!(!output.status.success());
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        stderr.contains("--dt") && stderr.contains("cannot be written exactly"),
        "{stderr}"
    );
    assert!(!out.exists(), "fails before creating the output directory");
}
