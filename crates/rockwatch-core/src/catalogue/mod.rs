//! The PBR catalogue: which precariously balanced rocks (and other freestanding objects) the
//! monitoring engine watches, where they are, which seismic station drives each of them, how
//! they are oriented, and their block parameters, possibly uncertain.
//!
//! This module parses and validates catalogue files (TOML or CSV) into [`Catalogue`] and turns
//! each entry ([`Pbr`]) into the [`BlockParams`] the dynamics integrate: [`Pbr::nominal`], and
//! [`Pbr::members`] for a Latin-hypercube ensemble over the uncertain parameters. Apart from
//! [`Catalogue::load`] (which reads one file) it is pure: no network, no clock, no global state.
//!
//! # TOML format
//!
//! The user's reference is `docs/catalogue.md` (every field, with its unit and domain, checked
//! against this parser by `tests/catalogue.rs`). A catalogue is an array of `[[pbr]]` tables, and nothing else at the top level:
//!
//! ```toml
//! [[pbr]]
//! id = "rrs-pillar"            # unique, non-empty, no whitespace
//! name = "Slender pillar near Rinaldi"
//! lat = 34.282                 # degrees north, [-90, 90]
//! lon = -118.478               # degrees east, [-180, 180]
//! station = "CI.RRS.00"        # SEED NET.STA.LOC driving this block
//! azimuth_deg = 45.0           # direction of the block's +x axis, clockwise from north, [0, 360)
//! width_m = 0.30               # base width B (m)
//! height_m = { min = 1.4, max = 1.6 }   # uniform on [min, max]
//! mu_s = 0.7                   # static friction coefficient
//! mu_k = { mean = 0.55, sd = 0.03 }     # normal, truncated to the valid domain
//! restitution = 0.9            # optional: rocking impact ratio e in [0, 1] (default Housner's η)
//! source = "illustrative"      # free text: where the numbers come from (non-empty)
//! ensemble = 50                # optional: K Latin-hypercube members, 1 ≤ K ≤ 10000 (default 1)
//! seed = 7                     # optional: LHS seed, default default_seed(id)
//! ```
//!
//! Field by field:
//! - `id`: non-empty, no whitespace or control characters, unique in the catalogue.
//! - `name`, `source`: free text, not blank. `source` says where the numbers come from.
//! - `lat`, `lon`: WGS84 degrees, `lat` in [−90, 90], `lon` in [−180, 180].
//! - `station`: a SEED identifier `NET.STA.LOC`: network 1–2, station 1–5, location 0–2
//!   characters, each upper-case ASCII letters or digits (the SEED manual's character set; lower
//!   case is rejected rather than silently never matching the upper-case codes of a live
//!   stream). An empty location is written with the trailing dot: `"CI.RRS."`.
//! - `azimuth_deg`: the azimuth of the block's +x axis (the axis of rocking and sliding),
//!   clockwise from north, in [0, 360). See [`Pbr::project_horizontal`] and [`crate::azimuth`].
//! - the geometry, exactly one of three forms ([`Geometry`]; docs/general-body.md):
//!   `width_m` + `height_m` (m, > 0: a rectangle B × H); `half_diagonal_m` (m, > 0) +
//!   `alpha_deg` (in (0, 90): a rectangle by R and α); or `b_plus_m` + `b_minus_m` + `h_m` +
//!   `rho_m` (m, > 0: a general body, horizontal distances from the centre of mass to the +x
//!   and −x pivots, height of the centre of mass, radius of gyration). A missing field of a
//!   form, or fields of two forms, are rejected naming the field.
//! - or a rock from its closed mesh (docs/meshes.md): `mesh = "rocks/r1.obj"` (.obj, .ply,
//!   .stl, metres; a relative path is relative to the catalogue file's directory when loaded
//!   by [`Catalogue::load`]), `azimuths` instead of `azimuth_deg` — a list `[0, 90, 200]` or
//!   `{ from = 0, to = 360, step = 15 }` (TO excluded; in CSV the text `0:360:15` or `"0,90"`),
//!   true azimuths clockwise from north, distinct, at most [`MAX_DIRECTIONS`]; default every
//!   15° (a rock may fall any way) — optional `up` (the mesh axis pointing up, default `"z"`),
//!   `cap` (`true` closes an open scan by its lowest boundary loop, [`crate::mesh::cap`]),
//!   `heading_deg` (true azimuth of the mesh's north axis, in [−360, 360], default 0) and
//!   `contact_tolerance_m` (in [0, 1] m, default 0: the resting hull facet alone; see
//!   [`crate::mesh::contact::DEFAULT_CONTACT_TOLERANCE_M`]). `heading_deg` and
//!   `contact_tolerance_m` are [`Distribution`]s like the other
//!   parameters (the mesh's uncertain fields, in that LHS column order). The rock has one
//!   planar body per direction ([`Pbr::directions`]; direction az is the mesh's azimuth
//!   az − heading); [`Pbr::nominal`] and [`Pbr::members`] are those of its first direction.
//!   `model` (`"2d"`, the default, or `"3d"`: one rigid body, docs/rocking-3d.md) chooses how
//!   a mesh rock is integrated.
//! - `mu_s` (> 0), `mu_k` (in [0, 4/3): μk ≥ 4/3 makes slide-rocking ill-posed, the Painlevé
//!   paradox; a general body's own bound 2√(c(1 + c)), c = ρ²/R², is checked on the nominal
//!   block), optional `restitution` (in [0, 1]). Every geometry field and these are each
//!   a [`Distribution`]: a number, a range `{ min = .., max = .. }` (uniform, `min < max`, both
//!   in the domain) or a normal `{ mean = .., sd = .. }` (`mean` in the domain, `sd > 0`).
//!   The nominal values (midpoint of a range, mean of a normal) must satisfy μk ≤ μs (an
//!   excess of a few ulps, e.g. from a midpoint, counts as equality: nominal μk = μs).
//! - `ensemble`: K, from 1 to 10000; K > 1 requires at least one uncertain parameter.
//! - `seed`: an integer ≥ 0 (TOML integers are signed 64-bit, so at most 2⁶³ − 1 in TOML; the
//!   CSV form takes the whole `u64` range). Default: [`default_seed`] of the id.
//!
//! Unknown fields are rejected (serde `deny_unknown_fields`), naming the field.
//!
//! # CSV format
//!
//! One header row, then one row per PBR; `#` starts a comment line; cells are trimmed; an empty
//! cell means "absent". The columns are the TOML field names. An uncertain parameter `P` (one of
//! the geometry fields, `mu_s`, `mu_k`, `restitution`) can use, row by row, exactly one of:
//! the column `P` (a number), the pair `P_min`,`P_max` (uniform) or the pair `P_mean`,`P_sd`
//! (normal); the other cells of `P` in that row stay empty. Columns may come in any order;
//! unknown or repeated column names are rejected at the header, as is a header without `id`,
//! `name`, `lat`, `lon`, `station` or `source`. `azimuth_deg` (required in a planar block's
//! row), `restitution`, `ensemble`, `seed` and the mesh columns `mesh`, `up`, `azimuths`,
//! `cap`, `model`, `heading_deg`, `contact_tolerance_m` are optional. A CSV and a TOML file describing the same PBRs load equal.
//!
//! # Errors
//!
//! Nothing here panics on bad input. Every problem of a file is found in one reading: each
//! entry is checked whole and every entry is checked; one problem is the error itself, several
//! are [`CatalogueError::Problems`] (the first [`MAX_REPORTED_PROBLEMS`] listed, the rest
//! counted). A problem with one entry is reported as
//! `SOURCE:LINE: pbr[INDEX] (id "ID"): PROBLEM`, e.g.
//! `catalogue.toml:31: pbr[3] (id "pinnacle-2"): mu_k = 0.9 exceeds mu_s = 0.6`, where INDEX is
//! the 0-based position of the entry in the file and LINE the line where the entry starts
//! (TOML: its `[[pbr]]` header; CSV: its row). Sub-fields are named `width_m.min` in TOML and
//! `width_m_min` in CSV, matching what the user wrote.
//!
//! # Uncertainty and ensembles
//!
//! [`Pbr::nominal`] is the block built from the nominal values. [`Pbr::members`] returns K
//! blocks: for K = 1 exactly the nominal block; for K > 1 the `d` uncertain parameters, in the
//! order of the geometry form's fields (as listed above), then `mu_s, mu_k, restitution`
//! (fixed ones skipped), are the columns of
//! [`latin_hypercube_seeded`]`(K, d, seed)`, and member `i` maps sample `i` through each
//! parameter's quantile function:
//! - range: `min + u·(max − min)`;
//! - normal: the normal **truncated to the parameter's valid domain** [a, b] ((0, ∞) for sizes
//!   and μs, (0, 90) for α in degrees, [0, 4/3) for μk, [0, 1] for e), sampled by inverse CDF:
//!   `mean + sd·Φ⁻¹(Φ(α) + u·(Φ(β) − Φ(α)))` with α, β the standardised bounds. Every margin is
//!   therefore exactly stratified in the CDF of the distribution actually sampled (one member per
//!   stratum), no member is clipped onto a bound, and when the bounds are many sd away (the usual
//!   case) this is the plain normal quantile. The nominal value stays the given `mean`.
//!
//! A member whose drawn μk exceeds its drawn μs gets **μk = μs** (kinetic friction cannot exceed
//! static friction). This keeps every other margin exactly stratified and the member count at
//! K; only the μk values of those members move (redrawing would break the stratification of
//! both friction margins). Keep the two friction distributions apart if that matters.

