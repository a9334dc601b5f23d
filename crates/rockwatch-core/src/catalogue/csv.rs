//! The CSV reader: one header row, then one row per entry (format in the module doc of
//! [`crate::catalogue`]). An uncertain parameter `P` is the column `P`, the pair `P_min`,
//! `P_max` or the pair `P_mean`, `P_sd`; each entry is located by its row's line (1-based)
//! and its 0-based index; sub-fields are named `width_m_min`.

use std::collections::HashMap;
use std::path::Path;

use super::distribution::Distribution;
use super::validate::{Integer, Problem, RawAzimuths, RawPbr};
use super::{Catalogue, CatalogueError, EntryContext, LoadWork};

impl Catalogue {
    /// Parses a CSV catalogue (format in the module doc); `source_name` names it in errors.
    /// Relative `mesh` paths are taken from the current directory.
    pub fn from_csv_str(text: &str, source_name: &str) -> Result<Catalogue, CatalogueError> {
        Catalogue::from_csv_str_in(text, source_name, None)
    }

    /// Parses a CSV catalogue whose relative `mesh` paths are relative to `base_dir`.
    pub fn from_csv_str_in(
        text: &str,
        source_name: &str,
        base_dir: Option<&Path>,
    ) -> Result<Catalogue, CatalogueError> {
        Catalogue::from_csv_counted(text, source_name, base_dir, &mut LoadWork::default())
    }

    /// [`Catalogue::from_csv_str_in`], adding its work to `work`.
    pub(super) fn from_csv_counted(
        text: &str,
        source_name: &str,
        base_dir: Option<&Path>,
        work: &mut LoadWork,
    ) -> Result<Catalogue, CatalogueError> {
        let mut reader = csv::ReaderBuilder::new()
            .comment(Some(b'#'))
            .trim(csv::Trim::All)
            .from_reader(text.as_bytes());
        let syntax = |line: Option<u64>, message: String| CatalogueError::Syntax {
            location: match line {
                Some(l) => format!("{source_name}:{l}"),
                None => source_name.to_owned(),
            },
            message,
        };
        let headers = reader
            .headers()
            .map_err(|e| syntax(None, format!("cannot read the CSV header: {e}")))?
            .clone();
        let header_line = headers.position().map_or(1, csv::Position::line);
        let columns = CsvColumns::from_header(&headers)
            .map_err(|message| syntax(Some(header_line), message))?;
        let mut entries = Vec::new();
        for (index, record) in reader.records().enumerate() {
            let record = match record {
                Ok(record) => record,
                Err(e) => {
                    // Reported, and the next rows are read on.
                    let line = e.position().map(csv::Position::line);
                    let context = EntryContext {
                        source_name,
                        line: line.map(|l| l as usize),
                        index,
                        id: None,
                        sub_separator: '_',
                    };
                    let problem = syntax(line, format!("invalid CSV row: {e}"));
                    entries.push((context, Err(vec![problem])));
                    continue;
                }
            };
            let line = record.position().map(|p| p.line() as usize);
            let id = columns
                .cell(&record, "id")
                .filter(|s| !s.is_empty())
                .map(str::to_owned);
            let context = EntryContext {
                source_name,
                line,
                index,
                id,
                sub_separator: '_',
            };
            let raw = columns.raw_pbr(&record).map_err(|found| {
                found
                    .into_iter()
                    .map(|(field, message)| context.error(Some(field), message))
                    .collect()
            });
            entries.push((context, raw));
        }
        Catalogue::build(source_name, entries, base_dir, work)
    }
}

/// The uncertain parameters, in LHS column order (also their CSV column stems).
const UNCERTAIN_FIELDS: [&str; 13] = [
    "width_m",
    "height_m",
    "half_diagonal_m",
    "alpha_deg",
    "b_plus_m",
    "b_minus_m",
    "h_m",
    "rho_m",
    "heading_deg",
    "contact_tolerance_m",
    "mu_s",
    "mu_k",
    "restitution",
];
/// Scalar CSV columns that must be present.
const REQUIRED_SCALAR_COLUMNS: [&str; 6] = ["id", "name", "lat", "lon", "station", "source"];
/// Scalar CSV columns that may be absent (`azimuth_deg` for planar blocks; `mesh`, `up`,
/// `azimuths`, `cap`, `model` for meshed rocks).
const OPTIONAL_SCALAR_COLUMNS: [&str; 8] = [
    "azimuth_deg",
    "ensemble",
    "seed",
    "mesh",
    "up",
    "azimuths",
    "cap",
    "model",
];
/// Suffixes of the columns of an uncertain parameter `P`: `P`, `P_min`, `P_max`, `P_mean`,
/// `P_sd`.
const DISTRIBUTION_SUFFIXES: [&str; 5] = ["", "_min", "_max", "_mean", "_sd"];

