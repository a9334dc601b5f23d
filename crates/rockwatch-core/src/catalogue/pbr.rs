//! One validated catalogue entry ([`Pbr`]) and its accessors: identity, position (WGS84
//! degrees), the driving station, the direction of the block's +x axis (degrees clockwise
//! from north) and the block parameters as written ([`Distribution`]s), with the nominal
//! block. Only `validate.rs` builds one; the ensembles are in `ensemble.rs`.

use super::distribution::Distribution;
use super::geometry::{Geometry, MeshRock, RockModel};
use super::StationId;
use crate::azimuth::Azimuth;
use crate::dynamics::BlockParams;
use crate::pbr_id::PbrId;

/// One validated catalogue entry: a PBR or other freestanding object modelled as a rigid block.
#[derive(Debug, Clone, PartialEq)]
pub struct Pbr {
    pub(super) id: PbrId,
    pub(super) name: String,
    pub(super) lat_deg: f64,
    pub(super) lon_deg: f64,
    pub(super) station: StationId,
    pub(super) azimuth: Azimuth,
    pub(super) geometry: Geometry,
    pub(super) mu_s: Distribution,
    pub(super) mu_k: Distribution,
    pub(super) restitution: Option<Distribution>,
    pub(super) source: String,
    pub(super) ensemble: usize,
    pub(super) seed: u64,
    pub(super) nominal: BlockParams,
    /// The rock's mesh, for the `mesh` geometry.
    pub(super) mesh: Option<MeshRock>,
}

impl Pbr {
    /// The unique identifier.
    #[must_use]
    pub fn id(&self) -> &PbrId {
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

    /// How the entry is integrated: planar bodies (every entry but a mesh rock with
    /// `model = "3d"`) or one 3-D rigid body.
    #[must_use]
    pub fn model(&self) -> RockModel {
        match self.mesh.as_ref().and_then(MeshRock::body) {
            Some(_) => RockModel::Rigid3d,
            None => RockModel::Planar,
        }
    }

    /// The horizontal ground acceleration along this block's +x axis from the east and north
    /// components (m/s²): [`Azimuth::component`] of [`Pbr::azimuth`],
    /// `a_x = a_E·sin(az) + a_N·cos(az)`. Components of a station that is not oriented
    /// east/north (e.g. channels `1`, `2`) must be rotated to east/north first.
    #[must_use]
    pub fn project_horizontal(&self, east_mps2: f64, north_mps2: f64) -> f64 {
        self.azimuth.component(east_mps2, north_mps2)
    }
}