//!
//! # Layout
//!
//! One concern per file; everything public is re-exported here, so the paths
//! `rockwatch_core::catalogue::…` are the API:
//! - `distribution.rs`: [`Distribution`] (fixed, uniform, normal) and the domain of each
//!   parameter, with the truncated quantile map of the ensembles;
//! - `geometry.rs`: [`Geometry`], its three planar forms and the mesh form, and [`MeshRock`];
//! - `pbr.rs`: [`Pbr`], one validated entry, and its accessors;
//! - `ensemble.rs`: the nominal block's siblings, [`Pbr::members`] and [`Pbr::directions`]
//!   (Latin hypercube, [`default_seed`]);
//! - `validate.rs`: one entry as written (shared by both readers) → [`Pbr`], every rule of the
//!   format above;
//! - `toml.rs`, `csv.rs`: the two readers, each locating its entries (line) for the errors.
//!
//! This file holds [`Catalogue`] (the validated entries in file order, ids unique),
//! [`CatalogueError`] and the entry context that names an entry in every error.

mod csv;
mod distribution;
mod ensemble;
mod geometry;
mod pbr;
mod toml;
mod validate;

use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};

pub use self::distribution::Distribution;
pub use self::ensemble::{default_seed, DirectionBlocks, EnsembleError, RigidMember};
pub use self::geometry::{Geometry, MeshRock, RockModel};
pub use self::pbr::Pbr;
pub use self::toml::toml_error_line;
pub use self::validate::{MAX_DIRECTIONS, MAX_ENSEMBLE};
pub use crate::station_id::StationId;

