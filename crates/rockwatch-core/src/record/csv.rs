//! CSV records: a header row `t,ax` or `t,ax,ay`, then one row per sample (s, m/s², m/s²).

use std::path::Path;

use super::{check_writable, read_text, write_text, Record, RecordError};

/// Reads a CSV record with a header row `t,ax` or `t,ax,ay` (s, m/s², m/s²). Time must be
/// uniform (to 1e-6 of a step). Blank lines and lines starting with `#` are ignored.
pub fn read_csv(path: &Path) -> Result<Record, RecordError> {
    let text = read_text(path)?;
    let err = |line: Option<usize>, problem: String| RecordError::new(path, line, problem);
    let mut rows = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty() && !l.trim_start().starts_with('#'));
    let (header_index, header) = rows
        .next()
        .ok_or_else(|| err(None, "empty file: expected a header row t,ax[,ay]".into()))?;
    let columns: Vec<String> = header
        .split(',')
        .map(|c| c.trim().to_ascii_lowercase())
        .collect();
    let has_vertical = match columns.iter().map(String::as_str).collect::<Vec<_>>()[..] {
        ["t", "ax"] => false,
        ["t", "ax", "ay"] => true,
        _ => {
            return Err(err(
                Some(header_index + 1),
                format!("header must be t,ax or t,ax,ay, found {:?}", header.trim()),
            ))
        }
    };
    let (mut t, mut ax, mut ay) = (Vec::new(), Vec::new(), Vec::new());
    for (index, line) in rows {
        let fields: Vec<&str> = line.split(',').map(str::trim).collect();
        if fields.len() != columns.len() {
            return Err(err(
                Some(index + 1),
                format!("{} fields, expected {}", fields.len(), columns.len()),
            ));
        }
        let mut values = [0.0; 3];
        for (slot, field) in values.iter_mut().zip(&fields) {
            *slot = field
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| err(Some(index + 1), format!("not a finite number: {field:?}")))?;
        }
        t.push((values[0], index + 1));
        ax.push(values[1]);
        if has_vertical {
            ay.push(values[2]);
        }
    }
    if t.len() < 2 {
        return Err(err(None, "need at least two samples".into()));
    }
    let (t0, _) = t[0];
    let (t_last, _) = t[t.len() - 1];
    let dt_s = (t_last - t0) / (t.len() - 1) as f64;
    if dt_s.is_nan() || dt_s <= 0.0 {
        return Err(err(None, "time must increase".into()));
    }
    for (i, &(ti, line)) in t.iter().enumerate() {
        let expected = t0 + i as f64 * dt_s;
        if (ti - expected).abs() > 1e-6 * dt_s {
            return Err(err(
                Some(line),
                format!("non-uniform time: t = {ti} s, expected {expected} s (dt = {dt_s} s)"),
            ));
        }
    }
    Ok(Record {
        source: path.display().to_string(),
        dt_s,
        horizontal_mps2: ax,
        vertical_mps2: has_vertical.then_some(ay),
    })
}

/// Writes `record` as CSV readable by [`read_csv`]: header `t,ax` (or `t,ax,ay` with the
/// vertical component as `ay`), then one row per sample with `t = i·dt_s` (s) and the
/// accelerations (m/s²) in shortest round-trip notation, so values read back exactly.
/// Errors name the file.
pub fn write_csv(path: &Path, record: &Record) -> Result<(), RecordError> {
    use std::fmt::Write as _;
    check_writable(path, record)?;
    let mut text = String::with_capacity(16 + record.len() * 48);
    match &record.vertical_mps2 {
        None => {
            text.push_str("t,ax\n");
            for (i, a) in record.horizontal_mps2.iter().enumerate() {
                let _ = writeln!(text, "{},{:e}", i as f64 * record.dt_s, a);
            }
        }
        Some(vertical) => {
            text.push_str("t,ax,ay\n");
            for (i, (a, v)) in record.horizontal_mps2.iter().zip(vertical).enumerate() {
                let _ = writeln!(text, "{},{:e},{:e}", i as f64 * record.dt_s, a, v);
            }
        }
    }
    write_text(path, &text)
}
