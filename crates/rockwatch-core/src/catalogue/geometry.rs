//! The geometry of a catalogue entry ([`Geometry`]): a rectangle by width and height (m), a
//! rectangle by half-diagonal R (m) and slenderness α (degrees, in (0, 90)), a general planar
//! body b₊, b₋, h, ρ (m; docs/general-body.md), or a rock from its closed mesh ([`MeshRock`]:
//! heading in degrees clockwise from north, contact tolerance in m; docs/meshes.md).
//!
//! The order of each form's fields is the order of the Latin-hypercube columns; the blocks
//! are built by the constructors of [`BlockParams`], which check what the dynamics need.

use std::path::PathBuf;

use super::distribution::{
    Distribution, Domain, ALPHA_DEG_DOMAIN, CONTACT_TOLERANCE_DOMAIN, HEADING_DOMAIN, SIZE_DOMAIN,
};
use crate::azimuth::Azimuth;
use crate::dynamics::{BlockParams, ParamError};
use crate::mesh::contact::{RestingContact, RockGeometry, UpAxis};

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
pub(super) const GEOMETRY_FORMS: [&[&str]; 3] = [
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
    pub(super) fn block(
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
    pub(super) fn from_form(index: usize, d: &[Distribution]) -> Geometry {
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

pub(super) fn domain_of(field: &str) -> Domain {
    match field {
        "alpha_deg" => ALPHA_DEG_DOMAIN,
        "heading_deg" => HEADING_DOMAIN,
        "contact_tolerance_m" => CONTACT_TOLERANCE_DOMAIN,
        _ => SIZE_DOMAIN,
    }
}

/// How a mesh rock is integrated (`model`, docs/rocking-3d.md).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum RockModel {
    /// `"2d"` (the default): the planar body of each toppling direction (docs/meshes.md).
    #[default]
    Planar,
    /// `"3d"`: one rigid body driven by all three ground-motion components
    /// ([`crate::rocking3d`]).
    Rigid3d,
}

/// A `model` that is neither `"2d"` nor `"3d"`.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("model = {0:?}: expected \"2d\" or \"3d\"")]
pub struct UnknownRockModel(pub String);

impl RockModel {
    /// `"2d"` or `"3d"`, as written in a catalogue.
    pub fn parse(text: &str) -> Result<RockModel, UnknownRockModel> {
        match text.trim() {
            "2d" => Ok(RockModel::Planar),
            "3d" => Ok(RockModel::Rigid3d),
            other => Err(UnknownRockModel(other.to_owned())),
        }
    }

    /// The name written in a catalogue and in `fragility.json`.
    #[must_use]
    pub fn as_str(self) -> &'static str {
        match self {
            RockModel::Planar => "2d",
            RockModel::Rigid3d => "3d",
        }
    }
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
    pub(super) rock: RockGeometry,
    /// The resting contact at the nominal contact tolerance.
    pub(super) rest: RestingContact,
    /// The open scan's boundary loop closed by `cap = true` (None: the mesh was closed).
    pub cap: Option<crate::mesh::cap::Cap>,
    /// The rigid body of `model = "3d"` (None for the planar model).
    pub(super) body: Option<crate::rocking3d::RockBody>,
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

    /// The rigid body of a `model = "3d"` entry (body frame: the resting pose's east, north,
    /// up in the mesh's axes, i.e. for heading 0).
    #[must_use]
    pub fn body(&self) -> Option<&crate::rocking3d::RockBody> {
        self.body.as_ref()
    }

    /// One block per direction for a heading (degrees, the true azimuth of the mesh's north
    /// axis) and a contact tolerance (m): direction az is the mesh's azimuth az − heading.
    pub(super) fn blocks(
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
                self.rest
                    .direction_at(az.degrees() - heading_deg, tolerance_m)
                    .block(mu_s, mu_k, restitution)
            })
            .collect()
    }
}
