//! PEER NGA `.AT2` records: three free-text header lines, an `NPTS`/`DT` line, then the
//! accelerations in units of g (converted to m/s² with [`STANDARD_GRAVITY_MPS2`]).

use std::path::Path;

use super::{check_writable, read_text, write_text, Record, RecordError, STANDARD_GRAVITY_MPS2};

/// A PEER NGA AT2 file: three free-text header lines, an `NPTS`/`DT` line, then values in g.
#[derive(Debug, Clone, PartialEq)]
pub struct At2 {
    /// The three free-text header lines (event, station, component, units).
    pub header: [String; 3],
    /// Sampling interval (s).
    pub dt_s: f64,
    /// Accelerations in units of g, exactly as in the file.
    pub values_g: Vec<f64>,
}

impl At2 {
    /// Converts to a [`Record`] in m/s² (g = [`STANDARD_GRAVITY_MPS2`]).
    #[must_use]
    pub fn into_record(self, path: &Path) -> Record {
        Record {
            source: path.display().to_string(),
            dt_s: self.dt_s,
            horizontal_mps2: self
                .values_g
                .into_iter()
                .map(|a| a * STANDARD_GRAVITY_MPS2)
                .collect(),
            vertical_mps2: None,
        }
    }
}

/// The component a record's header names.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Component {
    /// Up or down: `UP`, `DWN`, `V`, `VER`, `Z`, `UD`, `RRS-UP`, a SEED channel `HNZ`, ….
    Vertical,
    /// An azimuth (`228`), a direction (`N`, `EW`, `RRS-N`) or a SEED channel `HN1`, `HNE`, ….
    Horizontal,
    /// Not said, or not recognised.
    Unknown,
}

impl At2 {
    /// The component the header names: PEER's second header line ends with it
    /// (`Northridge-01, 1/17/1994, Rinaldi Receiving Sta, UP`).
    #[must_use]
    pub fn component(&self) -> Component {
        let token = self.header[1]
            .rsplit(',')
            .next()
            .unwrap_or("")
            .trim()
            .to_ascii_uppercase();
        // A station prefix (`RRS-UP`, `TCU029-N`) is not part of the component.
        let token = token.rsplit(['-', '_', ' ']).next().unwrap_or("");
        const VERTICAL: [&str; 10] = [
            "UP", "DWN", "DOWN", "DN", "V", "VER", "VERT", "VRT", "UD", "Z",
        ];
        const HORIZONTAL: [&str; 8] = ["N", "S", "E", "W", "NS", "EW", "SN", "WE"];
        // A SEED channel code: band, instrument (N accelerometer, H/L seismometer, G gravimeter),
        // orientation.
        let seed_channel = token.len() == 3
            && token.is_ascii()
            && matches!(token.as_bytes()[1], b'N' | b'H' | b'L' | b'G');
        if VERTICAL.contains(&token) || (seed_channel && token.ends_with('Z')) {
            Component::Vertical
        } else if token.parse::<f64>().is_ok()
            || HORIZONTAL.contains(&token)
            || (seed_channel && token.ends_with(['N', 'E', '1', '2']))
        {
            Component::Horizontal
        } else {
            Component::Unknown
        }
    }

    /// The event and station the header names (its second line without the component):
    /// records of one station's instrument share it.
    #[must_use]
    pub fn station_key(&self) -> &str {
        self.header[1]
            .rsplit_once(',')
            .map_or(self.header[1].as_str(), |(key, _)| key)
            .trim()
    }
}

/// Reads a PEER NGA `.AT2` file. Accepts both header forms found in the wild
/// (`NPTS=  1559, DT= .02000 SEC, <filter text>` and `3000   0.0100   NPTS, DT`),
/// free-format or fixed-width values (including fields that run together, such as
/// `-.1234567E-02-.2345678E-02`) and Fortran `D` exponents.
pub fn read_at2(path: &Path) -> Result<At2, RecordError> {
    let text = read_text(path)?;
    parse_at2_text(&text, path)
}

/// Parses the text of an AT2 file (see [`read_at2`]); `source` names it in errors.
pub fn parse_at2_text(text: &str, source: &Path) -> Result<At2, RecordError> {
    parse_at2(text).map_err(|(line, problem)| RecordError::new(source, line, problem))
}

type ParseError = (Option<usize>, String);