use self::validate::{validate, RawPbr};
use crate::partition::fnv1a64;

/// Why a catalogue could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum CatalogueError {
    /// The file could not be read.
    #[error("{}: cannot read the catalogue: {error}", path.display())]
    Io {
        path: PathBuf,
        error: std::io::Error,
    },
    /// The file name does not end in `.toml` or `.csv`.
    #[error("{}: unknown catalogue format: the file name must end in .toml or .csv", path.display())]
    UnknownFormat { path: PathBuf },
    /// The file is not valid TOML/CSV or its overall layout is wrong (top-level keys, header).
    #[error("{location}: {message}")]
    Syntax { location: String, message: String },
    /// The file holds no entry.
    #[error("{source_name}: the catalogue has no PBR entries")]
    Empty { source_name: String },
    /// Several problems, in file order: every one found in one reading, the first
    /// [`MAX_REPORTED_PROBLEMS`] of them listed (each an [`CatalogueError::Entry`] or, for a
    /// malformed CSV row, a [`CatalogueError::Syntax`]). One problem alone is reported as
    /// itself.
    #[error("{}", render_problems(source_name, shown, *total))]
    Problems {
        source_name: String,
        /// The first problems, at most [`MAX_REPORTED_PROBLEMS`].
        shown: Vec<CatalogueError>,
        /// Every problem found, shown or not.
        total: usize,
    },
    /// One entry is invalid.
    #[error(
        "{source_name}{}: pbr[{index}]{}: {message}",
        line.map(|l| format!(":{l}")).unwrap_or_default(),
        id.as_ref().map(|id| format!(" (id {id:?})")).unwrap_or_default()
    )]
    Entry {
        source_name: String,
        /// 1-based line where the entry starts, when known.
        line: Option<usize>,
        /// 0-based position of the entry in the file.
        index: usize,
        /// The entry's id, when it has one.
        id: Option<String>,
        /// The offending field (`mu_k`, `width_m.min`, …), when one field is to blame.
        field: Option<String>,
        /// What is wrong.
        message: String,
    },
}

