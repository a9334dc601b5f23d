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
//! A catalogue is an array of `[[pbr]]` tables, and nothing else at the top level:
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
//!   true azimuths clockwise from north, distinct, at most [`MAX_DIRECTIONS`] — optional
//!   `up` (the mesh axis pointing up, default `"z"`), `heading_deg` (true azimuth of the mesh's
//!   north axis, in [−360, 360], default 0) and `contact_tolerance_m` (in [0, 1] m, default
//!   0: the resting hull facet alone; see [`crate::mesh::contact::DEFAULT_CONTACT_TOLERANCE_M`]). `heading_deg` and `contact_tolerance_m` are [`Distribution`]s like the other
//!   parameters (the mesh's uncertain fields, in that LHS column order). The rock has one
//!   planar body per direction ([`Pbr::directions`]; direction az is the mesh's azimuth
//!   az − heading); [`Pbr::nominal`] and [`Pbr::members`] are those of its first direction.
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
//! `heading_deg`, `contact_tolerance_m` are optional. A CSV and a TOML file describing the same PBRs load equal.
//!
//! # Errors
//!
//! Nothing here panics on bad input. A problem with one entry is reported as
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

use std::fmt;
use std::path::{Path, PathBuf};

use serde::de::{self, Deserializer, MapAccess, Visitor};
use serde::Deserialize;

use crate::azimuth::Azimuth;
use crate::dynamics::{BlockParams, ParamError};
use crate::lhs::{latin_hypercube_seeded, standard_normal_quantile};
use crate::mesh::contact::{
    azimuth_steps, parse_azimuths, RestingContact, RockGeometry, UpAxis,
    DEFAULT_CONTACT_TOLERANCE_M,
};

/// Largest ensemble size K accepted in a catalogue.
pub const MAX_ENSEMBLE: usize = 10_000;

/// The default LHS seed of an entry without `seed`: the 64-bit FNV-1a hash of the UTF-8 bytes
/// of its `id` (offset basis 0xcbf29ce484222325, prime 0x100000001b3, xor then multiply).
/// Stable across platforms and versions, and different ids give unrelated ensembles.
#[must_use]
pub fn default_seed(id: &str) -> u64 {
    crate::partition::fnv1a64(id.as_bytes())
}

/// A possibly uncertain scalar parameter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Distribution {
    /// A known value.
    Fixed(f64),
    /// Uniform on `[min, max]` (`min < max`). Nominal value: the midpoint.
    Uniform { min: f64, max: f64 },
    /// Normal with mean `mean` and standard deviation `sd > 0`, truncated to the parameter's
    /// valid domain when sampled. Nominal value: `mean`.
    Normal { mean: f64, sd: f64 },
}

impl Distribution {
    /// The nominal value: the value itself, the midpoint of a range, the mean of a normal.
    #[must_use]
    pub fn nominal(&self) -> f64 {
        match *self {
            Distribution::Fixed(v) => v,
            Distribution::Uniform { min, max } => 0.5 * (min + max),
            Distribution::Normal { mean, .. } => mean,
        }
    }

    /// Whether the value is known exactly (not sampled in an ensemble).
    #[must_use]
    pub fn is_fixed(&self) -> bool {
        matches!(self, Distribution::Fixed(_))
    }

    /// The value at cumulative probability `u` ∈ (0, 1) of the distribution restricted to
    /// `domain` (see the module doc), always inside `domain`.
    fn quantile(&self, u: f64, domain: Domain) -> f64 {
        let x = match *self {
            Distribution::Fixed(v) => v,
            Distribution::Uniform { min, max } => min + u * (max - min),
            Distribution::Normal { mean, sd } => {
                let p_lo = standard_normal_cdf((domain.lo - mean) / sd);
                let p_hi = standard_normal_cdf((domain.hi - mean) / sd);
                // Keep p strictly inside (0, 1) so that Φ⁻¹ stays finite whatever the rounding.
                let p = (p_lo + u * (p_hi - p_lo)).clamp(f64::MIN_POSITIVE, 1.0 - f64::EPSILON);
                mean + sd * standard_normal_quantile(p)
            }
        };
        domain.clamp(x)
    }
}

/// Φ(z), the standard normal CDF, as ½·erfc(−z/√2) (erfc from `libm`, accurate to about one
/// ulp, also in the tails). Φ(−∞) = 0, Φ(∞) = 1.
fn standard_normal_cdf(z: f64) -> f64 {
    0.5 * libm::erfc(-z / std::f64::consts::SQRT_2)
}

/// The set of valid values of one parameter: from `lo` to `hi`, each end open or closed.
#[derive(Debug, Clone, Copy)]
struct Domain {
    lo: f64,
    lo_open: bool,
    hi: f64,
    hi_open: bool,
    /// "must be …" completion for error messages.
    requirement: &'static str,
}

const SIZE_DOMAIN: Domain = Domain {
    lo: 0.0,
    lo_open: true,
    hi: f64::INFINITY,
    hi_open: true,
    requirement: "a finite length > 0 (metres)",
};
const ALPHA_DEG_DOMAIN: Domain = Domain {
    lo: 0.0,
    lo_open: true,
    hi: 90.0,
    hi_open: true,
    requirement: "in (0, 90) degrees",
};
const MU_S_DOMAIN: Domain = Domain {
    lo: 0.0,
    lo_open: true,
    hi: f64::INFINITY,
    hi_open: true,
    requirement: "a finite number > 0",
};
const MU_K_DOMAIN: Domain = Domain {
    lo: 0.0,
    lo_open: false,
    hi: 4.0 / 3.0,
    hi_open: true,
    requirement: "in [0, 4/3) (mu_k ≥ 4/3 makes slide-rocking ill-posed: Painlevé paradox)",
};
const HEADING_DOMAIN: Domain = Domain {
    lo: -360.0,
    lo_open: false,
    hi: 360.0,
    hi_open: false,
    requirement: "in [-360, 360] degrees clockwise from north",
};
const CONTACT_TOLERANCE_DOMAIN: Domain = Domain {
    lo: 0.0,
    lo_open: false,
    hi: 1.0,
    hi_open: false,
    requirement: "in [0, 1] m",
};
const RESTITUTION_DOMAIN: Domain = Domain {
    lo: 0.0,
    lo_open: false,
    hi: 1.0,
    hi_open: false,
    requirement: "in [0, 1]",
};

impl Domain {
    fn contains(&self, x: f64) -> bool {
        let above_lo = if self.lo_open {
            x > self.lo
        } else {
            x >= self.lo
        };
        let below_hi = if self.hi_open {
            x < self.hi
        } else {
            x <= self.hi
        };
        x.is_finite() && above_lo && below_hi
    }

