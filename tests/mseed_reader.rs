//! MiniSEED reader: the malformed/edge-case corpus (every file has an expectation), the
//! encoding controls, real accelerograph records against their README, MiniSEED 3 against
//! MiniSEED 2 twins and against an independent encoder (libmseed), and mutation robustness.
//!
//! Reference checksums ("libmseed 3.1.3: n, sum, Σ k·x_k") were computed with libmseed 3.1.3
//! (through the `mseed` crate) during the reader evaluation (docs/mseed-reader.md): an
//! independent decoder, so a match is evidence and not a tautology.

use rockwatch_core::azimuth::Azimuth;
use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::time::Duration;

use rockwatch_core::record::mseed::{
    parse_mseed, read_mseed, record_from_channels, record_from_enz, Channel, GapFill, MseedFile,
    SampleKind, NS_PER_S,
};
use rockwatch_core::record::{Record, RecordError};

fn data(rel: &str) -> PathBuf {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."))
        .join("tests/data")
        .join(rel)
}

/// Reads `path` on another thread; fails the test if it takes more than 10 s (a hang).
fn read_with_timeout(path: &Path) -> Result<MseedFile, RecordError> {
    let (tx, rx) = mpsc::channel();
    let owned = path.to_path_buf();
    std::thread::spawn(move || {
        let _ = tx.send(read_mseed(&owned));
    });
    match rx.recv_timeout(Duration::from_secs(10)) {
        Ok(result) => result,
        Err(mpsc::RecvTimeoutError::Timeout) => {
            panic!("{}: read took > 10 s (hang?)", path.display())
        }
        Err(mpsc::RecvTimeoutError::Disconnected) => {
            panic!("{}: the reader panicked", path.display())
        }
    }
}