/// The column layout of a CSV catalogue: name → index.
struct CsvColumns {
    index: HashMap<String, usize>,
}

impl CsvColumns {
    fn from_header(headers: &csv::StringRecord) -> Result<CsvColumns, String> {
        let mut index = HashMap::new();
        for (i, name) in headers.iter().enumerate() {
            let known = REQUIRED_SCALAR_COLUMNS
                .iter()
                .chain(OPTIONAL_SCALAR_COLUMNS.iter())
                .any(|c| *c == name)
                || UNCERTAIN_FIELDS.iter().any(|stem| {
                    DISTRIBUTION_SUFFIXES
                        .iter()
                        .any(|suffix| name.strip_prefix(stem) == Some(suffix))
                });
            if !known {
                return Err(format!(
                    "unknown column {name:?} in the CSV header (known: {}, and for P in {}: P, \
                     P_min + P_max, or P_mean + P_sd)",
                    REQUIRED_SCALAR_COLUMNS
                        .iter()
                        .chain(OPTIONAL_SCALAR_COLUMNS.iter())
                        .copied()
                        .collect::<Vec<_>>()
                        .join(", "),
                    UNCERTAIN_FIELDS.join(", ")
                ));
            }
            if index.insert(name.to_owned(), i).is_some() {
                return Err(format!("column {name:?} appears twice in the CSV header"));
            }
        }
        for required in REQUIRED_SCALAR_COLUMNS {
            if !index.contains_key(required) {
                return Err(format!("the CSV header has no {required:?} column"));
            }
        }
        for stem in ["mu_s", "mu_k"] {
            if !DISTRIBUTION_SUFFIXES
                .iter()
                .any(|suffix| index.contains_key(&format!("{stem}{suffix}")))
            {
                return Err(format!(
                    "the CSV header has no column for {stem} ({stem}, {stem}_min + {stem}_max, \
                     or {stem}_mean + {stem}_sd)"
                ));
            }
        }
        Ok(CsvColumns { index })
    }