    /// The nearest value inside the domain (for rounding at the ends of a quantile map).
    fn clamp(&self, x: f64) -> f64 {
        let lo = if self.lo_open {
            self.lo.next_up()
        } else {
            self.lo
        };
        let hi = if self.hi_open {
            self.hi.next_down()
        } else {
            self.hi
        };
        if x.is_nan() {
            lo
        } else {
            x.clamp(lo, hi)
        }
    }
}

impl<'de> Deserialize<'de> for Distribution {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        deserializer.deserialize_any(DistributionVisitor)
    }
}

struct DistributionVisitor;

impl<'de> Visitor<'de> for DistributionVisitor {
    type Value = Distribution;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("a number, a range { min = .., max = .. } or a normal { mean = .., sd = .. }")
    }

    fn visit_f64<E: de::Error>(self, v: f64) -> Result<Distribution, E> {
        Ok(Distribution::Fixed(v))
    }

    fn visit_i64<E: de::Error>(self, v: i64) -> Result<Distribution, E> {
        Ok(Distribution::Fixed(v as f64))
    }

    fn visit_u64<E: de::Error>(self, v: u64) -> Result<Distribution, E> {
        Ok(Distribution::Fixed(v as f64))
    }

    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Distribution, A::Error> {
        let (mut min, mut max, mut mean, mut sd) = (None, None, None, None);
        while let Some(key) = map.next_key::<String>()? {
            let slot = match key.as_str() {
                "min" => &mut min,
                "max" => &mut max,
                "mean" => &mut mean,
                "sd" => &mut sd,
                _ => {
                    return Err(de::Error::custom(format!(
                        "unknown key `{key}`: a distribution is {{ min, max }} (uniform) or \
                         {{ mean, sd }} (normal)"
                    )))
                }
            };
            *slot = Some(map.next_value::<f64>()?);
        }
        match (min, max, mean, sd) {
            (Some(min), Some(max), None, None) => Ok(Distribution::Uniform { min, max }),
            (None, None, Some(mean), Some(sd)) => Ok(Distribution::Normal { mean, sd }),
            _ => {
                let given: Vec<&str> = [("min", min), ("max", max), ("mean", mean), ("sd", sd)]
                    .iter()
                    .filter(|(_, v)| v.is_some())
                    .map(|(k, _)| *k)
                    .collect();
                Err(de::Error::custom(format!(
                    "a distribution is {{ min, max }} (uniform) or {{ mean, sd }} (normal), got \
                     {{ {} }}",
                    given.join(", ")
                )))
            }
        }
    }
}

pub use crate::station_id::StationId;

/// One validated catalogue entry: a PBR or other freestanding object modelled as a rigid block.
#[derive(Debug, Clone, PartialEq)]
pub struct Pbr {
    id: String,
    name: String,
    lat_deg: f64,
    lon_deg: f64,
    station: StationId,
    azimuth: Azimuth,
    geometry: Geometry,
    mu_s: Distribution,
    mu_k: Distribution,
    restitution: Option<Distribution>,
    source: String,
    ensemble: usize,
    seed: u64,
    nominal: BlockParams,
    /// The rock's mesh, for the `mesh` geometry.
    mesh: Option<MeshRock>,
}

/// A rock given by its closed mesh (`mesh = "file"`): the analysed mesh, its up axis and
/// the toppling directions to integrate (docs/meshes.md).
#[derive(Debug, Clone, PartialEq)]
pub struct MeshRock {
    /// The mesh file, as resolved (relative paths are relative to the catalogue's directory).
    pub path: PathBuf,
    pub up: UpAxis,
    /// The directions (true azimuths, clockwise from north), in the order given.
    pub azimuths: Vec<Azimuth>,
    rock: RockGeometry,
    /// The resting contact at the nominal contact tolerance.
    rest: RestingContact,
}

impl MeshRock {
    /// The analysed mesh.
    #[must_use]
    pub fn rock(&self) -> &RockGeometry {
        &self.rock
    }

    /// The resting contact at the entry's nominal contact tolerance.
    #[must_use]
    pub fn rest(&self) -> &RestingContact {
        &self.rest
    }

    /// One block per direction for a heading (degrees, the true azimuth of the mesh's north
    /// axis) and a contact tolerance (m): direction az is the mesh's azimuth az − heading.
    fn blocks(
        &self,
        heading_deg: f64,
        tolerance_m: f64,
        mu_s: f64,
        mu_k: f64,
        restitution: Option<f64>,
    ) -> Result<Vec<BlockParams>, ParamError> {
        self.azimuths
            .iter()
            .map(|az| {
                let d = self
                    .rest
                    .direction_at(az.degrees() - heading_deg, tolerance_m);
                BlockParams::from_body(
                    d.b_plus_m,
                    d.b_minus_m,
                    d.h_m,
                    d.rho_m,
                    mu_s,
                    mu_k,
                    restitution,
                )
            })
            .collect()
    }
}

/// The blocks of one toppling direction of an entry.
#[derive(Debug, Clone, PartialEq)]
pub struct DirectionBlocks {
    /// Direction of the blocks' +x axis (clockwise from north).
    pub azimuth: Azimuth,
    /// The nominal block of this direction.
    pub nominal: BlockParams,
    /// The K ensemble members of this direction (empty when K = 1).
    pub members: Vec<BlockParams>,
}

/// Why an ensemble member could not be built (cannot happen for a validated entry; reported
/// rather than panicking).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("pbr {id:?}: ensemble member {member}: {reason}")]
pub struct EnsembleError {
    pub id: String,
    pub member: usize,
    pub reason: ParamError,
}

impl Pbr {
    /// The unique identifier.
    #[must_use]
    pub fn id(&self) -> &str {
        &self.id
    }

    /// The human-readable name.
    #[must_use]
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Latitude (degrees north).
    #[must_use]
    pub fn lat_deg(&self) -> f64 {
        self.lat_deg
    }

    /// Longitude (degrees east).
    #[must_use]
    pub fn lon_deg(&self) -> f64 {
        self.lon_deg
    }

    /// The station whose ground motion drives this block.
    #[must_use]
    pub fn station(&self) -> &StationId {
        &self.station
    }

    /// Azimuth of the block's +x axis, clockwise from north (degrees, [0, 360)); for a
    /// meshed rock, its first direction.
    #[must_use]
    pub fn azimuth_deg(&self) -> f64 {
        self.azimuth.degrees()
    }

    /// The direction of the block's +x axis (see [`Pbr::azimuth_deg`]).
    #[must_use]
    pub fn azimuth(&self) -> Azimuth {
        self.azimuth
    }

    /// The geometry as written: one of the three forms, each parameter a [`Distribution`].
    #[must_use]
    pub fn geometry(&self) -> Geometry {
        self.geometry
    }