/// Most problems of one catalogue listed in its error ([`CatalogueError::Problems`]); the
/// others are counted.
pub const MAX_REPORTED_PROBLEMS: usize = 50;

/// The text of [`CatalogueError::Problems`]: a first line with the count, then one indented
/// line per problem shown, and how many more there are.
fn render_problems(source_name: &str, shown: &[CatalogueError], total: usize) -> String {
    let mut text = format!("{source_name}: {total} problems in the catalogue:");
    for problem in shown {
        text.push_str("\n  ");
        text.push_str(&problem.to_string());
    }
    if total > shown.len() {
        text.push_str(&format!(
            "\n  … and {} more (the first {} are listed)",
            total - shown.len(),
            shown.len()
        ));
    }
    text
}

/// The problems of one reading, in file order: the first [`MAX_REPORTED_PROBLEMS`] kept, the
/// others counted.
#[derive(Default)]
struct Problems {
    shown: Vec<CatalogueError>,
    total: usize,
}

impl Problems {
    fn push(&mut self, problem: CatalogueError) {
        self.total += 1;
        if self.shown.len() < MAX_REPORTED_PROBLEMS {
            self.shown.push(problem);
        }
    }

    /// `Ok(())` without a problem, the problem itself if alone, else all of them.
    fn into_result(self, source_name: &str) -> Result<(), CatalogueError> {
        let mut shown = self.shown;
        match (self.total, shown.len()) {
            (0, _) => Ok(()),
            (1, 1) => Err(shown.remove(0)),
            (total, _) => Err(CatalogueError::Problems {
                source_name: source_name.to_owned(),
                shown,
                total,
            }),
        }
    }
}

/// One entry as a reader found it: its context, and the entry as written or the reader's
/// problems with it.
type ReadEntry<'a> = (EntryContext<'a>, Result<RawPbr, Vec<CatalogueError>>);

/// A validated catalogue: the entries in file order, ids unique.
#[derive(Debug, Clone, PartialEq)]
pub struct Catalogue {
    source_name: String,
    pbrs: Vec<Pbr>,
}

impl Catalogue {
    /// Reads a catalogue file: TOML if the name ends in `.toml`, CSV if `.csv` (any case).
    pub fn load(path: impl AsRef<Path>) -> Result<Catalogue, CatalogueError> {
        let path = path.as_ref();
        let extension = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        let is_toml = match extension.as_deref() {
            Some("toml") => true,
            Some("csv") => false,
            _ => {
                return Err(CatalogueError::UnknownFormat {
                    path: path.to_owned(),
                })
            }
        };
        let text = crate::bounded_read::read_to_string_bounded(
            path,
            crate::bounded_read::MAX_DATA_FILE_BYTES,
        )
        .map_err(|error| CatalogueError::Io {
            path: path.to_owned(),
            error,
        })?;
        let source_name = path.display().to_string();
        let base_dir = path.parent();
        if is_toml {
            Catalogue::from_toml_str_in(&text, &source_name, base_dir)
        } else {
            Catalogue::from_csv_str_in(&text, &source_name, base_dir)
        }
    }

