//! Ground-acceleration records and their file formats: PEER NGA `.AT2`, CSV
//! and MiniSEED ([`mseed`]).
//!
//! A [`Record`] is a uniformly sampled acceleration time history in SI units:
//! `horizontal_mps2[i]` is the horizontal ground acceleration (m/s², + towards the block's
//! +x axis, "to the right") at `t = i·dt_s`, and `vertical_mps2`, when present, the vertical
//! ground acceleration (m/s², + up) at the same instants. [`Record::read`] picks the format
//! by the file's extension.
//!
//! Readers never panic on bad input: every problem is a [`RecordError`] whose message names
//! the file, the line where it applies, and what is wrong.
//!
//! Layout: this module holds what every format shares (the record, its error, text I/O and
//! the checks before writing); each format module uses only this parent, never a sibling.

mod at2;
mod csv;
pub mod mseed;

use std::fmt;
use std::path::{Path, PathBuf};

pub use at2::{parse_at2_text, read_at2, write_at2, At2, Component};
pub use csv::{read_csv, write_csv};

/// Re-exported: AT2 values (in g) are converted to m/s² with this value.
pub use crate::STANDARD_GRAVITY_MPS2;

/// Sampling intervals a record may have (s): 0.1 ms to 1 s, the sample rates the engine
/// accepts in a packet ([`crate::engine::packet::SAMPLE_RATE_RANGE_HZ`], 1 Hz to 10 kHz).
/// Bounds the work of every tool: a record's sample count is bounded by the file's size, and
/// its duration, padding and tails by this interval.
pub const DT_RANGE_S: (f64, f64) = (1e-4, 1.0);

/// Most samples a record may hold: about 28 h at 100 Hz, 80 MB per component.
pub const MAX_RECORD_SAMPLES: usize = 10_000_000;

/// Largest |ground acceleration| a record may carry (m/s²): 100 g, five times the largest
/// accelerometer range in use for strong motion (±20 g) and 25 times the largest recorded
/// ground acceleration (≈ 4 g). Values beyond are corrupt data or a unit mistake: the
/// integrators would overflow and report nothing.
pub const MAX_ABS_ACCEL_MPS2: f64 = 100.0 * STANDARD_GRAVITY_MPS2;

/// A uniformly sampled ground-acceleration record (SI units).
#[derive(Debug, Clone, PartialEq)]
pub struct Record {
    /// Where the record came from (file path, or a description for synthetic records).
    pub source: String,
    /// Sampling interval (s), > 0.
    pub dt_s: f64,
    /// Horizontal ground acceleration (m/s², + to the right / along the block's +x axis).
    pub horizontal_mps2: Vec<f64>,
    /// Vertical ground acceleration (m/s², + up), same length as `horizontal_mps2`.
    pub vertical_mps2: Option<Vec<f64>>,
}

impl Record {
    /// Number of samples.
    #[must_use]
    pub fn len(&self) -> usize {
        self.horizontal_mps2.len()
    }

    /// True when the record has no samples.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.horizontal_mps2.is_empty()
    }

    /// Duration from the first to the last sample (s).
    #[must_use]
    pub fn duration_s(&self) -> f64 {
        self.len().saturating_sub(1) as f64 * self.dt_s
    }

    /// Multiplies every sample (both components) by `factor`.
    pub fn scale(&mut self, factor: f64) {
        self.horizontal_mps2.iter_mut().for_each(|a| *a *= factor);
        if let Some(v) = &mut self.vertical_mps2 {
            v.iter_mut().for_each(|a| *a *= factor);
        }
    }

    /// Checks that the record is within the bounds every tool relies on: sampling interval in
    /// [`DT_RANGE_S`], 1 to [`MAX_RECORD_SAMPLES`] samples, every value finite and within
    /// ±[`MAX_ABS_ACCEL_MPS2`]. The error names the first problem (not the file).
    pub fn check_bounds(&self) -> Result<(), RecordBoundsError> {
        let (lo, hi) = DT_RANGE_S;
        if !(self.dt_s.is_finite() && (lo..=hi).contains(&self.dt_s)) {
            return Err(RecordBoundsError::SamplingInterval { dt_s: self.dt_s });
        }
        if self.is_empty() || self.len() > MAX_RECORD_SAMPLES {
            return Err(RecordBoundsError::Length {
                samples: self.len(),
            });
        }
        let components = [
            ("horizontal", Some(&self.horizontal_mps2)),
            ("vertical", self.vertical_mps2.as_ref()),
        ];
        for (component, values) in components {
            let Some(values) = values else { continue };
            if let Some((index, &value)) = values
                .iter()
                .enumerate()
                .find(|(_, a)| !a.is_finite() || a.abs() > MAX_ABS_ACCEL_MPS2)
            {
                return Err(RecordBoundsError::Value {
                    component,
                    index,
                    value,
                });
            }
        }
        Ok(())
    }

    /// Reads a horizontal record from `path`, choosing the format by extension
    /// (`.at2` → PEER NGA AT2, `.csv` → CSV, `.mseed`/`.ms`/`.miniseed` → MiniSEED;
    /// case-insensitive). A MiniSEED file must hold exactly one channel of floating-point
    /// samples in m/s² (see [`mseed::read_single_channel_record`]; counts need a gain
    /// and go through [`mseed::read_mseed`]). The record must be within
    /// [`Record::check_bounds`].
    pub fn read(path: &Path) -> Result<Record, RecordError> {
        let record = Self::read_unchecked(path)?;
        record
            .check_bounds()
            .map_err(|problem| RecordError::new(path, None, problem.to_string()))?;
        Ok(record)
    }

    fn read_unchecked(path: &Path) -> Result<Record, RecordError> {
        match extension_lowercase(path).as_deref() {
            Some("at2") => read_at2(path).map(|at2| at2.into_record(path)),
            Some("csv") => read_csv(path),
            Some("mseed" | "ms" | "miniseed") => mseed::read_single_channel_record(path),
            _ => Err(RecordError::new(
                path,
                None,
                "unknown record format: expected a .AT2, .csv or MiniSEED (.mseed, .ms, \
                 .miniseed) file",
            )),
        }
    }

    /// Attaches a vertical component read from a second file (AT2 or a CSV `t,ax` whose
    /// single column is taken as vertical). The sampling interval and length must match.
    pub fn attach_vertical(&mut self, path: &Path) -> Result<(), RecordError> {
        self.attach_vertical_record(Record::read(path)?, path)
    }

    /// Attaches `vertical` (a single-component record, read from `path`) as the vertical
    /// component. The sampling interval and length must match.
    pub fn attach_vertical_record(
        &mut self,
        vertical: Record,
        path: &Path,
    ) -> Result<(), RecordError> {
        if vertical.vertical_mps2.is_some() {
            return Err(RecordError::new(
                path,
                None,
                "a vertical record must have a single component",
            ));
        }
        if (vertical.dt_s - self.dt_s).abs() > 1e-9 * self.dt_s {
            return Err(RecordError::new(
                path,
                None,
                format!(
                    "sampling interval {} s differs from the horizontal record's {} s",
                    vertical.dt_s, self.dt_s
                ),
            ));
        }
        if vertical.len() != self.len() {
            return Err(RecordError::new(
                path,
                None,
                format!(
                    "{} samples, but the horizontal record has {}",
                    vertical.len(),
                    self.len()
                ),
            ));
        }
        self.vertical_mps2 = Some(vertical.horizontal_mps2);
        Ok(())
    }
}