/// What reading one corpus file must give.
#[derive(Debug)]
enum Expect {
    /// An error whose message contains this text (and names the file).
    Error(&'static str),
    /// A read: number of channels, total samples, and a warning fragment (None = no
    /// warnings at all; a warning means a documented partial read or an assumption).
    Read(usize, usize, Option<&'static str>),
}

use Expect::{Error, Read};

/// One expectation per file in tests/data/mseed-malformed (path relative to it). Errors are
/// the reader's policy (docs/mseed-reader.md); sample counts are those ObsPy and libmseed
/// report in that folder's README, except where a note says why we differ.
const MALFORMED: &[(&str, Expect)] = &[
    (
        "BW.BGLD.__.EHE.D.2008.001.first_10_records",
        Read(1, 4120, None),
    ),
    // Legacy gain-ranged encodings: not needed for accelerograms; a clear error.
    (
        "CDSN_encoding.mseed",
        Error("unsupported data encoding 16 (CDSN"),
    ),
    (
        "DWWSSN_encoding.mseed",
        Error("unsupported data encoding 32 (DWWSSN"),
    ),
    (
        "GEOSCOPE16_4_encoding.mseed",
        Error("unsupported data encoding 14 (GEOSCOPE"),
    ),
    (
        "SRO_encoding.mseed",
        Error("unsupported data encoding 30 (SRO"),
    ),
    ("bizarre/emptyfile.mseed", Error("empty file")),
    (
        "bizarre/endiantest.be-header.be-data.mseed",
        Read(1, 11947, None),
    ),
    (
        "bizarre/endiantest.be-header.le-data.mseed",
        Read(1, 11947, None),
    ),
    (
        "bizarre/endiantest.le-header.be-data.mseed",
        Read(1, 11947, None),
    ),
    (
        "bizarre/endiantest.le-header.le-data.mseed",
        Read(1, 11947, None),
    ),
    // The 0-sample middle record adds nothing; 252 + 262 samples are contiguous in time.
    ("bizarre/mseed_data_offset_0.mseed", Read(1, 514, None)),
    (
        "bizarre/mseed_no_blkt_1000.mseed",
        Read(1, 7536, Some("without blockette 1000")),
    ),
    // Partial read: the valid 4096-byte record; the junk after it is skipped and reported.
    (
        "brokenlastrecord.mseed",
        Read(1, 5980, Some("skipped 2206 bytes at byte 4096")),
    ),
    (
        "corrupt_one_extra_byte_at_end.mseed",
        Read(1, 412, Some("skipped 1 bytes at byte 512")),
    ),
    (
        "encoding/float32_Float32_bigEndian.mseed",
        Read(1, 50, None),
    ),
    (
        "encoding/float32_Float32_littleEndian.mseed",
        Read(1, 50, None),
    ),
    (
        "encoding/float64_Float64_bigEndian.mseed",
        Read(1, 50, None),
    ),
    (
        "encoding/float64_Float64_littleEndian.mseed",
        Read(1, 50, None),
    ),
    (
        "encoding/fullASCII_bigEndian.mseed",
        Error("only text (ASCII/log) records"),
    ),
    (
        "encoding/fullASCII_littleEndian.mseed",
        Error("only text (ASCII/log) records"),
    ),
    ("encoding/int16_INT16_bigEndian.mseed", Read(1, 50, None)),
    ("encoding/int16_INT16_littleEndian.mseed", Read(1, 50, None)),
    ("encoding/int32_INT32_bigEndian.mseed", Read(1, 50, None)),
    ("encoding/int32_INT32_littleEndian.mseed", Read(1, 50, None)),
    ("encoding/int32_Steim1_bigEndian.mseed", Read(1, 50, None)),
    (
        "encoding/int32_Steim1_littleEndian.mseed",
        Read(1, 50, None),
    ),
    ("encoding/int32_Steim2_bigEndian.mseed", Read(1, 50, None)),
    (
        "encoding/int32_Steim2_littleEndian.mseed",
        Read(1, 50, None),
    ),
    ("encoding/nan_float32.mseed", Read(1, 4, None)),
    ("encoding/nan_float64.mseed", Read(1, 4, None)),
    (
        "encoding/smallASCII_bigEndian.mseed",
        Error("only text (ASCII/log) records"),
    ),
    (
        "encoding/smallASCII_littleEndian.mseed",
        Error("only text (ASCII/log) records"),
    ),
    ("gaps.mseed", Read(1, 52728, None)),
    (
        "gecko_non_ascii_header.ms",
        Read(1, 206, Some("non-ASCII byte 0xF0")),
    ),
    // Stricter than libmseed (which only warns): a failed Steim check is an error.
    (
        "infinite-loop.mseed",
        Error("Steim-2 integrity check failed"),
    ),
    // Stricter than ObsPy (which wraps into the next second): an invalid time is an error.
    (
        "microsecond_wrap.mseed",
        Error("fractional seconds field 10000"),
    ),
    (
        "mseed_not_a_single_blkt_48byte_data_offset.mseed",
        Read(1, 3632, Some("without blockette 1000")),
    ),
    // A SEED volume header, then a data-record header cut off by the end of the file.
    ("not.mseed", Error("ends inside a MiniSEED 2 record header")),
    ("not2.mseed", Error("too short to hold a MiniSEED record")),
    ("not3.mseed", Error("too short to hold a MiniSEED record")),
    (
        "not4.mseed",
        Error("ends inside a MiniSEED 2 record header"),
    ),
    (
        "reclen_1024_without_sequence_numbers.mseed",
        Read(1, 932, None),
    ),
    (
        "record_with_invalid_word_order.mseed",
        Read(1, 1267, Some("invalid word order 95")),
    ),
    (
        "rt130_sr0_cropped.mseed",
        Error("only text (ASCII/log) records (GR.FUR..LOG)"),
    ),
    (
        "single_record_negative_sr_fact_and_mult.mseed",
        Read(1, 60, None),
    ),
    (
        "single_record_plus_noise_record.mseed",
        Read(1, 277, Some("skipped 512 bytes at byte 512")),
    ),
    ("test.mseed", Read(1, 11947, None)),
    (
        "three_records_zero_data_in_middle.mseed",
        Read(1, 824, None),
    ),
    ("two_channels.mseed", Read(2, 772, None)),
    (
        "various_noise_records.mseed",
        Read(4, 1108, Some("skipped 256 bytes at byte 0")),
    ),
    (
        "wrong_blockette_numbers_specified.mseed",
        Read(
            1,
            5492,
            Some("fixed header says 2 blockettes, but 1 were found"),
        ),
    ),
];

/// Files in the corpus folder that are documentation, not data.
const NOT_DATA: &[&str] = &["README.md", "PROVENANCE.md", "sha256sums.txt"];

fn corpus_files(dir: &Path, rel: &str, out: &mut Vec<String>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let entry = entry.unwrap();
        let name = entry.file_name().to_string_lossy().to_string();
        let rel_name = if rel.is_empty() {
            name.clone()
        } else {
            format!("{rel}/{name}")
        };
        if entry.file_type().unwrap().is_dir() {
            corpus_files(&entry.path(), &rel_name, out);
        } else if !NOT_DATA.contains(&name.as_str()) {
            out.push(rel_name);
        }
    }
}

#[test]
fn every_malformed_corpus_file_has_an_expectation() {
    let mut files = Vec::new();
    corpus_files(&data("mseed-malformed"), "", &mut files);
    files.sort();
    let missing: Vec<&String> = files
        .iter()
        .filter(|f| !MALFORMED.iter().any(|(name, _)| name == f))
        .collect();
    assert!(
        missing.is_empty(),
        "corpus files without an expectation in MALFORMED: {missing:?}"
    );
    let stale: Vec<&str> = MALFORMED
        .iter()
        .map(|(name, _)| *name)
        .filter(|name| !files.iter().any(|f| f == name))
        .collect();
    assert!(
        stale.is_empty(),
        "expectations for missing files: {stale:?}"
    );
}

#[test]
fn every_malformed_corpus_file_gives_its_expected_error_or_read() {
    let mut failures = Vec::new();
    for (name, expect) in MALFORMED {
        let path = data("mseed-malformed").join(name);
        let result = read_with_timeout(&path);
        let file_name = Path::new(name).file_name().unwrap().to_string_lossy();
        match (expect, result) {
            (Error(fragment), Err(e)) => {
                let text = e.to_string();
                if !text.contains(fragment) || !text.contains(file_name.as_ref()) {
                    failures.push(format!(
                        "{name}: error {text:?} lacks {fragment:?} or the file name"
                    ));
                }
            }
            (Error(fragment), Ok(file)) => failures.push(format!(
                "{name}: expected an error containing {fragment:?}, read {} channel(s)",
                file.channels.len()
            )),
            (Read(channels, samples, warning), Ok(file)) => {
                let total: usize = file.channels.iter().map(Channel::sample_count).sum();
                if file.channels.len() != *channels || total != *samples {
                    failures.push(format!(
                        "{name}: {} channel(s), {total} samples; expected {channels}, {samples}",
                        file.channels.len()
                    ));
                }
                match warning {
                    None if !file.warnings.is_empty() => {
                        failures.push(format!("{name}: unexpected warnings {:?}", file.warnings))
                    }
                    Some(w) if !file.warnings.iter().any(|x| x.contains(w)) => {
                        failures.push(format!("{name}: warnings {:?} lack {w:?}", file.warnings))
                    }
                    _ => {}
                }
            }
            (Read(..), Err(e)) => failures.push(format!("{name}: expected a read, got {e}")),
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

fn single_channel(rel: &str) -> Channel {
    let file = read_mseed(&data(rel)).unwrap();
    assert_eq!(file.channels.len(), 1, "{rel}");
    file.channels.into_iter().next().unwrap()
}

fn all_samples(channel: &Channel) -> Vec<f64> {
    channel
        .segments
        .iter()
        .flat_map(|s| s.samples.iter().copied())
        .collect()
}

/// (count, Σ x_k, Σ k·x_k with k from 1) of the samples.
fn checksums(samples: &[f64]) -> (usize, i64, i128) {
    let sum = samples.iter().map(|&x| x as i64).sum();
    let weighted = samples
        .iter()
        .enumerate()
        .map(|(k, &x)| (k as i128 + 1) * x as i128)
        .sum();
    (samples.len(), sum, weighted)
}

#[test]
fn valid_encoding_controls_decode_to_one_through_fifty() {
    // The README: "the same 50 samples in each encoding × byte order". They are 1, 2, …, 50
    // (libmseed 3.1.3 decodes the same; another public decoder's table gives first 1, 2,
    // last 50, sum 1275, Σ k·x_k 42925, which 1..=50 satisfies).
    let expected: Vec<f64> = (1..=50).map(f64::from).collect();
    for encoding in [
        "int16_INT16",
        "int32_INT32",
        "int32_Steim1",
        "int32_Steim2",
        "float32_Float32",
        "float64_Float64",
    ] {
        for order in ["bigEndian", "littleEndian"] {
            let rel = format!("mseed-malformed/encoding/{encoding}_{order}.mseed");
            let c = single_channel(&rel);
            assert_eq!(all_samples(&c), expected, "{rel}");
            assert_eq!(c.id(), "XX.TEST..BHE", "{rel}");
            assert_eq!(c.sample_rate_hz, 1.0, "{rel}");
            // 2004-12-15T00:00:00Z = 1103068800 s (`date -u -d ... +%s`).
            assert_eq!(c.start_time_ns, 1_103_068_800 * NS_PER_S, "{rel}");
            let kind = if encoding.starts_with("float") {
                SampleKind::Float
            } else {
                SampleKind::Integer
            };
            assert_eq!(c.sample_kind, kind, "{rel}");
        }
    }
}

#[test]
fn byte_swapped_float_files_decode_to_the_documented_values() {
    let documented = [-1188.07800293, 638.16400146, 395.07809448, 1060.28112793];
    // The README prints 8 decimals (±5e-9); float32 adds its rounding: half a unit in the
    // last place at |x| < 2048 is 2^-13 ≈ 1.2e-4.
    for (rel, tolerance) in [
        ("mseed-malformed/encoding/nan_float64.mseed", 5e-9),
        ("mseed-malformed/encoding/nan_float32.mseed", 1.3e-4),
    ] {
        let got = all_samples(&single_channel(rel));
        assert_eq!(got.len(), 4);
        for (g, d) in got.iter().zip(documented) {
            assert!((g - d).abs() <= tolerance, "{rel}: {g} vs {d}");
        }
    }
}

#[test]
fn corpus_files_match_libmseed_checksums() {
    // (file, channel, n, Σx, Σk·x) from libmseed 3.1.3 (see the module doc).
    let table: &[(&str, &str, usize, i64, i128)] = &[
        (
            "mseed-malformed/test.mseed",
            "NL.HGN.00.BHZ",
            11947,
            33241452,
            198552037961,
        ),
        (
            "mseed-malformed/bizarre/endiantest.be-header.le-data.mseed",
            "NL.HGN.00.BHZ",
            11947,
            33241452,
            198552037961,
        ),
        (
            "mseed-malformed/bizarre/endiantest.le-header.be-data.mseed",
            "NL.HGN.00.BHZ",
            11947,
            33241452,
            198552037961,
        ),
        (
            "mseed-malformed/bizarre/endiantest.le-header.le-data.mseed",
            "NL.HGN.00.BHZ",
            11947,
            33241452,
            198552037961,
        ),
        (
            "mseed-malformed/gaps.mseed",
            "BW.BGLD..EHE",
            52728,
            -20781450,
            -546485021687,
        ),
        (
            "mseed-malformed/bizarre/mseed_no_blkt_1000.mseed",
            ".GRA1..BHZ",
            7536,
            13799,
            50507392,
        ),
        (
            "mseed-malformed/reclen_1024_without_sequence_numbers.mseed",
            "XX.STF1..HHN",
            932,
            -1353458,
            -639982246,
        ),
        (
            "mseed-malformed/gecko_non_ascii_header.ms",
            ".GECKO.A.CNZ",
            206,
            19765,
            1872403,
        ),
        (
            "mseed-malformed/record_with_invalid_word_order.mseed",
            "IU.COR..LHZ",
            1267,
            -3201635,
            -2054442232,
        ),
        (
            "mseed-malformed/two_channels.mseed",
            "BW.UH3..EHZ",
            386,
            -32624,
            -6388560,
        ),
        (
            "mseed-malformed/mseed_not_a_single_blkt_48byte_data_offset.mseed",
            "XX.TEST..BHE",
            3632,
            141292,
            198494172,
        ),
        (
            "mseed-malformed/wrong_blockette_numbers_specified.mseed",
            "SK.MODS..HHZ",
            5492,
            -18399767,
            -50541705109,
        ),
        (
            "mseed-malformed/single_record_negative_sr_fact_and_mult.mseed",
            "MN.TNV..VHZ",
            60,
            -3015914,
            -92202747,
        ),
        (
            "mseed-malformed/BW.BGLD.__.EHE.D.2008.001.first_10_records",
            "BW.BGLD..EHE",
            4120,
            -1623886,
            -3337509185,
        ),
        (
            "mseed/knet_AKT013_HNE_counts.mseed",
            "BO.AKT01..HNE",
            5900,
            -106245985,
            -313474187540,
        ),
        (
            "mseed/k2_STNA_HN123_counts.mseed",
            "XX.STN..HN1",
            8250,
            -85425556,
            -352351463716,
        ),
        (
            "mseed/k2_STNA_HN123_counts.mseed",
            "XX.STN..HN2",
            8250,
            -128780962,
            -531379112464,
        ),
        (
            "mseed/k2_STNA_HN123_counts.mseed",
            "XX.STN..HN3",
            8250,
            -98704506,
            -407432908134,
        ),
    ];
    for &(rel, id, n, sum, weighted) in table {
        let file = read_mseed(&data(rel)).unwrap();
        let channel = file
            .channels
            .iter()
            .find(|c| c.id() == id)
            .unwrap_or_else(|| panic!("{rel}: no channel {id}"));
        assert_eq!(
            checksums(&all_samples(channel)),
            (n, sum, weighted),
            "{rel} {id}"
        );
    }
}

#[test]
fn gaps_are_listed_with_times_and_sizes() {
    let c = single_channel("mseed-malformed/gaps.mseed");
    // ObsPy (README): segments of 412, 824, 824, 50668 samples at 200 Hz starting
    // 2007-12-31T23:59:59.915, 2008-01-01T00:00:04.035, 00:00:10.215, 00:00:18.455.
    let lengths: Vec<usize> = c.segments.iter().map(|s| s.samples.len()).collect();
    assert_eq!(lengths, vec![412, 824, 824, 50668]);
    let t0 = 1_199_145_599 * NS_PER_S; // 2007-12-31T23:59:59Z
    let starts_ms = [915, 5035, 11215, 19455];
    for (segment, ms) in c.segments.iter().zip(starts_ms) {
        assert_eq!(segment.start_time_ns, t0 + ms * 1_000_000);
    }
    assert!(c.overlaps.is_empty());
    // Each gap: next start − (previous start + n/200 s): 2.06 s, 2.06 s, 4.12 s.
    let sizes: Vec<f64> = c.gaps.iter().map(|g| g.size_s).collect();
    let expected = [2.06, 2.06, 4.12];
    assert_eq!(sizes.len(), 3);
    for ((gap, size), want) in c.gaps.iter().zip(&sizes).zip(expected) {
        assert!((size - want).abs() < 1e-9, "{size} vs {want}");
        assert!((gap.size_samples - want * 200.0).abs() < 1e-6);
        assert_eq!(gap.actual_ns - gap.expected_ns, (want * 1e9).round() as i64);
    }
    assert_eq!(c.gaps[0].expected_ns, t0 + 2_975_000_000); // 23:59:59.915 + 2.06 s
    assert_eq!(c.gaps[0].after_segment, 0);

    let err = c.to_record(1.0, GapFill::Reject).unwrap_err().to_string();
    assert!(
        err.contains("3 gap(s)") && err.contains("gaps.mseed"),
        "{err}"
    );
    let filled = c.contiguous_samples(GapFill::Zeros).unwrap();
    // 52728 samples + gaps of 412 + 412 + 824 samples.
    assert_eq!(filled.len(), 52728 + 412 + 412 + 824);
    assert!(filled[412..824].iter().all(|&x| x == 0.0));
    assert_eq!(filled[824], c.segments[1].samples[0]);
}

#[test]
fn knet_counts_times_gain_equal_the_ms2_file() {
    let counts = single_channel("mseed/knet_AKT013_HNE_counts.mseed");
    let ms2 = single_channel("mseed/knet_AKT013_HNE_ms2.mseed");
    // README: 100 Hz, 5900 samples, start 1996-08-10T18:12:24Z (= 839700744 s), BO.AKT01..HNE.
    for c in [&counts, &ms2] {
        assert_eq!(c.id(), "BO.AKT01..HNE");
        assert_eq!(c.sample_rate_hz, 100.0);
        assert_eq!(c.sample_count(), 5900);
        assert_eq!(c.start_time_ns, 839_700_744 * NS_PER_S);
        assert!(c.gaps.is_empty() && c.overlaps.is_empty());
    }
    assert_eq!(counts.sample_kind, SampleKind::Integer);
    assert_eq!(ms2.sample_kind, SampleKind::Float);
    let gain = 2.384185791015625e-06; // (m/s²)/count, README
    let scaled = counts.counts_to_mps2(gain).unwrap();
    let (a, b) = (all_samples(&scaled), all_samples(&ms2));
    // FLOAT64 file written as counts × gain in double precision: equal to within one ulp.
    for (x, y) in a.iter().zip(&b) {
        assert!((x - y).abs() <= f64::EPSILON * y.abs(), "{x} vs {y}");
    }
    // README: mean-removed peak 0.0438328 m/s² (= the K-NET header's 4.383 gal); 6 digits.
    let mean = a.iter().sum::<f64>() / a.len() as f64;
    let peak = a.iter().map(|x| (x - mean).abs()).fold(0.0, f64::max);
    assert!((peak - 0.0438328).abs() < 5e-7, "peak {peak}");

    let record = counts.to_record(gain, GapFill::Reject).unwrap();
    assert_eq!(record.dt_s, 0.01);
    assert_eq!(record.len(), 5900);
    assert!(record.vertical_mps2.is_none());
    assert_eq!(record.horizontal_mps2, a);
}

#[test]
fn k2_counts_times_calib_equal_the_float32_file() {
    let counts = read_mseed(&data("mseed/k2_STNA_HN123_counts.mseed")).unwrap();
    let ms2 = read_mseed(&data("mseed/k2_STNA_HN123_ms2_float32.mseed")).unwrap();
    // README: calib (m/s² per count) and mean-removed peak per channel.
    let table = [
        ("XX.STN..HN1", 1.1682748289245507e-06, 0.074027),
        ("XX.STN..HN2", 1.1682281943836448e-06, 0.061998),
        ("XX.STN..HN3", 1.1687419361571917e-06, 0.043028),
    ];
    let ids: Vec<String> = counts.channels.iter().map(Channel::id).collect();
    assert_eq!(ids, table.map(|t| t.0.to_string()));
    for (id, gain, peak_mps2) in table {
        let c = counts.channels.iter().find(|c| c.id() == id).unwrap();
        let m = ms2.channels.iter().find(|c| c.id() == id).unwrap();
        // README: 250 Hz, 8250 samples, start 2002-07-22T04:46:49 (= 1027313209 s).
        for ch in [c, m] {
            assert_eq!(ch.sample_rate_hz, 250.0);
            assert_eq!(ch.sample_count(), 8250);
            assert_eq!(ch.start_time_ns, 1_027_313_209 * NS_PER_S);
        }
        let a = all_samples(&c.counts_to_mps2(gain).unwrap());
        let b = all_samples(m);
        // FLOAT32 file: rounding to f32 is within half an f32 ulp, 2^-24 relative.
        for (x, y) in a.iter().zip(&b) {
            assert!(
                (x - y).abs() <= 2f64.powi(-24) * x.abs(),
                "{id}: {x} vs {y}"
            );
        }
        let mean = a.iter().sum::<f64>() / a.len() as f64;
        let peak = a.iter().map(|x| (x - mean).abs()).fold(0.0, f64::max);
        assert!((peak - peak_mps2).abs() < 5e-7, "{id}: peak {peak}"); // README: 6 decimals
    }
}

#[test]
fn enz_triple_rotates_to_the_block_azimuth() {
    let file = read_mseed(&data("mseed/k2_STNA_HN123_counts.mseed")).unwrap();
    let [e, n, z] = [0, 1, 2].map(|i| &file.channels[i]);
    let gains = [
        1.1682748289245507e-06,
        1.1682281943836448e-06,
        1.1687419361571917e-06,
    ];
    let scaled = |c: &Channel, g: f64| all_samples(&c.counts_to_mps2(g).unwrap());
    let az = |degrees: f64| Azimuth::from_degrees(degrees).unwrap();
    // Azimuth 90° (east): a_h = a_E; azimuth 0° (north): a_h = a_N.
    let east = record_from_enz(
        (e, gains[0]),
        (n, gains[1]),
        Some((z, gains[2])),
        az(90.0),
        GapFill::Reject,
    )
    .unwrap();
    let north =
        record_from_enz((e, gains[0]), (n, gains[1]), None, az(0.0), GapFill::Reject).unwrap();
    // cos 90° is 6e-17, not 0: allow 1e-15 m/s² (samples are < 0.1 m/s²).
    for (x, y) in east.horizontal_mps2.iter().zip(scaled(e, gains[0])) {
        assert!((x - y).abs() < 1e-15);
    }
    assert_eq!(north.horizontal_mps2, scaled(n, gains[1]));
    assert_eq!(east.vertical_mps2, Some(scaled(z, gains[2])));
    assert_eq!(east.dt_s, 1.0 / 250.0);
    // 45°: (a_N + a_E)/√2.
    let diag = record_from_enz(
        (e, gains[0]),
        (n, gains[1]),
        None,
        az(45.0),
        GapFill::Reject,
    )
    .unwrap();
    let (ae, an) = (scaled(e, gains[0]), scaled(n, gains[1]));
    for (k, x) in diag.horizontal_mps2.iter().enumerate() {
        let want = (ae[k] + an[k]) / 2f64.sqrt();
        assert!((x - want).abs() < 1e-15);
    }
    let hv = record_from_channels((e, gains[0]), Some((z, gains[2])), GapFill::Reject).unwrap();
    assert_eq!(hv.vertical_mps2.as_ref().map(Vec::len), Some(8250));
    assert!(e.counts_to_mps2(0.0).is_err() && e.counts_to_mps2(f64::NAN).is_err());
}

#[test]
fn record_read_dispatches_miniseed_extensions() {
    let record = Record::read(&data("mseed/knet_AKT013_HNE_ms2.mseed")).unwrap();
    assert_eq!(record.len(), 5900);
    assert_eq!(record.dt_s, 0.01);
    let ms2 = single_channel("mseed/knet_AKT013_HNE_ms2.mseed");
    assert_eq!(record.horizontal_mps2, all_samples(&ms2));

    let err = Record::read(&data("mseed/k2_STNA_HN123_ms2_float32.mseed"))
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("3 channels") && err.contains("XX.STN..HN1, XX.STN..HN2, XX.STN..HN3"),
        "{err}"
    );
    let err = Record::read(&data("mseed/knet_AKT013_HNE_counts.mseed"))
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("integer counts") && err.contains("gain"),
        "{err}"
    );

    // `.ms` and `.miniseed` (case-insensitive) dispatch the same way.
    let dir = tempfile::tempdir().unwrap();
    for name in ["a.ms", "b.MINISEED"] {
        let path = dir.path().join(name);
        std::fs::copy(data("mseed/knet_AKT013_HNE_ms2.mseed"), &path).unwrap();
        assert_eq!(Record::read(&path).unwrap().len(), 5900, "{name}");
    }
}

#[test]
fn miniseed3_twins_decode_like_their_miniseed2_originals() {
    for stem in [
        "reference-testdata-steim2",
        "testdata-3channel-signal",
        "testdata-oneseries-mixedlengths-mixedorder",
    ] {
        let v2 = read_mseed(&data(&format!("mseed/libmseed/{stem}.mseed2"))).unwrap();
        let v3 = read_mseed(&data(&format!("mseed/libmseed/{stem}.mseed3"))).unwrap();
        assert!(v2.warnings.is_empty() && v3.warnings.is_empty(), "{stem}");
        assert_eq!(v2.channels.len(), v3.channels.len(), "{stem}");
        for (a, b) in v2.channels.iter().zip(&v3.channels) {
            assert_eq!(a.id(), b.id(), "{stem}");
            assert_eq!(a.sample_rate_hz, b.sample_rate_hz, "{stem}");
            // MiniSEED 2 times carry 0.1 ms + a µs offset; v3 carries ns: same instant.
            assert_eq!(a.start_time_ns, b.start_time_ns, "{stem}");
            assert_eq!(all_samples(a), all_samples(b), "{stem} {}", a.id());
        }
    }
    // libmseed 3.1.3 counts (PROVENANCE.md).
    let three = read_mseed(&data("mseed/libmseed/testdata-3channel-signal.mseed3")).unwrap();
    let ids: Vec<String> = three.channels.iter().map(Channel::id).collect();
    assert_eq!(ids, ["IU.COLA.00.LH1", "IU.COLA.00.LH2", "IU.COLA.00.LHZ"]);
    assert!(three.channels.iter().all(|c| c.sample_count() == 4200));
    // Records out of time order still give one gap-free series.
    let mixed = single_channel("mseed/libmseed/testdata-oneseries-mixedlengths-mixedorder.mseed3");
    assert_eq!(mixed.sample_count(), 3952);
    assert_eq!(mixed.segments.len(), 1);
    let steim2 = single_channel("mseed/libmseed/reference-testdata-steim2.mseed3");
    assert_eq!((steim2.sample_count(), steim2.sample_rate_hz), (499, 40.0));
    let no_b1000 = read_mseed(&data(
        "mseed/libmseed/testdata-no-blockette1000-steim1.mseed2",
    ))
    .unwrap();
    assert_eq!(no_b1000.channels[0].sample_count(), 7312);
    for text in [
        "reference-testdata-text.mseed2",
        "reference-testdata-text.mseed3",
    ] {
        let err = read_mseed(&data(&format!("mseed/libmseed/{text}")))
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("only text") && err.contains("XX.TEST..LOG"),
            "{err}"
        );
    }
}

/// The generator's series (tests/data/mseed/generated-v3/GENERATOR.md), recomputed here.
fn series(i: i64) -> i64 {
    if i < 300 {
        (i * i * 7919) % 200_001 - 100_000
    } else {
        i - 300
    }
}

#[test]
fn miniseed3_files_from_libmseed_decode_to_the_generated_series() {
    // Start 1 700 000 000.123456789 s; FDSN:XX_GEN3_00_H_N_Z.
    let start_ns = 1_700_000_000 * NS_PER_S + 123_456_789;
    type Case = (&'static str, f64, fn(i64) -> f64);
    let cases: &[Case] = &[
        ("v3_steim1", 100.0, |i| series(i) as f64),
        ("v3_steim2", 100.0, |i| series(i) as f64),
        ("v3_int32", 100.0, |i| series(i) as f64),
        ("v3_int16", 100.0, |i| (series(i) % 30_000) as f64),
        // Exact: |series| < 2^24, so series/1024 is exact in f32.
        ("v3_float32", 100.0, |i| series(i) as f64 / 1024.0),
        ("v3_float64_period", 4.0, |i| series(i) as f64 / 3.0),
    ];
    for &(stem, rate, value) in cases {
        let c = single_channel(&format!("mseed/generated-v3/{stem}.mseed3"));
        assert_eq!(c.id(), "XX.GEN3.00.HNZ", "{stem}");
        assert_eq!(c.sample_rate_hz, rate, "{stem}");
        assert_eq!(c.start_time_ns, start_ns, "{stem}");
        assert_eq!(c.segments.len(), 1, "{stem}");
        let expected: Vec<f64> = (0..400).map(value).collect();
        assert_eq!(all_samples(&c), expected, "{stem}");
    }
}

fn must_fail_cleanly(bytes: &[u8], fragment: &str) {
    let err = parse_mseed(bytes, Path::new("crafted.mseed"))
        .unwrap_err()
        .to_string();
    assert!(
        err.contains(fragment) && err.contains("crafted.mseed"),
        "{err}"
    );
}

#[test]
fn crafted_bad_headers_are_clear_errors() {
    let good = std::fs::read(data(
        "mseed-malformed/encoding/int32_Steim2_bigEndian.mseed",
    ))
    .unwrap();
    assert!(parse_mseed(&good, Path::new("x")).is_ok());

    // A blockette pointing back to itself (would loop forever if followed).
    let mut looped = good.clone();
    let first = u16::from_be_bytes([good[46], good[47]]) as usize;
    looped[first + 2..first + 4].copy_from_slice(&(first as u16).to_be_bytes());
    must_fail_cleanly(&looped, "invalid blockette chain");

    // Record length exponent 31 in blockette 1000.
    let mut huge = good.clone();
    huge[first + 6] = 31;
    must_fail_cleanly(&huge, "invalid record length 2^31");

    // Truncated in the middle of the record.
    must_fail_cleanly(&good[..200], "ends inside the record");

    // More samples announced than the frames can hold.
    let mut greedy = good.clone();
    greedy[30..32].copy_from_slice(&60000u16.to_be_bytes());
    must_fail_cleanly(&greedy, "frames hold at most");

    // Hour 25.
    let mut late = good.clone();
    late[24] = 25;
    must_fail_cleanly(&late, "invalid start time");

    // MiniSEED 3: one flipped data bit breaks the CRC.
    let mut v3 = std::fs::read(data("mseed/generated-v3/v3_steim2.mseed3")).unwrap();
    let last = v3.len() - 100;
    v3[last] ^= 0x10;
    must_fail_cleanly(&v3, "CRC mismatch");

    // Sample rate 0 with samples.
    let mut still = good.clone();
    still[32..36].fill(0);
    must_fail_cleanly(&still, "sampling rate 0 Hz");
}

/// Small deterministic generator (xorshift64*), so the mutation test is reproducible.
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
}

#[test]
fn mutated_and_truncated_files_never_panic_or_hang() {
    let sources = [
        "mseed-malformed/test.mseed",
        "mseed-malformed/two_channels.mseed",
        "mseed-malformed/encoding/int32_Steim1_littleEndian.mseed",
        "mseed/libmseed/testdata-oneseries-mixedlengths-mixedorder.mseed3",
        "mseed/generated-v3/v3_float64_period.mseed3",
    ];
    let (tx, rx) = mpsc::channel();
    let handle = std::thread::spawn(move || {
        let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
        let mut runs = 0usize;
        for rel in sources {
            let good = std::fs::read(data(rel)).unwrap();
            let exercise = |bytes: &[u8]| {
                if let Ok(file) = parse_mseed(bytes, Path::new(rel)) {
                    for c in &file.channels {
                        let _ = c.contiguous_samples(GapFill::Linear);
                        let _ = c.to_record(1.0, GapFill::Zeros);
                    }
                }
            };
            // Every truncation of the first 600 bytes.
            for len in 0..good.len().min(600) {
                exercise(&good[..len]);
                runs += 1;
            }
            // 2000 random mutations of 1–8 bytes, half of them in the first 128 bytes.
            for _ in 0..2000 {
                let mut bad = good.clone();
                for _ in 0..=(rng.next() % 8) {
                    let span = if rng.next() & 1 == 0 { 128 } else { bad.len() };
                    let at = (rng.next() as usize) % span.min(bad.len());
                    bad[at] = rng.next() as u8;
                }
                exercise(&bad);
                runs += 1;
            }
        }
        let _ = tx.send(runs);
    });
    match rx.recv_timeout(Duration::from_secs(60)) {
        Ok(runs) => assert!(runs > 10_000),
        Err(_) => panic!(
            "mutation run panicked or took > 60 s: {:?}",
            handle.join().err()
        ),
    }
}