    /// Validates the read entries and checks that the ids are unique, in file order, reporting
    /// every problem found ([`CatalogueError::Problems`], bounded). Linear: an id is compared
    /// only with the earlier ids of the same FNV-1a hash (none, but for a duplicate or a
    /// 64-bit collision).
    fn build(
        source_name: &str,
        entries: Vec<ReadEntry<'_>>,
        base_dir: Option<&Path>,
        work: &mut LoadWork,
    ) -> Result<Catalogue, CatalogueError> {
        if entries.is_empty() {
            return Err(CatalogueError::Empty {
                source_name: source_name.to_owned(),
            });
        }
        let mut problems = Problems::default();
        let mut pbrs: Vec<Pbr> = Vec::with_capacity(entries.len());
        // Every entry's id (valid or not), its index and line, for the uniqueness check.
        let mut ids: Vec<(String, usize, Option<usize>)> = Vec::with_capacity(entries.len());
        let mut by_hash: HashMap<u64, Vec<usize>> = HashMap::with_capacity(entries.len());
        for (context, read) in entries {
            let validated = read.and_then(|raw| {
                validate(raw, context.sub_separator, base_dir).map_err(|found| {
                    found
                        .into_iter()
                        .map(|(field, message)| context.error(Some(field), message))
                        .collect()
                })
            });
            match validated {
                Ok(pbr) => pbrs.push(pbr),
                Err(found) => found.into_iter().for_each(|p| problems.push(p)),
            }
            let Some(id) = &context.id else { continue };
            let same_hash = by_hash.entry(fnv1a64(id.as_bytes())).or_default();
            let earlier = same_hash.iter().copied().find(|&i| {
                work.id_comparisons += 1;
                ids[i].0 == *id
            });
            if let Some(first) = earlier {
                let (_, index, line) = &ids[first];
                let at = line.map(|l| format!(" (line {l})")).unwrap_or_default();
                let message = format!("id {id:?} is already used by pbr[{index}]{at}");
                problems.push(context.error(Some("id".to_owned()), message));
            }
            same_hash.push(ids.len());
            ids.push((id.clone(), context.index, context.line));
        }
        problems.into_result(source_name)?;
        Ok(Catalogue {
            source_name: source_name.to_owned(),
            pbrs,
        })
    }

    /// The name the catalogue was loaded under (file path or the given source name).
    #[must_use]
    pub fn source_name(&self) -> &str {
        &self.source_name
    }

    /// All entries, in file order.
    #[must_use]
    pub fn pbrs(&self) -> &[Pbr] {
        &self.pbrs
    }

    /// Number of entries (never 0 for a loaded catalogue).
    #[must_use]
    pub fn len(&self) -> usize {
        self.pbrs.len()
    }

    /// Whether the catalogue has no entry (never true for a loaded catalogue).
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.pbrs.is_empty()
    }

    /// The entry with this id.
    #[must_use]
    pub fn get(&self, id: &str) -> Option<&Pbr> {
        self.pbrs.iter().find(|p| p.id == id)
    }

    /// The entries driven by the station `NET.STA.LOC` (exact, case-sensitive match), in file
    /// order.
    pub fn pbrs_for_station<'a>(&'a self, station: &'a str) -> impl Iterator<Item = &'a Pbr> + 'a {
        self.pbrs
            .iter()
            .filter(move |p| p.station.as_str() == station)
    }

    /// The distinct stations of the catalogue, in order of first appearance.
    #[must_use]
    pub fn stations(&self) -> Vec<&StationId> {
        let mut seen: HashSet<&str> = HashSet::new();
        self.pbrs
            .iter()
            .map(|p| &p.station)
            .filter(|s| seen.insert(s.as_str()))
            .collect()
    }
}

/// The work of one load, counted where it grows with the catalogue (the unit tests check that
/// it grows linearly: a deterministic measure, unlike a time).
#[derive(Debug, Default, Clone, Copy, PartialEq)]
struct LoadWork {
    /// Bytes of the text read to find the lines where entries start.
    line_bytes_scanned: usize,
    /// Id equality comparisons of the uniqueness check.
    id_comparisons: usize,
}

/// Where an entry came from, to name it in errors.
struct EntryContext<'a> {
    source_name: &'a str,
    line: Option<usize>,
    index: usize,
    id: Option<String>,
    /// Separator between a parameter and its sub-field in messages: `.` (TOML) or `_` (CSV).
    sub_separator: char,
}