fn parse_at2(text: &str) -> Result<At2, ParseError> {
    let mut lines = text.lines().enumerate();
    let mut header: [String; 3] = Default::default();
    for slot in header.iter_mut() {
        let (_, line) = lines
            .next()
            .ok_or_else(|| (None, "truncated header: fewer than 4 lines".to_string()))?;
        *slot = line.trim_end().to_string();
    }
    let (index, npts_line) = lines
        .next()
        .ok_or_else(|| (None, "truncated header: no NPTS/DT line".to_string()))?;
    let (npts, dt_s) = parse_npts_dt(npts_line).map_err(|p| (Some(index + 1), p))?;

    // NPTS comes from the file: never let it size an allocation beyond what the text can hold.
    let mut values_g = Vec::with_capacity(npts.min(text.len() / 2));
    let mut extra_nonzero = false;
    for (index, line) in lines {
        for token in split_fortran_numbers(line) {
            let value = parse_fortran_float(token)
                .ok_or_else(|| (Some(index + 1), format!("not a number: {token:?}")))?;
            if !value.is_finite() {
                return Err((Some(index + 1), format!("non-finite value {token:?}")));
            }
            if values_g.len() < npts {
                values_g.push(value);
            } else if value != 0.0 {
                extra_nonzero = true;
            }
        }
    }
    if values_g.len() < npts {
        return Err((
            None,
            format!(
                "header says NPTS={npts} but the file has only {} values",
                values_g.len()
            ),
        ));
    }
    if extra_nonzero {
        return Err((
            None,
            format!("header says NPTS={npts} but the file has more (non-zero) values"),
        ));
    }
    Ok(At2 {
        header,
        dt_s,
        values_g,
    })
}

/// Parses the AT2 `NPTS`/`DT` line in either of its two forms.
fn parse_npts_dt(line: &str) -> Result<(usize, f64), String> {
    let upper = line.to_ascii_uppercase();
    let (npts_text, dt_text) = if let (Some(n), Some(d)) = (upper.find("NPTS="), upper.find("DT="))
    {
        (first_token(&line[n + 5..]), first_token(&line[d + 3..]))
    } else if upper.contains("NPTS") && upper.contains("DT") {
        // Old form: "3000   0.0100   NPTS, DT"
        let mut numbers = line
            .split(|c: char| c.is_whitespace() || c == ',')
            .filter(|t| !t.is_empty());
        (numbers.next().unwrap_or(""), numbers.next().unwrap_or(""))
    } else {
        return Err(format!("expected an NPTS/DT line, found {:?}", line.trim()));
    };
    let npts: usize = npts_text
        .parse()
        .map_err(|_| format!("NPTS is not a whole number: {npts_text:?}"))?;
    let dt_s =
        parse_fortran_float(dt_text).ok_or_else(|| format!("DT is not a number: {dt_text:?}"))?;
    if npts == 0 {
        return Err("NPTS is 0".into());
    }
    if !(dt_s.is_finite() && dt_s > 0.0) {
        return Err(format!(
            "DT must be a positive number of seconds, found {dt_text:?}"
        ));
    }
    Ok((npts, dt_s))
}

fn first_token(s: &str) -> &str {
    s.split(|c: char| c.is_whitespace() || c == ',')
        .find(|t| !t.is_empty())
        .unwrap_or("")
}

/// Splits a line of Fortran-formatted numbers on white space, and also where a sign follows
/// a digit or a decimal point (fixed-width fields that run together), but not inside an
/// exponent (`E-02`).
fn split_fortran_numbers(line: &str) -> impl Iterator<Item = &str> {
    line.split_whitespace().flat_map(|word| {
        let bytes = word.as_bytes();
        let mut pieces = Vec::new();
        let mut start = 0;
        for i in 1..bytes.len() {
            let sign = bytes[i] == b'-' || bytes[i] == b'+';
            let prev = bytes[i - 1];
            if sign && (prev.is_ascii_digit() || prev == b'.') {
                pieces.push(&word[start..i]);
                start = i;
            }
        }
        pieces.push(&word[start..]);
        pieces
    })
}

fn parse_fortran_float(token: &str) -> Option<f64> {
    let token = token.trim();
    if token.is_empty() {
        return None;
    }
    if token.contains(['d', 'D']) {
        token.replace(['d', 'D'], "E").parse().ok()
    } else {
        token.parse().ok()
    }
}