    /// Base width B (m), when the entry gives its geometry as `width_m` + `height_m`.
    #[must_use]
    pub fn width_m(&self) -> Option<Distribution> {
        match self.geometry {
            Geometry::WidthHeight { width_m, .. } => Some(width_m),
            _ => None,
        }
    }

    /// Height H (m), when the entry gives its geometry as `width_m` + `height_m`.
    #[must_use]
    pub fn height_m(&self) -> Option<Distribution> {
        match self.geometry {
            Geometry::WidthHeight { height_m, .. } => Some(height_m),
            _ => None,
        }
    }

    /// Static friction coefficient μs.
    #[must_use]
    pub fn mu_s(&self) -> Distribution {
        self.mu_s
    }

    /// Kinetic friction coefficient μk.
    #[must_use]
    pub fn mu_k(&self) -> Distribution {
        self.mu_k
    }

    /// Rocking impact ratio e, if given (else the dynamics use Housner's η).
    #[must_use]
    pub fn restitution(&self) -> Option<Distribution> {
        self.restitution
    }

    /// Where the numbers come from (free text).
    #[must_use]
    pub fn source(&self) -> &str {
        &self.source
    }

    /// Ensemble size K (1 if the entry has no `ensemble`).
    #[must_use]
    pub fn ensemble_size(&self) -> usize {
        self.ensemble
    }

    /// The LHS seed: `seed` if given, else [`default_seed`]`(id)`.
    #[must_use]
    pub fn seed(&self) -> u64 {
        self.seed
    }

    /// The block with every parameter at its nominal value (midpoint of a range, mean of a
    /// normal); for a meshed rock, the block of its first direction.
    #[must_use]
    pub fn nominal(&self) -> BlockParams {
        self.nominal
    }

    /// The mesh of a `mesh` entry.
    #[must_use]
    pub fn mesh(&self) -> Option<&MeshRock> {
        self.mesh.as_ref()
    }

    /// Every toppling direction with its nominal block and, for K > 1, its K members (the
    /// same Latin-hypercube samples in every direction: member i of each direction is one
    /// rock). A planar entry has one direction, [`Pbr::azimuth`], with [`Pbr::nominal`] and
    /// [`Pbr::members`].
    pub fn directions(&self) -> Result<Vec<DirectionBlocks>, EnsembleError> {
        self.directions_sized(self.ensemble)
    }

    /// [`Pbr::directions`] with `ensemble` members instead of the entry's own K (the Latin
    /// hypercube of the same seed; `rockwatch fragility --ensemble K`).
    pub fn directions_sized(&self, ensemble: usize) -> Result<Vec<DirectionBlocks>, EnsembleError> {
        let Some(mesh) = &self.mesh else {
            let members = if ensemble > 1 {
                self.members_sized(ensemble)?
            } else {
                Vec::new()
            };
            return Ok(vec![DirectionBlocks {
                azimuth: self.azimuth,
                nominal: self.nominal,
                members,
            }]);
        };
        let nominal_values: Vec<f64> = self
            .sampled_parameters()
            .iter()
            .map(|p| p.map_or(f64::NAN, |(d, _)| d.nominal()))
            .collect();
        let nominal = self.mesh_blocks(mesh, &nominal_values, usize::MAX)?;
        let mut directions: Vec<DirectionBlocks> = mesh
            .azimuths
            .iter()
            .zip(nominal)
            .map(|(&azimuth, nominal)| DirectionBlocks {
                azimuth,
                nominal,
                members: Vec::with_capacity(if ensemble > 1 { ensemble } else { 0 }),
            })
            .collect();
        if ensemble > 1 {
            for (member, values) in self.member_values(ensemble).iter().enumerate() {
                let blocks = self.mesh_blocks(mesh, values, member)?;
                for (direction, block) in directions.iter_mut().zip(blocks) {
                    direction.members.push(block);
                }
            }
        }
        Ok(directions)
    }

    /// The blocks of every direction of a meshed rock for one row of parameter values
    /// (heading, tolerance, μs, μk, e in LHS column order).
    fn mesh_blocks(
        &self,
        mesh: &MeshRock,
        values: &[f64],
        member: usize,
    ) -> Result<Vec<BlockParams>, EnsembleError> {
        let (mu_s, mu_k, restitution) = (values[2], values[3], values[4]);
        mesh.blocks(
            values[0],
            values[1],
            mu_s,
            mu_k.min(mu_s),
            self.restitution.map(|_| restitution),
        )
        .map_err(|reason| EnsembleError {
            id: self.id.clone(),
            member,
            reason,
        })
    }

    /// The horizontal ground acceleration along this block's +x axis from the east and north
    /// components (m/s²): [`Azimuth::component`] of [`Pbr::azimuth`],
    /// `a_x = a_E·sin(az) + a_N·cos(az)`. Components of a station that is not oriented
    /// east/north (e.g. channels `1`, `2`) must be rotated to east/north first.
    #[must_use]
    pub fn project_horizontal(&self, east_mps2: f64, north_mps2: f64) -> f64 {
        self.azimuth.component(east_mps2, north_mps2)
    }

    /// The K ensemble members (K = [`Pbr::ensemble_size`]): for K = 1 exactly
    /// [`Pbr::nominal`]; otherwise a Latin hypercube over the uncertain parameters (see the
    /// module doc: column order, quantile maps, truncation, μk > μs handling). Reproducible:
    /// the same entry (same seed) always gives the same members.
    pub fn members(&self) -> Result<Vec<BlockParams>, EnsembleError> {
        self.members_sized(self.ensemble)
    }

    /// True when some parameter of the entry is uncertain (a range or a normal), so that an
    /// ensemble of more than one member differs from the nominal block.
    #[must_use]
    pub fn has_uncertainty(&self) -> bool {
        self.sampled_parameters()
            .iter()
            .any(|p| p.is_some_and(|(d, _)| !d.is_fixed()))
    }

    /// [`Pbr::members`] with `ensemble` members instead of the entry's own K (the Latin
    /// hypercube of the same seed; `rockwatch fragility --ensemble K`).
    pub fn members_sized(&self, ensemble: usize) -> Result<Vec<BlockParams>, EnsembleError> {
        if ensemble <= 1 {
            return Ok(vec![self.nominal]);
        }
        if let Some(mesh) = &self.mesh {
            return self
                .member_values(ensemble)
                .iter()
                .enumerate()
                .map(|(member, values)| Ok(self.mesh_blocks(mesh, values, member)?[0]))
                .collect();
        }
        let n_geometry = self.geometry.fields().len();
        let mut members = Vec::with_capacity(ensemble);
        for (member, values) in self.member_values(ensemble).iter().enumerate() {
            let (geometry, friction) = values.split_at(n_geometry);
            let (mu_s, mu_k, restitution) = (friction[0], friction[1], friction[2]);
            let params = self
                .geometry
                .block(
                    geometry,
                    mu_s,
                    mu_k.min(mu_s),
                    self.restitution.map(|_| restitution),
                )
                .map_err(|reason| EnsembleError {
                    id: self.id.clone(),
                    member,
                    reason,
                })?;
            members.push(params);
        }
        Ok(members)
    }