impl EntryContext<'_> {
    fn error(&self, field: Option<String>, message: String) -> CatalogueError {
        CatalogueError::Entry {
            source_name: self.source_name.to_owned(),
            line: self.line,
            index: self.index,
            id: self.id.clone(),
            field,
            message,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `n` planar entries, 50 per station, as TOML and as CSV.
    fn generated(n: usize) -> (String, String) {
        let mut toml = String::new();
        let mut csv =
            String::from("id,name,lat,lon,station,azimuth_deg,width_m,height_m,mu_s,mu_k,source\n");
        for i in 0..n {
            let station = format!("XB.S{:04}.", i / 50);
            toml.push_str(&format!(
                "[[pbr]]\nid = \"b{i:06}\"\nname = \"b\"\nlat = 34\nlon = -118\n\
                 station = \"{station}\"\nazimuth_deg = 0\nwidth_m = 0.3\nheight_m = 1.5\n\
                 mu_s = 0.7\nmu_k = 0.5\nsource = \"t\"\n"
            ));
            csv.push_str(&format!(
                "b{i:06},b,34,-118,{station},0,0.3,1.5,0.7,0.5,t\n"
            ));
        }
        (toml, csv)
    }

    /// Issue 24: loading was quadratic (every entry's line counted from the top of the file,
    /// every id compared with all earlier ones: 100 000 TOML blocks took minutes). Counted
    /// work rather than time, so that a loaded machine cannot make it flake: at N and 2N
    /// entries the text is read at most once to place the entries, an id is compared with at
    /// most one other (the same hash), and 2N entries cost at most ~2× the work of N.
    #[test]
    fn loading_work_is_linear_in_the_entries() {
        let load = |n: usize| {
            let (toml, csv) = generated(n);
            let (mut of_toml, mut of_csv) = (LoadWork::default(), LoadWork::default());
            let a = Catalogue::from_toml_counted(&toml, "t.toml", None, &mut of_toml)
                .expect("the TOML loads");
            let b = Catalogue::from_csv_counted(&csv, "t.csv", None, &mut of_csv)
                .expect("the CSV loads");
            assert_eq!((a.len(), a.pbrs()), (n, b.pbrs()));
            (toml.len(), of_toml, of_csv)
        };
        let total = |w: LoadWork| w.line_bytes_scanned + w.id_comparisons;
        let mut by_size = Vec::new();
        for n in [1000, 2000] {
            let (toml_len, of_toml, of_csv) = load(n);
            assert!(
                of_toml.line_bytes_scanned <= toml_len,
                "{n} entries: {} bytes read to place entries in {toml_len} bytes of TOML",
                of_toml.line_bytes_scanned
            );
            for (format, work) in [("TOML", of_toml), ("CSV", of_csv)] {
                assert!(
                    work.id_comparisons <= n,
                    "{format}, {n} entries: {} id comparisons",
                    work.id_comparisons
                );
            }
            by_size.push((total(of_toml), total(of_csv)));
        }
        let ((toml_1, csv_1), (toml_2, csv_2)) = (by_size[0], by_size[1]);
        assert!(
            toml_2 <= 2 * toml_1 + toml_1 / 20,
            "TOML: work {toml_1} at 1000 entries, {toml_2} at 2000"
        );
        assert!(
            csv_2 <= 2 * csv_1 + csv_1 / 20 + 10,
            "CSV: work {csv_1} at 1000 entries, {csv_2} at 2000"
        );
    }

    #[test]
    fn station_id_splits_into_seed_codes() {
        let s = StationId::parse("CI.RRS.00").unwrap();
        assert_eq!(
            (s.network(), s.station(), s.location()),
            ("CI", "RRS", "00")
        );
        assert_eq!(s.to_string(), "CI.RRS.00");
        let s = StationId::parse("N4.ABCDE.").unwrap();
        assert_eq!(
            (s.network(), s.station(), s.location()),
            ("N4", "ABCDE", "")
        );
        for bad in [
            "CI.RRS",
            "CI.RRS.00.HNE",
            "CIX.RRS.00",
            ".RRS.00",
            "CI.RRSXYZ.00",
            "CI..00",
            "CI.RRS.000",
            "ci.RRS.00",
            "CI.R-S.00",
        ] {
            assert!(StationId::parse(bad).is_err(), "{bad} accepted");
        }
    }
}