/// Writes the horizontal component of `record` as a PEER NGA `.AT2` file readable by
/// [`read_at2`]: the three free-text `header_lines` (by PEER convention: source, event and
/// station, then units — e.g. `"ACCELERATION TIME SERIES IN UNITS OF G"`), the line
/// `NPTS= n, DT= dt SEC`, then the accelerations in g (m/s² ÷ [`STANDARD_GRAVITY_MPS2`]),
/// five per line with 10 significant digits (relative rounding ≤ 5e−10).
///
/// AT2 holds one component: a record with a vertical component is refused (write the
/// components as two records). Header lines must not contain line breaks. Errors name the
/// file.
pub fn write_at2(path: &Path, record: &Record, header_lines: [&str; 3]) -> Result<(), RecordError> {
    use std::fmt::Write as _;
    check_writable(path, record)?;
    if record.vertical_mps2.is_some() {
        return Err(RecordError::new(
            path,
            None,
            "an AT2 file holds one component, but this record also has a vertical one",
        ));
    }
    if let Some(line) = header_lines.iter().find(|l| l.contains(['\n', '\r'])) {
        return Err(RecordError::new(
            path,
            None,
            format!("AT2 header line contains a line break: {line:?}"),
        ));
    }
    let mut text = String::with_capacity(80 * 4 + record.len() * 17);
    for line in header_lines {
        text.push_str(line);
        text.push('\n');
    }
    // `{}` prints the shortest decimal that reads back as the same f64.
    let _ = writeln!(text, "NPTS= {}, DT= {} SEC", record.len(), record.dt_s);
    for chunk in record.horizontal_mps2.chunks(5) {
        for &a in chunk {
            let _ = write!(text, " {:>16.9E}", a / STANDARD_GRAVITY_MPS2);
        }
        text.push('\n');
    }
    write_text(path, &text)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn with_line(line: &str) -> At2 {
        At2 {
            header: ["PEER".into(), line.into(), "G".into()],
            dt_s: 0.01,
            values_g: vec![0.0],
        }
    }

    #[test]
    fn the_component_is_read_from_peer_s_second_header_line() {
        for (line, expected) in [
            (
                "Northridge-01, 1/17/1994, Rinaldi Receiving Sta, UP",
                Component::Vertical,
            ),
            (
                "Northridge-01, 1/17/1994, Rinaldi Receiving Sta, 228",
                Component::Horizontal,
            ),
            (
                "Chi-Chi Taiwan, 9/20/1999, TCU029, N",
                Component::Horizontal,
            ),
            ("Chi-Chi Taiwan, 9/20/1999, TCU029, V", Component::Vertical),
            ("Landers, 6/28/1992, Lucerne, LCN-DWN", Component::Vertical),
            ("Somewhere, 1/1/2000, XYZ, HNZ", Component::Vertical),
            ("Somewhere, 1/1/2000, XYZ, HN1", Component::Horizontal),
            (
                "Imperial Valley-06, 10/15/1979, El Centro Array #6, 230",
                Component::Horizontal,
            ),
            ("free text without a component", Component::Unknown),
            ("Somewhere, 1/1/2000, Station LAZ", Component::Unknown),
        ] {
            assert_eq!(with_line(line).component(), expected, "{line}");
        }
        assert_eq!(
            with_line("Northridge-01, 1/17/1994, Rinaldi Receiving Sta, UP").station_key(),
            "Northridge-01, 1/17/1994, Rinaldi Receiving Sta"
        );
    }

    #[test]
    fn npts_dt_new_form_with_filter_text() {
        let line =
            "NPTS=   1991, DT=   .0100 SEC,   0 POLE @    30.00000 HZ,  -5 POLE @      .05000";
        assert_eq!(parse_npts_dt(line), Ok((1991, 0.01)));
    }

    #[test]
    fn npts_dt_old_form() {
        assert_eq!(parse_npts_dt("3000   0.0100   NPTS, DT"), Ok((3000, 0.01)));
    }

    #[test]
    fn npts_dt_rejects_garbage() {
        assert!(parse_npts_dt("hello world").is_err());
        assert!(parse_npts_dt("NPTS= abc, DT= .01").is_err());
        assert!(parse_npts_dt("NPTS= 10, DT= -0.01").is_err());
    }

    #[test]
    fn run_together_fixed_width_fields_split() {
        let got: Vec<&str> =
            split_fortran_numbers("  -.1234567E-02-.2345678E-02 1.5 2.0-3.0").collect();
        assert_eq!(
            got,
            vec!["-.1234567E-02", "-.2345678E-02", "1.5", "2.0", "-3.0"]
        );
    }

    #[test]
    fn fortran_d_exponent() {
        assert_eq!(parse_fortran_float("0.25D-01"), Some(0.025));
    }

    #[test]
    fn short_file_is_an_error_naming_counts() {
        let text = "a\nb\nc\nNPTS= 4, DT= 0.01 SEC\n 0.1 0.2\n 0.3\n";
        let (_, msg) = parse_at2(text).unwrap_err();
        assert!(msg.contains("NPTS=4") && msg.contains("only 3"), "{msg}");
    }

    #[test]
    fn non_numeric_token_names_line() {
        let text = "a\nb\nc\nNPTS= 3, DT= 0.01 SEC\n 0.1 x 0.3\n";
        assert_eq!(parse_at2(text).unwrap_err().0, Some(5));
    }

    #[test]
    fn absurd_npts_is_an_error_not_an_allocation() {
        let text = "a\nb\nc\nNPTS= 1000000000000, DT= 0.01 SEC\n 0.1 0.2\n";
        assert!(parse_at2(text).unwrap_err().1.contains("only 2"));
    }

    #[test]
    fn nan_value_rejected() {
        let text = "a\nb\nc\nNPTS= 2, DT= 0.01 SEC\n 0.1 NaN\n";
        assert!(parse_at2(text).unwrap_err().1.contains("non-finite"));
    }
}