    /// The trimmed cell of `column` in `record`, `None` if there is no such column.
    fn cell<'r>(&self, record: &'r csv::StringRecord, column: &str) -> Option<&'r str> {
        self.index.get(column).and_then(|&i| record.get(i))
    }

    /// The non-empty cell of `column`, `None` if the column is absent or the cell empty.
    fn value<'r>(&self, record: &'r csv::StringRecord, column: &str) -> Option<&'r str> {
        self.cell(record, column).filter(|s| !s.is_empty())
    }

    fn string(&self, record: &csv::StringRecord, column: &str) -> String {
        self.cell(record, column).unwrap_or("").to_owned()
    }

    fn number(&self, record: &csv::StringRecord, column: &str) -> Result<f64, (String, String)> {
        match self.value(record, column) {
            None => Err((
                column.to_owned(),
                format!("{column} is missing (empty cell)"),
            )),
            Some(text) => parse_number(column, text),
        }
    }

    fn integer(
        &self,
        record: &csv::StringRecord,
        column: &str,
    ) -> Result<Option<Integer>, (String, String)> {
        self.value(record, column)
            .map(|text| {
                text.parse::<i128>().map(Integer).map_err(|_| {
                    (
                        column.to_owned(),
                        format!("{column} = {text:?} is not an integer"),
                    )
                })
            })
            .transpose()
    }

    /// The distribution of `stem` in this row: exactly one of the three column forms.
    fn distribution(
        &self,
        record: &csv::StringRecord,
        stem: &str,
    ) -> Result<Option<Distribution>, (String, String)> {
        let cells: Vec<(String, Option<&str>)> = DISTRIBUTION_SUFFIXES
            .iter()
            .map(|suffix| {
                let column = format!("{stem}{suffix}");
                let value = self.value(record, &column);
                (column, value)
            })
            .collect();
        let present: Vec<bool> = cells.iter().map(|(_, v)| v.is_some()).collect();
        let number = |k: usize| -> Result<f64, (String, String)> {
            parse_number(&cells[k].0, cells[k].1.unwrap_or(""))
        };
        match present[..] {
            [false, false, false, false, false] => Ok(None),
            [true, false, false, false, false] => Ok(Some(Distribution::Fixed(number(0)?))),
            [false, true, true, false, false] => Ok(Some(Distribution::Uniform {
                min: number(1)?,
                max: number(2)?,
            })),
            [false, false, false, true, true] => Ok(Some(Distribution::Normal {
                mean: number(3)?,
                sd: number(4)?,
            })),
            _ => {
                let given: Vec<&str> = cells
                    .iter()
                    .filter(|(_, v)| v.is_some())
                    .map(|(c, _)| c.as_str())
                    .collect();
                Err((
                    stem.to_owned(),
                    format!(
                        "{stem}: fill exactly one of {stem}, {stem}_min + {stem}_max, or \
                         {stem}_mean + {stem}_sd (got {})",
                        given.join(", ")
                    ),
                ))
            }
        }
    }

    /// The row as written, or every problem of its cells.
    fn raw_pbr(&self, record: &csv::StringRecord) -> Result<RawPbr, Vec<Problem>> {
        let mut problems: Vec<Problem> = Vec::new();
        let mut take = |result: Result<Option<Distribution>, Problem>| {
            result
                .map_err(|problem| problems.push(problem))
                .ok()
                .flatten()
        };
        let heading_deg = take(self.distribution(record, "heading_deg"));
        let contact_tolerance_m = take(self.distribution(record, "contact_tolerance_m"));
        let width_m = take(self.distribution(record, "width_m"));
        let height_m = take(self.distribution(record, "height_m"));
        let half_diagonal_m = take(self.distribution(record, "half_diagonal_m"));
        let alpha_deg = take(self.distribution(record, "alpha_deg"));
        let b_plus_m = take(self.distribution(record, "b_plus_m"));
        let b_minus_m = take(self.distribution(record, "b_minus_m"));
        let h_m = take(self.distribution(record, "h_m"));
        let rho_m = take(self.distribution(record, "rho_m"));
        let mu_s = take(self.required(record, "mu_s"));
        let mu_k = take(self.required(record, "mu_k"));
        let restitution = take(self.distribution(record, "restitution"));
        let mut take = |result: Result<Option<f64>, Problem>| {
            result
                .map_err(|problem| problems.push(problem))
                .ok()
                .flatten()
        };
        let lat = take(self.number(record, "lat").map(Some));
        let lon = take(self.number(record, "lon").map(Some));
        let azimuth_deg = take(
            self.value(record, "azimuth_deg")
                .map(|text| parse_number("azimuth_deg", text))
                .transpose(),
        );
        let mut take = |result: Result<Option<Integer>, Problem>| {
            result
                .map_err(|problem| problems.push(problem))
                .ok()
                .flatten()
        };
        let ensemble = take(self.integer(record, "ensemble"));
        let seed = take(self.integer(record, "seed"));
        let cap = self
            .value(record, "cap")
            .map(|text| parse_bool("cap", text))
            .transpose()
            .map_err(|problem| problems.push(problem))
            .ok()
            .flatten();
        if !problems.is_empty() {
            return Err(problems);
        }
        Ok(RawPbr {
            id: Some(self.string(record, "id")),
            name: Some(self.string(record, "name")),
            lat,
            lon,
            station: Some(self.string(record, "station")),
            azimuth_deg,
            mesh: self.value(record, "mesh").map(str::to_owned),
            up: self.value(record, "up").map(str::to_owned),
            azimuths: self
                .value(record, "azimuths")
                .map(|text| RawAzimuths::Text(text.to_owned())),
            cap,
            model: self.value(record, "model").map(str::to_owned),
            heading_deg,
            contact_tolerance_m,
            width_m,
            height_m,
            half_diagonal_m,
            alpha_deg,
            b_plus_m,
            b_minus_m,
            h_m,
            rho_m,
            mu_s,
            mu_k,
            restitution,
            source: Some(self.string(record, "source")),
            ensemble,
            seed,
        })
    }

    /// The distribution of a required parameter `stem` in this row.
    fn required(
        &self,
        record: &csv::StringRecord,
        stem: &str,
    ) -> Result<Option<Distribution>, Problem> {
        match self.distribution(record, stem)? {
            Some(d) => Ok(Some(d)),
            None => Err((
                stem.to_owned(),
                format!(
                    "{stem} is missing (fill {stem}, {stem}_min + {stem}_max, or \
                     {stem}_mean + {stem}_sd)"
                ),
            )),
        }
    }
}

fn parse_bool(column: &str, text: &str) -> Result<bool, (String, String)> {
    match text.trim() {
        "true" => Ok(true),
        "false" => Ok(false),
        other => Err((
            column.to_owned(),
            format!("{column} = {other:?} must be true or false"),
        )),
    }
}

fn parse_number(column: &str, text: &str) -> Result<f64, (String, String)> {
    text.parse::<f64>().map_err(|_| {
        (
            column.to_owned(),
            format!("{column} = {text:?} is not a number"),
        )
    })
}