    /// The K rows of parameter values of the ensemble (K > 1), in LHS column order (the
    /// geometry's fields, then μs, μk, e; NaN for an absent restitution).
    fn member_values(&self, ensemble: usize) -> Vec<Vec<f64>> {
        let parameters = self.sampled_parameters();
        // Column j of the hypercube is the j-th uncertain parameter, in `parameters` order.
        let uncertain: Vec<(usize, Distribution, Domain)> = parameters
            .iter()
            .enumerate()
            .filter_map(|(k, p)| p.filter(|(d, _)| !d.is_fixed()).map(|(d, dom)| (k, d, dom)))
            .collect();
        let nominal_values: Vec<f64> = parameters
            .iter()
            .map(|p| p.map_or(f64::NAN, |(d, _)| d.nominal()))
            .collect();
        if uncertain.is_empty() {
            // Validation rejects K > 1 without uncertainty; K identical rows would be the answer.
            return vec![nominal_values; ensemble];
        }
        let lhs = latin_hypercube_seeded(ensemble, uncertain.len(), self.seed);
        lhs.samples()
            .map(|sample| {
                let mut values = nominal_values.clone();
                for (&(k, distribution, domain), &u) in uncertain.iter().zip(sample) {
                    values[k] = distribution.quantile(u, domain);
                }
                values
            })
            .collect()
    }

    /// The block parameters in LHS column order (the geometry's fields in their form's
    /// order, then `mu_s`, `mu_k`, `restitution`), each with its domain.
    fn sampled_parameters(&self) -> Vec<Option<(Distribution, Domain)>> {
        let mut parameters: Vec<Option<(Distribution, Domain)>> = self
            .geometry
            .fields()
            .iter()
            .map(|&(name, d)| Some((d, domain_of(name))))
            .collect();
        parameters.extend([
            Some((self.mu_s, MU_S_DOMAIN)),
            Some((self.mu_k, MU_K_DOMAIN)),
            self.restitution.map(|d| (d, RESTITUTION_DOMAIN)),
        ]);
        parameters
    }
}

/// The geometry of a catalogue entry, in one of three forms (docs/general-body.md), each
/// parameter a [`Distribution`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Geometry {
    /// A rectangle B × H: `width_m`, `height_m` (m).
    WidthHeight {
        width_m: Distribution,
        height_m: Distribution,
    },
    /// A rectangle given by its half-diagonal R (m) and slenderness α (degrees, in (0, 90)):
    /// `half_diagonal_m`, `alpha_deg`.
    HalfDiagonalAlpha {
        half_diagonal_m: Distribution,
        alpha_deg: Distribution,
    },
    /// A general planar body: horizontal distances `b_plus_m`, `b_minus_m` from the centre of
    /// mass to the +x and −x pivots, height `h_m` of the centre of mass above the base and
    /// radius of gyration `rho_m` about it (all m).
    Body {
        b_plus_m: Distribution,
        b_minus_m: Distribution,
        h_m: Distribution,
        rho_m: Distribution,
    },
    /// A rock from its closed mesh ([`Pbr::mesh`]): the uncertain parameters are its
    /// `heading_deg` (true azimuth of the mesh's north axis, degrees clockwise from north;
    /// default 0) and its `contact_tolerance_m` (m, default 0: the resting facet alone).
    Mesh {
        heading_deg: Distribution,
        contact_tolerance_m: Distribution,
    },
}

/// The fields of each planar geometry form, in LHS column order (the mesh form's are
/// `heading_deg`, `contact_tolerance_m`).
const GEOMETRY_FORMS: [&[&str]; 3] = [
    &["width_m", "height_m"],
    &["half_diagonal_m", "alpha_deg"],
    &["b_plus_m", "b_minus_m", "h_m", "rho_m"],
];

impl Geometry {
    /// The fields with their names, in LHS column order.
    #[must_use]
    pub fn fields(&self) -> Vec<(&'static str, Distribution)> {
        match *self {
            Geometry::WidthHeight { width_m, height_m } => {
                vec![("width_m", width_m), ("height_m", height_m)]
            }
            Geometry::HalfDiagonalAlpha {
                half_diagonal_m,
                alpha_deg,
            } => vec![
                ("half_diagonal_m", half_diagonal_m),
                ("alpha_deg", alpha_deg),
            ],
            Geometry::Body {
                b_plus_m,
                b_minus_m,
                h_m,
                rho_m,
            } => vec![
                ("b_plus_m", b_plus_m),
                ("b_minus_m", b_minus_m),
                ("h_m", h_m),
                ("rho_m", rho_m),
            ],
            Geometry::Mesh {
                heading_deg,
                contact_tolerance_m,
            } => vec![
                ("heading_deg", heading_deg),
                ("contact_tolerance_m", contact_tolerance_m),
            ],
        }
    }

    /// The block for values of this form's fields (in [`Geometry::fields`] order).
    fn block(
        &self,
        values: &[f64],
        mu_s: f64,
        mu_k: f64,
        restitution: Option<f64>,
    ) -> Result<BlockParams, ParamError> {
        match self {
            Geometry::WidthHeight { .. } => {
                BlockParams::from_width_height(values[0], values[1], mu_s, mu_k, restitution)
            }
            Geometry::HalfDiagonalAlpha { .. } => BlockParams::from_r_alpha(
                values[0],
                values[1].to_radians(),
                mu_s,
                mu_k,
                restitution,
            ),
            Geometry::Body { .. } => BlockParams::from_body(
                values[0],
                values[1],
                values[2],
                values[3],
                mu_s,
                mu_k,
                restitution,
            ),
            // Never called: a mesh entry's blocks come from `MeshRock::blocks`.
            Geometry::Mesh { .. } => Err(ParamError::NotPositive {
                name: "mesh direction",
                value: f64::NAN,
            }),
        }
    }

    /// The form `index` of [`GEOMETRY_FORMS`] from its distributions, in that order.
    fn from_form(index: usize, d: &[Distribution]) -> Geometry {
        match index {
            0 => Geometry::WidthHeight {
                width_m: d[0],
                height_m: d[1],
            },
            1 => Geometry::HalfDiagonalAlpha {
                half_diagonal_m: d[0],
                alpha_deg: d[1],
            },
            _ => Geometry::Body {
                b_plus_m: d[0],
                b_minus_m: d[1],
                h_m: d[2],
                rho_m: d[3],
            },
        }
    }
}