/// A problem reading a record file: which file, which line (1-based) if known, and what.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RecordError {
    pub path: PathBuf,
    pub line: Option<usize>,
    pub problem: String,
}

impl RecordError {
    pub fn new(path: &Path, line: Option<usize>, problem: impl Into<String>) -> Self {
        RecordError {
            path: path.to_path_buf(),
            line,
            problem: problem.into(),
        }
    }
}

impl fmt::Display for RecordError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.line {
            Some(line) => write!(
                f,
                "{}: line {}: {}",
                self.path.display(),
                line,
                self.problem
            ),
            None => write!(f, "{}: {}", self.path.display(), self.problem),
        }
    }
}

impl std::error::Error for RecordError {}

/// A record outside the bounds every tool relies on ([`Record::check_bounds`]).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RecordBoundsError {
    /// The sampling interval is outside [`DT_RANGE_S`].
    #[error("sampling interval {dt_s:?} s is outside [{}, {}] s (1 Hz to 10 kHz)", DT_RANGE_S.0, DT_RANGE_S.1)]
    SamplingInterval { dt_s: f64 },
    /// Empty, or more than [`MAX_RECORD_SAMPLES`] samples.
    #[error("{samples} samples: a record holds 1 to {MAX_RECORD_SAMPLES}")]
    Length { samples: usize },
    /// A value is not finite or beyond ±[`MAX_ABS_ACCEL_MPS2`].
    #[error("{component} sample {index} = {value:?} m/s² is beyond ±{MAX_ABS_ACCEL_MPS2} m/s² (100 g): corrupt data or wrong units")]
    Value {
        component: &'static str,
        index: usize,
        value: f64,
    },
}

fn extension_lowercase(path: &Path) -> Option<String> {
    path.extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
}

fn read_text(path: &Path) -> Result<String, RecordError> {
    let bytes = crate::bounded_read::read_bounded(path, crate::bounded_read::MAX_DATA_FILE_BYTES)
        .map_err(|e| RecordError::new(path, None, e.to_string()))?;
    String::from_utf8(bytes).map_err(|e| {
        RecordError::new(
            path,
            None,
            format!(
                "not a text file (invalid UTF-8 at byte {})",
                e.utf8_error().valid_up_to()
            ),
        )
    })
}

/// Checks that `record` can be written: positive finite `dt_s`, at least one sample, finite
/// values, and a vertical component (if any) of the same length.
fn check_writable(path: &Path, record: &Record) -> Result<(), RecordError> {
    let err = |problem: String| Err(RecordError::new(path, None, problem));
    if !(record.dt_s.is_finite() && record.dt_s > 0.0) {
        return err(format!(
            "cannot write a record with sampling interval {} s (must be > 0)",
            record.dt_s
        ));
    }
    if record.is_empty() {
        return err("cannot write an empty record".into());
    }
    if let Some(i) = record.horizontal_mps2.iter().position(|a| !a.is_finite()) {
        return err(format!("horizontal sample {i} is not finite"));
    }
    if let Some(vertical) = &record.vertical_mps2 {
        if vertical.len() != record.len() {
            return err(format!(
                "vertical component has {} samples, horizontal {}",
                vertical.len(),
                record.len()
            ));
        }
        if let Some(i) = vertical.iter().position(|a| !a.is_finite()) {
            return err(format!("vertical sample {i} is not finite"));
        }
    }
    Ok(())
}

fn write_text(path: &Path, text: &str) -> Result<(), RecordError> {
    std::fs::write(path, text).map_err(|e| RecordError::new(path, None, e.to_string()))
}