fn domain_of(field: &str) -> Domain {
    match field {
        "alpha_deg" => ALPHA_DEG_DOMAIN,
        "heading_deg" => HEADING_DOMAIN,
        "contact_tolerance_m" => CONTACT_TOLERANCE_DOMAIN,
        _ => SIZE_DOMAIN,
    }
}

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
        let text = std::fs::read_to_string(path).map_err(|error| CatalogueError::Io {
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

    /// Parses a TOML catalogue; `source_name` names it in error messages. Relative `mesh`
    /// paths are taken from the current directory (see [`Catalogue::from_toml_str_in`]).
    pub fn from_toml_str(text: &str, source_name: &str) -> Result<Catalogue, CatalogueError> {
        Catalogue::from_toml_str_in(text, source_name, None)
    }

    /// Parses a TOML catalogue whose relative `mesh` paths are relative to `base_dir` (the
    /// catalogue file's directory).
    pub fn from_toml_str_in(
        text: &str,
        source_name: &str,
        base_dir: Option<&Path>,
    ) -> Result<Catalogue, CatalogueError> {
        #[derive(Deserialize)]
        #[serde(deny_unknown_fields)]
        struct Document {
            #[serde(default)]
            pbr: Vec<toml::Spanned<toml::Table>>,
        }
        let document: Document = toml::from_str(text).map_err(|e| CatalogueError::Syntax {
            location: source_name.to_owned(),
            message: toml_error_line(text, &e),
        })?;
        let mut entries = Vec::with_capacity(document.pbr.len());
        for (index, spanned) in document.pbr.into_iter().enumerate() {
            let line = Some(line_of_offset(text, spanned.span().start));
            let table = spanned.into_inner();
            let id = table
                .get("id")
                .and_then(toml::Value::as_str)
                .filter(|s| !s.is_empty())
                .map(str::to_owned);
            let context = EntryContext {
                source_name,
                line,
                index,
                id,
                sub_separator: '.',
            };
            let raw: RawPbr = serde_path_to_error::deserialize(table).map_err(|e| {
                let path = e.path().to_string();
                let message = e.inner().message().to_owned();
                if path == "." || path.is_empty() {
                    context.error(None, message)
                } else if message.starts_with("unknown field") {
                    // serde's message already names the field.
                    context.error(Some(path), message)
                } else {
                    let message = format!("{path}: {message}");
                    context.error(Some(path), message)
                }
            })?;
            entries.push((context, raw));
        }
        Catalogue::build(source_name, entries, base_dir)
    }

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
            let record = record.map_err(|e| {
                let line = e.position().map(csv::Position::line);
                syntax(line, format!("invalid CSV row: {e}"))
            })?;
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
            let raw = columns
                .raw_pbr(&record)
                .map_err(|(field, message)| context.error(Some(field), message))?;
            entries.push((context, raw));
        }
        Catalogue::build(source_name, entries, base_dir)
    }

    /// Validates the parsed entries and checks that the ids are unique.
    fn build(
        source_name: &str,
        entries: Vec<(EntryContext<'_>, RawPbr)>,
        base_dir: Option<&Path>,
    ) -> Result<Catalogue, CatalogueError> {
        if entries.is_empty() {
            return Err(CatalogueError::Empty {
                source_name: source_name.to_owned(),
            });
        }
        let mut pbrs: Vec<Pbr> = Vec::with_capacity(entries.len());
        let mut lines: Vec<Option<usize>> = Vec::with_capacity(entries.len());
        for (context, raw) in entries {
            let pbr = validate(raw, context.sub_separator, base_dir)
                .map_err(|(field, message)| context.error(Some(field), message))?;
            if let Some(first) = pbrs.iter().position(|p| p.id == pbr.id) {
                let at = lines[first]
                    .map(|l| format!(" (line {l})"))
                    .unwrap_or_default();
                let message = format!("id {:?} is already used by pbr[{first}]{at}", pbr.id);
                return Err(context.error(Some("id".to_owned()), message));
            }
            lines.push(context.line);
            pbrs.push(pbr);
        }
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
        let mut stations: Vec<&StationId> = Vec::new();
        for pbr in &self.pbrs {
            if !stations.contains(&&pbr.station) {
                stations.push(&pbr.station);
            }
        }
        stations
    }
}

/// A TOML error as one line, `line N: message` (toml's own rendering spans several lines).
pub fn toml_error_line(text: &str, error: &toml::de::Error) -> String {
    let message = error.message().replace('\n', " ");
    match error.span() {
        Some(span) => format!("line {}: {message}", line_of_offset(text, span.start)),
        None => message,
    }
}

fn line_of_offset(text: &str, offset: usize) -> usize {
    let end = offset.min(text.len());
    text.as_bytes()[..end]
        .iter()
        .filter(|&&b| b == b'\n')
        .count()
        + 1
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

/// One entry as written, before validation (shared by the TOML and CSV readers).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawPbr {
    id: String,
    name: String,
    lat: f64,
    lon: f64,
    station: String,
    #[serde(default)]
    azimuth_deg: Option<f64>,
    #[serde(default)]
    mesh: Option<String>,
    #[serde(default)]
    up: Option<String>,
    #[serde(default)]
    azimuths: Option<RawAzimuths>,
    #[serde(default)]
    heading_deg: Option<Distribution>,
    #[serde(default)]
    contact_tolerance_m: Option<Distribution>,
    #[serde(default)]
    width_m: Option<Distribution>,
    #[serde(default)]
    height_m: Option<Distribution>,
    #[serde(default)]
    half_diagonal_m: Option<Distribution>,
    #[serde(default)]
    alpha_deg: Option<Distribution>,
    #[serde(default)]
    b_plus_m: Option<Distribution>,
    #[serde(default)]
    b_minus_m: Option<Distribution>,
    #[serde(default)]
    h_m: Option<Distribution>,
    #[serde(default)]
    rho_m: Option<Distribution>,
    mu_s: Distribution,
    mu_k: Distribution,
    #[serde(default)]
    restitution: Option<Distribution>,
    source: String,
    #[serde(default)]
    ensemble: Option<Integer>,
    #[serde(default)]
    seed: Option<Integer>,
}

/// The directions of a meshed rock as written: a list of degrees, a step form
/// `{ from, to, step }` (TO excluded), or (CSV) the text `FROM:TO:STEP` or `A,B,C`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(untagged)]
enum RawAzimuths {
    List(Vec<f64>),
    Steps(AzimuthSteps),
    Text(String),
}

#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
struct AzimuthSteps {
    from: f64,
    to: f64,
    step: f64,
}

/// Most directions of one catalogued rock.
pub const MAX_DIRECTIONS: usize = 360;

/// An integer of either sign up to the `u64` range (TOML integers are `i64`, CSV seeds `u64`);
/// range checks happen in validation, with the field's own message.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Integer(i128);

impl<'de> Deserialize<'de> for Integer {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct IntegerVisitor;
        impl Visitor<'_> for IntegerVisitor {
            type Value = Integer;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("an integer")
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> Result<Integer, E> {
                Ok(Integer(i128::from(v)))
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> Result<Integer, E> {
                Ok(Integer(i128::from(v)))
            }
        }
        deserializer.deserialize_any(IntegerVisitor)
    }
}

/// Validates one entry; the error is (field, message).
fn validate(raw: RawPbr, sep: char, base_dir: Option<&Path>) -> Result<Pbr, (String, String)> {
    let fail = |field: &str, message: String| Err((field.to_owned(), message));

    if raw.id.is_empty() {
        return fail("id", "id must not be empty".to_owned());
    }
    if raw.id.chars().any(|c| c.is_whitespace() || c.is_control()) {
        return fail(
            "id",
            format!(
                "id {:?} must not contain whitespace or control characters",
                raw.id
            ),
        );
    }
    for (field, text) in [("name", &raw.name), ("source", &raw.source)] {
        if text.trim().is_empty() {
            let why = if field == "source" {
                " (say where the numbers come from)"
            } else {
                ""
            };
            return fail(field, format!("{field} must not be blank{why}"));
        }
    }
    if !(raw.lat.is_finite() && (-90.0..=90.0).contains(&raw.lat)) {
        return fail(
            "lat",
            format!("lat = {} must be in [-90, 90] degrees", raw.lat),
        );
    }
    if !(raw.lon.is_finite() && (-180.0..=180.0).contains(&raw.lon)) {
        return fail(
            "lon",
            format!("lon = {} must be in [-180, 180] degrees", raw.lon),
        );
    }
    let station = StationId::parse(&raw.station)
        .map_err(|why| ("station".to_owned(), format!("station {why}")))?;
    let geometry = raw_geometry(&raw)?;
    let azimuths: Vec<Azimuth> = match (&raw.mesh, raw.azimuth_deg, &raw.azimuths) {
        (Some(_), Some(_), _) => {
            return fail(
                "azimuth_deg",
                "azimuth_deg cannot be combined with mesh: give the directions as azimuths = \
                 [...] or azimuths = { from, to, step }"
                    .to_owned(),
            )
        }
        (Some(_), None, None) => {
            return fail(
                "azimuths",
                "azimuths is missing: a mesh rock needs its directions, azimuths = [...] or \
                 { from = 0, to = 360, step = 15 } (degrees clockwise from north)"
                    .to_owned(),
            )
        }
        (Some(_), None, Some(written)) => directions(written)?,
        (None, _, Some(_)) => {
            return fail(
                "azimuths",
                "azimuths needs mesh (a planar block has azimuth_deg)".to_owned(),
            )
        }
        (None, None, None) => return fail("azimuth_deg", "azimuth_deg is missing".to_owned()),
        (None, Some(degrees), None) => match Azimuth::from_degrees(degrees) {
            Ok(azimuth) if (0.0..360.0).contains(&degrees) => vec![azimuth],
            _ => {
                return fail(
                    "azimuth_deg",
                    format!(
                        "azimuth_deg = {degrees} must be in [0, 360) degrees clockwise from north"
                    ),
                )
            }
        },
    };
    let azimuth = azimuths[0];
    for (field, d) in geometry.fields() {
        check_distribution(field, &d, domain_of(field), sep)?;
    }
    check_distribution("mu_s", &raw.mu_s, MU_S_DOMAIN, sep)?;
    check_distribution("mu_k", &raw.mu_k, MU_K_DOMAIN, sep)?;
    if let Some(e) = &raw.restitution {
        check_distribution("restitution", e, RESTITUTION_DOMAIN, sep)?;
    }
    let (mu_s, mu_k) = (raw.mu_s.nominal(), raw.mu_k.nominal());
    // A midpoint such as (0.4 + 0.8)/2 = 0.6000000000000001 must not count as exceeding 0.6:
    // an excess of a few ulps is rounding, and the nominal μk is then taken equal to μs.
    if mu_k > mu_s * (1.0 + 4.0 * f64::EPSILON) {
        let nominal = if raw.mu_s.is_fixed() && raw.mu_k.is_fixed() {
            ""
        } else {
            "nominal "
        };
        return fail(
            "mu_k",
            format!("{nominal}mu_k = {mu_k} exceeds {nominal}mu_s = {mu_s}"),
        );
    }
    let n_uncertain = geometry
        .fields()
        .iter()
        .map(|(_, d)| d)
        .chain([raw.mu_s, raw.mu_k].iter())
        .chain(raw.restitution.iter())
        .filter(|d| !d.is_fixed())
        .count();
    let ensemble = match raw.ensemble.map(|k| k.0) {
        None => 1,
        Some(k) if (1..=MAX_ENSEMBLE as i128).contains(&k) => k as usize,
        Some(k) => {
            return fail(
                "ensemble",
                format!("ensemble = {k} must be an integer from 1 to {MAX_ENSEMBLE}"),
            )
        }
    };
    if ensemble > 1 && n_uncertain == 0 {
        return fail(
            "ensemble",
            format!(
                "ensemble = {ensemble} but no parameter is uncertain: give a range or a normal \
                 for at least one of {}, mu_s, mu_k, restitution, or drop ensemble",
                geometry
                    .fields()
                    .iter()
                    .map(|(name, _)| *name)
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        );
    }
    let seed = match raw.seed.map(|s| s.0) {
        None => default_seed(&raw.id),
        Some(s) => match u64::try_from(s) {
            Ok(s) => s,
            Err(_) => {
                return fail(
                    "seed",
                    format!("seed = {s} must be an integer from 0 to {}", u64::MAX),
                )
            }
        },
    };
    let fields = geometry.fields();
    let nominal_geometry: Vec<f64> = fields.iter().map(|(_, d)| d.nominal()).collect();
    let mesh = match &raw.mesh {
        Some(file) => Some(load_mesh(
            file,
            raw.up.as_deref(),
            azimuths,
            nominal_geometry[1],
            base_dir,
        )?),
        None => None,
    };
    let nominal = match &mesh {
        // Every direction's nominal block must be valid; the first is the entry's nominal.
        Some(m) => m
            .blocks(
                nominal_geometry[0],
                nominal_geometry[1],
                mu_s,
                mu_k.min(mu_s),
                raw.restitution.map(|d| d.nominal()),
            )
            .map(|blocks| blocks[0]),
        None => geometry.block(
            &nominal_geometry,
            mu_s,
            mu_k.min(mu_s),
            raw.restitution.map(|d| d.nominal()),
        ),
    }
    .map_err(|e| {
        (
            fields[0].0.to_owned(),
            format!("nominal block rejected: {e}"),
        )
    })?;
    Ok(Pbr {
        id: raw.id,
        name: raw.name,
        lat_deg: raw.lat,
        lon_deg: raw.lon,
        station,
        azimuth,
        geometry,
        mu_s: raw.mu_s,
        mu_k: raw.mu_k,
        restitution: raw.restitution,
        source: raw.source,
        ensemble,
        seed,
        nominal,
        mesh,
    })
}

/// The directions of a mesh entry: each a finite azimuth, taken modulo 360, distinct, at most
/// [`MAX_DIRECTIONS`].
fn directions(written: &RawAzimuths) -> Result<Vec<Azimuth>, (String, String)> {
    let fail = |message: String| Err(("azimuths".to_owned(), format!("azimuths: {message}")));
    let degrees = match written {
        RawAzimuths::List(list) => list.clone(),
        RawAzimuths::Steps(AzimuthSteps { from, to, step }) => {
            match azimuth_steps(*from, *to, *step) {
                Ok(list) => list,
                Err(e) => return fail(e),
            }
        }
        RawAzimuths::Text(text) => match parse_azimuths(text) {
            Ok(list) => list,
            Err(e) => return fail(e),
        },
    };
    if degrees.is_empty() || degrees.len() > MAX_DIRECTIONS {
        return fail(format!(
            "give 1 to {MAX_DIRECTIONS} directions, got {}",
            degrees.len()
        ));
    }
    let mut azimuths: Vec<Azimuth> = Vec::with_capacity(degrees.len());
    for d in degrees {
        let normalised = d.rem_euclid(360.0);
        let Ok(azimuth) = Azimuth::from_degrees(normalised) else {
            return fail(format!("{d} is not a finite number of degrees"));
        };
        if azimuths.iter().any(|a| a.degrees() == normalised) {
            return fail(format!("the direction {normalised}° is given twice"));
        }
        azimuths.push(azimuth);
    }
    Ok(azimuths)
}

/// Reads and analyses the mesh of an entry (relative paths from `base_dir`).
fn load_mesh(
    file: &str,
    up: Option<&str>,
    azimuths: Vec<Azimuth>,
    tolerance_m: f64,
    base_dir: Option<&Path>,
) -> Result<MeshRock, (String, String)> {
    let up = match up {
        Some(text) => UpAxis::parse(text).map_err(|e| ("up".to_owned(), format!("up: {e}")))?,
        None => UpAxis::PlusZ,
    };
    let written = Path::new(file);
    let path = match base_dir {
        Some(dir) if written.is_relative() => dir.join(written),
        _ => written.to_owned(),
    };
    let mesh_error = |e: crate::mesh::MeshError| ("mesh".to_owned(), format!("mesh: {e}"));
    let rock = RockGeometry::read(&path).map_err(mesh_error)?;
    let rest = rock.rest(up, tolerance_m).map_err(mesh_error)?;
    Ok(MeshRock {
        path,
        up,
        azimuths,
        rock,
        rest,
    })
}

/// The entry's geometry: exactly one complete form of [`GEOMETRY_FORMS`]; the error names the
/// first field that conflicts or is missing.
fn raw_geometry(raw: &RawPbr) -> Result<Geometry, (String, String)> {
    let planar = [
        ("width_m", raw.width_m),
        ("height_m", raw.height_m),
        ("half_diagonal_m", raw.half_diagonal_m),
        ("alpha_deg", raw.alpha_deg),
        ("b_plus_m", raw.b_plus_m),
        ("b_minus_m", raw.b_minus_m),
        ("h_m", raw.h_m),
        ("rho_m", raw.rho_m),
    ];
    if raw.mesh.is_some() {
        if let Some((field, _)) = planar.iter().find(|(_, d)| d.is_some()) {
            return Err((
                (*field).to_owned(),
                format!("{field} cannot be combined with mesh: the mesh gives the geometry"),
            ));
        }
        return Ok(Geometry::Mesh {
            heading_deg: raw.heading_deg.unwrap_or(Distribution::Fixed(0.0)),
            contact_tolerance_m: raw
                .contact_tolerance_m
                .unwrap_or(Distribution::Fixed(DEFAULT_CONTACT_TOLERANCE_M)),
        });
    }
    for (field, given) in [
        ("heading_deg", raw.heading_deg.is_some()),
        ("contact_tolerance_m", raw.contact_tolerance_m.is_some()),
        ("up", raw.up.is_some()),
    ] {
        if given {
            return Err((field.to_owned(), format!("{field} needs mesh")));
        }
    }
    let value = |field: &str| match field {
        "width_m" => raw.width_m,
        "height_m" => raw.height_m,
        "half_diagonal_m" => raw.half_diagonal_m,
        "alpha_deg" => raw.alpha_deg,
        "b_plus_m" => raw.b_plus_m,
        "b_minus_m" => raw.b_minus_m,
        "h_m" => raw.h_m,
        _ => raw.rho_m,
    };
    let forms_text = "width_m + height_m, half_diagonal_m + alpha_deg, b_plus_m + b_minus_m \
                      + h_m + rho_m, or mesh";
    let used: Vec<usize> = (0..GEOMETRY_FORMS.len())
        .filter(|&i| GEOMETRY_FORMS[i].iter().any(|f| value(f).is_some()))
        .collect();
    match used[..] {
        [] => Err((
            "width_m".to_owned(),
            format!("the geometry is missing: give {forms_text}"),
        )),
        [form] => {
            let fields = GEOMETRY_FORMS[form];
            let mut distributions = Vec::with_capacity(fields.len());
            for field in fields {
                match value(field) {
                    Some(d) => distributions.push(d),
                    None => {
                        return Err((
                            (*field).to_owned(),
                            format!(
                                "{field} is missing: this geometry needs {}",
                                fields.join(" + ")
                            ),
                        ))
                    }
                }
            }
            Ok(Geometry::from_form(form, &distributions))
        }
        [first, second, ..] => {
            let given = |i: usize| {
                GEOMETRY_FORMS[i]
                    .iter()
                    .copied()
                    .find(|f| value(f).is_some())
                    .unwrap_or(GEOMETRY_FORMS[i][0])
            };
            let (a, b) = (given(first), given(second));
            Err((
                b.to_owned(),
                format!("{b} cannot be combined with {a}: give one geometry, {forms_text}"),
            ))
        }
    }
}

/// Checks one distribution against its parameter's domain; errors name `field` or
/// `field{sep}min` etc.
fn check_distribution(
    field: &str,
    distribution: &Distribution,
    domain: Domain,
    sep: char,
) -> Result<(), (String, String)> {
    let need = |name: String, value: f64| -> Result<(), (String, String)> {
        if domain.contains(value) {
            Ok(())
        } else {
            let message = format!("{name} = {value} must be {}", domain.requirement);
            Err((name, message))
        }
    };
    match *distribution {
        Distribution::Fixed(v) => need(field.to_owned(), v),
        Distribution::Uniform { min, max } => {
            need(format!("{field}{sep}min"), min)?;
            need(format!("{field}{sep}max"), max)?;
            if min < max {
                Ok(())
            } else {
                let name = format!("{field}{sep}min");
                let message = format!(
                    "{name} = {min} must be less than {field}{sep}max = {max} (use a plain number \
                     for a known value)"
                );
                Err((name, message))
            }
        }
        Distribution::Normal { mean, sd } => {
            need(format!("{field}{sep}mean"), mean)?;
            if sd.is_finite() && sd > 0.0 {
                Ok(())
            } else {
                let name = format!("{field}{sep}sd");
                let message = format!(
                    "{name} = {sd} must be a finite number > 0 (use a plain number for a known \
                     value)"
                );
                Err((name, message))
            }
        }
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
/// `azimuths` for meshed rocks).
const OPTIONAL_SCALAR_COLUMNS: [&str; 6] =
    ["azimuth_deg", "ensemble", "seed", "mesh", "up", "azimuths"];
/// Suffixes of the columns of an uncertain parameter `P`: `P`, `P_min`, `P_max`, `P_mean`,
/// `P_sd`.
const DISTRIBUTION_SUFFIXES: [&str; 5] = ["", "_min", "_max", "_mean", "_sd"];

/// The column layout of a CSV catalogue: name → index.
struct CsvColumns {
    index: std::collections::HashMap<String, usize>,
}

impl CsvColumns {
    fn from_header(headers: &csv::StringRecord) -> Result<CsvColumns, String> {
        let mut index = std::collections::HashMap::new();
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

    fn raw_pbr(&self, record: &csv::StringRecord) -> Result<RawPbr, (String, String)> {
        let required = |stem: &str| -> Result<Distribution, (String, String)> {
            self.distribution(record, stem)?.ok_or_else(|| {
                (
                    stem.to_owned(),
                    format!(
                        "{stem} is missing (fill {stem}, {stem}_min + {stem}_max, or \
                         {stem}_mean + {stem}_sd)"
                    ),
                )
            })
        };
        Ok(RawPbr {
            id: self.string(record, "id"),
            name: self.string(record, "name"),
            lat: self.number(record, "lat")?,
            lon: self.number(record, "lon")?,
            station: self.string(record, "station"),
            azimuth_deg: self
                .value(record, "azimuth_deg")
                .map(|text| parse_number("azimuth_deg", text))
                .transpose()?,
            mesh: self.value(record, "mesh").map(str::to_owned),
            up: self.value(record, "up").map(str::to_owned),
            azimuths: self
                .value(record, "azimuths")
                .map(|text| RawAzimuths::Text(text.to_owned())),
            heading_deg: self.distribution(record, "heading_deg")?,
            contact_tolerance_m: self.distribution(record, "contact_tolerance_m")?,
            width_m: self.distribution(record, "width_m")?,
            height_m: self.distribution(record, "height_m")?,
            half_diagonal_m: self.distribution(record, "half_diagonal_m")?,
            alpha_deg: self.distribution(record, "alpha_deg")?,
            b_plus_m: self.distribution(record, "b_plus_m")?,
            b_minus_m: self.distribution(record, "b_minus_m")?,
            h_m: self.distribution(record, "h_m")?,
            rho_m: self.distribution(record, "rho_m")?,
            mu_s: required("mu_s")?,
            mu_k: required("mu_k")?,
            restitution: self.distribution(record, "restitution")?,
            source: self.string(record, "source"),
            ensemble: self.integer(record, "ensemble")?,
            seed: self.integer(record, "seed")?,
        })
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fnv1a_default_seed_matches_published_test_vectors() {
        // Test vectors of the FNV reference (Landon Curt Noll, www.isthe.com/chongo/tech/comp/fnv,
        // and draft-eastlake-fnv): FNV-1a 64 of "", "a" and "foobar".
        assert_eq!(default_seed(""), 0xcbf2_9ce4_8422_2325);
        assert_eq!(default_seed("a"), 0xaf63_dc4c_8601_ec8c);
        assert_eq!(default_seed("foobar"), 0x8594_4171_f739_67e8);
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

    #[test]
    fn domain_clamp_stays_inside_open_and_closed_ends() {
        assert!(SIZE_DOMAIN.contains(SIZE_DOMAIN.clamp(-1.0)));
        assert!(SIZE_DOMAIN.contains(SIZE_DOMAIN.clamp(0.0)));
        assert!(MU_K_DOMAIN.contains(MU_K_DOMAIN.clamp(4.0 / 3.0)));
        assert_eq!(MU_K_DOMAIN.clamp(-0.5), 0.0);
        assert_eq!(RESTITUTION_DOMAIN.clamp(1.5), 1.0);
        assert!(!MU_K_DOMAIN.contains(4.0 / 3.0));
        assert!(!SIZE_DOMAIN.contains(f64::INFINITY));
    }

    #[test]
    fn standard_normal_cdf_matches_published_values() {
        // Φ(1) = 0.841344746068542948…, Φ(−1.959963984540054) = 0.025, Φ(−6) = 9.8658765e−10
        // (A&S table 26.1 / R pnorm); erfc is ~1 ulp, so 1e−15 relative is generous.
        assert!((standard_normal_cdf(1.0) - 0.841_344_746_068_542_9).abs() < 1e-15);
        assert!((standard_normal_cdf(-1.959_963_984_540_054) - 0.025).abs() < 1e-16);
        assert!((standard_normal_cdf(-6.0) / 9.865_876_450_376_98e-10 - 1.0).abs() < 1e-12);
        assert_eq!(standard_normal_cdf(f64::NEG_INFINITY), 0.0);
        assert_eq!(standard_normal_cdf(f64::INFINITY), 1.0);
    }

    #[test]
    fn truncated_normal_quantile_hits_the_domain_ends_at_u_extremes() {
        // A normal with mean 0.05, sd 0.1 on [0, 4/3): u → 0 gives values near 0 (never below),
        // u = ½ gives the median of the truncated law: Φ⁻¹(Φ(−0.5) + ½(1 − Φ(−0.5)))·sd + mean.
        let d = Distribution::Normal {
            mean: 0.05,
            sd: 0.1,
        };
        let lo = d.quantile(1e-12, MU_K_DOMAIN);
        assert!((0.0..1e-9).contains(&lo), "{lo}");
        // Φ(−0.5) = 0.308537538725987; median p = 0.654268769362994, Φ⁻¹(p) = 0.396...
        let p_med = 0.308_537_538_725_987 + 0.5 * (1.0 - 0.308_537_538_725_987);
        let expected = 0.05 + 0.1 * standard_normal_quantile(p_med);
        assert!((d.quantile(0.5, MU_K_DOMAIN) - expected).abs() < 1e-12);
    }
}
