//! How a meshed rock rests, and the planar body ([`crate::dynamics::BlockParams::from_body`])
//! of each horizontal direction (docs/meshes.md).
//!
//! # Frames
//! The mesh is in metres. `up` ([`UpAxis`]) names the mesh axis that points roughly up; the
//! mesh's **north** and **east** axes follow from it by a fixed right-handed table
//! (east × north = up):
//!
//! | up   | east | north |
//! |------|------|-------|
//! | +z   | +x   | +y    |
//! | −z   | +x   | −y    |
//! | +y   | +z   | +x    |
//! | −y   | +z   | −x    |
//! | +x   | +y   | +z    |
//! | −x   | +y   | −z    |
//!
//! The rock rests on the **stable hull facet nearest to `up`**: among the planar facets of the
//! convex hull whose plane contains the centre of mass's projection strictly inside the facet
//! (by more than 10⁻⁹ of the mesh size), the one whose outward normal n is closest to −up.
//! The true vertical is then U = −n; north N is the mesh north axis projected on the facet's
//! plane (normalised), east E = N × U. An azimuth az (degrees clockwise from north) is the
//! horizontal direction d = E sin az + N cos az — the +x axis of the planar body and of the
//! ground acceleration a_x = a_E sin az + a_N cos az ([`crate::azimuth::Azimuth`]).
//!
//! # Contact patch and planar body
//! The **contact patch** is every mesh vertex within the contact tolerance of the facet's plane
//! (distance along n; default 0: the resting facet alone). Its vertices, projected on the
//! horizontal plane, span the convex **support polygon** P ([`SupportPolygon`]). For a
//! direction d, with c the centre of mass:
//! - `b_plus` = r(d), `b_minus` = r(−d): the distance from c's projection to the boundary of P
//!   along the ray from c towards ±d. It is the exact lever arm of the quasi-static uplift: the
//!   rock first lifts off under a horizontal pseudo-force m·a along d when a = g·r(d)/h, tipping
//!   about the edge of P that the ray crosses ([`super::support_polygon`] derives it). The
//!   extreme contact vertex along d, max_p (p − c)·d, overstates it unless that vertex lies on
//!   the ray;
//! - `h` = distance of c above the facet's plane;
//! - `rho` = √(I_a / m), I_a the moment of inertia about the horizontal axis a = U × d
//!   through c (perpendicular to the plane of motion), from the inertia tensor at unit density
//!   (m = volume); it does not depend on the density. It sets the planar body's inertia about
//!   its pivot, m(ρ² + b² + h²): the rotation about a pivot point at distance b along d. When
//!   the pivot edge is oblique to d the 3-D rock turns about that edge instead, whose moment of
//!   inertia differs; the planar model keeps the axis perpendicular to d (docs/meshes.md);
//! - `alpha±` = atan(b±/h).
//!
//! Approximations (docs/meshes.md): the patch's vertices are projected on the facet's plane
//! (their heights within the tolerance are ignored); the rock is rigid and its density
//! uniform; the planar model of each direction ignores motion out of that vertical plane.

use super::hull::{convex_hull, Facet};
use super::mass::MassProperties;
use super::support_polygon::SupportPolygon;
use super::{cross, dot, norm, normalize, scale3, sub, MeshError, TriMesh};
use crate::dynamics::{BlockParams, ParamError};

/// Default contact tolerance (m): 0, the resting hull facet alone. A wider patch moves the
/// pivots outwards (by factors of 2–8 on half-metre scanned specimens at 5 mm): an unsafe
/// overstatement of stability unless the ground really supports those vertices. `geometry`
/// prints the sensitivity ([`SENSITIVITY_TOLERANCES_M`]).
pub const DEFAULT_CONTACT_TOLERANCE_M: f64 = 0.0;

/// The contact tolerances (m) whose bodies `geometry` compares: 0, 1, 2 and 5 mm.
pub const SENSITIVITY_TOLERANCES_M: [f64; 4] = [0.0, 0.001, 0.002, 0.005];

/// Largest contact tolerance (m): 1 m.
pub const MAX_CONTACT_TOLERANCE_M: f64 = 1.0;

/// A signed mesh axis: the mesh's approximate up direction.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum UpAxis {
    PlusX,
    MinusX,
    PlusY,
    MinusY,
    PlusZ,
    MinusZ,
}

impl UpAxis {
    /// Parses `x`, `y`, `z`, optionally signed (`+z`, `-y`), any case.
    pub fn parse(text: &str) -> Result<UpAxis, DirectionError> {
        Ok(match text.trim().to_ascii_lowercase().as_str() {
            "x" | "+x" => UpAxis::PlusX,
            "-x" => UpAxis::MinusX,
            "y" | "+y" => UpAxis::PlusY,
            "-y" => UpAxis::MinusY,
            "z" | "+z" => UpAxis::PlusZ,
            "-z" => UpAxis::MinusZ,
            other => return Err(DirectionError::UpAxis(other.to_owned())),
        })
    }

    /// (up, east, north) unit vectors of the table in the module doc.
    #[must_use]
    pub fn frame(self) -> ([f64; 3], [f64; 3], [f64; 3]) {
        const X: [f64; 3] = [1.0, 0.0, 0.0];
        const Y: [f64; 3] = [0.0, 1.0, 0.0];
        const Z: [f64; 3] = [0.0, 0.0, 1.0];
        let neg = |v: [f64; 3]| scale3(v, -1.0);
        match self {
            UpAxis::PlusZ => (Z, X, Y),
            UpAxis::MinusZ => (neg(Z), X, neg(Y)),
            UpAxis::PlusY => (Y, Z, X),
            UpAxis::MinusY => (neg(Y), Z, neg(X)),
            UpAxis::PlusX => (X, Y, Z),
            UpAxis::MinusX => (neg(X), Y, neg(Z)),
        }
    }

    /// The axis as written by [`UpAxis::parse`]'s canonical form (`+z`, `-y`, …).
    #[must_use]
    pub fn as_str(self) -> &'static str {
        match self {
            UpAxis::PlusX => "+x",
            UpAxis::MinusX => "-x",
            UpAxis::PlusY => "+y",
            UpAxis::MinusY => "-y",
            UpAxis::PlusZ => "+z",
            UpAxis::MinusZ => "-z",
        }
    }
}

/// A meshed rock: its mass properties and convex hull (computed once; the contact depends on
/// the up axis and the tolerance, see [`RockGeometry::rest`]).
#[derive(Debug, Clone, PartialEq)]
pub struct RockGeometry {
    source: String,
    mass: MassProperties,
    facets: Vec<Facet>,
    vertices: Vec<[f64; 3]>,
    /// The mesh's triangles (outward), for sections.
    faces: Vec<[usize; 3]>,
    scale_m: f64,
}

/// The resting contact of a rock (see the module doc).
#[derive(Debug, Clone, PartialEq)]
pub struct RestingContact {
    /// True vertical (unit, mesh coordinates): −(outward normal of the resting facet).
    pub up: [f64; 3],
    /// Horizontal east and north (unit, mesh coordinates).
    pub east: [f64; 3],
    pub north: [f64; 3],
    /// Height of the centre of mass above the resting plane (m).
    pub h_m: f64,
    /// Angle between the given up axis and the true vertical (degrees).
    pub tilt_deg: f64,
    /// The contact tolerance used (m).
    pub tolerance_m: f64,
    /// Number of vertices of the resting facet's polygon.
    pub facet_vertices: usize,
    /// Unit-density mass properties of the rock.
    pub mass: MassProperties,
    /// The vertices within [`MAX_CONTACT_TOLERANCE_M`] of the resting plane, as (depth above
    /// the plane, east, north) relative to the centre of mass (m), by increasing depth: the
    /// patch of any tolerance is a prefix.
    near: Vec<(f64, f64, f64)>,
    /// Rounding allowance of the depth comparison (10⁻⁹ of the mesh size, m).
    margin_m: f64,
    /// The support polygon of the resting facet alone (tolerance 0).
    facet_polygon: SupportPolygon,
}

/// The planar body of one direction (module doc).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct DirectionBody {
    /// Direction, degrees clockwise from the mesh's north axis.
    pub azimuth_deg: f64,
    pub b_plus_m: f64,
    pub b_minus_m: f64,
    pub h_m: f64,
    pub rho_m: f64,
    pub alpha_plus_deg: f64,
    pub alpha_minus_deg: f64,
}

/// The weakest side of a rock's planar bodies, each given as (azimuth of its +x axis, α₊, α₋),
/// degrees: `(azimuth, α)` of the side with the smallest uplift angle — the +x side tips
/// towards the body's azimuth, the −x side towards the opposite one — the first such side on a
/// tie; `None` without a body. g·tan α is the rock's least quasi-static uplift acceleration
/// among those directions.
#[must_use]
pub fn weakest_side(bodies: impl IntoIterator<Item = (f64, f64, f64)>) -> Option<(f64, f64)> {
    let mut best: Option<(f64, f64)> = None;
    for (azimuth_deg, alpha_plus_deg, alpha_minus_deg) in bodies {
        for (alpha, towards) in [
            (alpha_plus_deg, azimuth_deg),
            (alpha_minus_deg, (azimuth_deg + 180.0).rem_euclid(360.0)),
        ] {
            if best.is_none_or(|(_, a)| alpha < a) {
                best = Some((towards, alpha));
            }
        }
    }
    best
}

impl DirectionBody {
    /// The planar block of this direction with its friction and impact
    /// ([`BlockParams::from_body`], docs/general-body.md).
    pub fn block(
        &self,
        mu_s: f64,
        mu_k: f64,
        restitution: Option<f64>,
    ) -> Result<BlockParams, ParamError> {
        BlockParams::from_body(
            self.b_plus_m,
            self.b_minus_m,
            self.h_m,
            self.rho_m,
            mu_s,
            mu_k,
            restitution,
        )
    }
}

impl RockGeometry {
    /// Mass properties and hull of a validated mesh.
    pub fn new(mesh: &TriMesh) -> Result<RockGeometry, MeshError> {
        let mass = MassProperties::of(mesh);
        let facets = convex_hull(&mesh.vertices).map_err(|e| MeshError::Degenerate {
            source_name: mesh.source.clone(),
            location: None,
            message: format!("convex hull: {e}"),
        })?;
        Ok(RockGeometry {
            source: mesh.source.clone(),
            mass,
            facets,
            vertices: mesh.vertices.clone(),
            faces: mesh.faces.clone(),
            scale_m: mesh.bounding_diagonal(),
        })
    }

    /// Reads, validates and analyses a mesh file.
    pub fn read(path: impl AsRef<std::path::Path>) -> Result<RockGeometry, MeshError> {
        RockGeometry::new(&TriMesh::read(path)?)
    }

    /// [`RockGeometry::read`], closing an open scan's lowest boundary loop along `cap` first
    /// when given ([`super::cap`]); says what was capped (`None`: the mesh was closed).
    pub fn read_with(
        path: impl AsRef<std::path::Path>,
        cap: Option<UpAxis>,
    ) -> Result<(RockGeometry, Option<super::cap::Cap>), MeshError> {
        let (mesh, capped) = TriMesh::read_with(path, cap.map(|up| up.frame().0))?;
        Ok((RockGeometry::new(&mesh)?, capped))
    }

    /// Unit-density mass properties.
    #[must_use]
    pub fn mass(&self) -> &MassProperties {
        &self.mass
    }

    /// The facets of the convex hull.
    #[must_use]
    pub fn facets(&self) -> &[Facet] {
        &self.facets
    }

    /// The vertices of the convex hull (mesh coordinates, m), each once, in increasing order
    /// of their mesh index: the contact shape of the 3-D dynamics ([`crate::rocking3d`]).
    #[must_use]
    pub fn hull_vertices(&self) -> Vec<[f64; 3]> {
        let mut indices: Vec<usize> = self
            .facets
            .iter()
            .flat_map(|f| f.polygon.iter().copied())
            .collect();
        indices.sort_unstable();
        indices.dedup();
        indices.into_iter().map(|i| self.vertices[i]).collect()
    }

    /// The rock's outline in the vertical plane of the direction `azimuth_deg` (degrees
    /// clockwise from north) through the centre of mass, resting on `rest`: one segment per
    /// mesh triangle the plane cuts, as ((s, z), (s, z)) with s the horizontal distance from
    /// the centre of mass along the direction and z the height above the resting plane (m).
    #[must_use]
    pub fn section(&self, rest: &RestingContact, azimuth_deg: f64) -> Vec<[(f64, f64); 2]> {
        let (sin, cos) = azimuth_deg.to_radians().sin_cos();
        let d = [
            rest.east[0] * sin + rest.north[0] * cos,
            rest.east[1] * sin + rest.north[1] * cos,
            rest.east[2] * sin + rest.north[2] * cos,
        ];
        let across = cross(rest.up, d);
        let c = self.mass.com_m;
        let local = |p: [f64; 3]| {
            let r = sub(p, c);
            (dot(r, d), dot(r, rest.up) + rest.h_m)
        };
        let mut segments = Vec::new();
        for face in &self.faces {
            let p = face.map(|i| self.vertices[i]);
            let side = p.map(|v| dot(sub(v, c), across));
            // The points where the plane cuts the edges whose ends lie on opposite sides (a
            // vertex on the plane counts on the + side, so each crossing is found once).
            let mut cuts = [(0.0, 0.0); 2];
            let mut n = 0;
            for k in 0..3 {
                let (a, b) = (k, (k + 1) % 3);
                if (side[a] >= 0.0) != (side[b] >= 0.0) && n < 2 {
                    let t = side[a] / (side[a] - side[b]);
                    let q = [
                        p[a][0] + t * (p[b][0] - p[a][0]),
                        p[a][1] + t * (p[b][1] - p[a][1]),
                        p[a][2] + t * (p[b][2] - p[a][2]),
                    ];
                    cuts[n] = local(q);
                    n += 1;
                }
            }
            if n == 2 {
                segments.push(cuts);
            }
        }
        segments
    }

    /// The mesh's triangles (outward) with the rock resting on `rest` and turned to
    /// `heading_deg` (the true azimuth of the mesh's north axis, degrees clockwise from north):
    /// each vertex as (east, north, up) in m from the point of the resting plane below the
    /// centre of mass — the rock at rest in a local ENU frame, for display.
    #[must_use]
    pub fn triangles_at_rest(&self, rest: &RestingContact, heading_deg: f64) -> Vec<[[f64; 3]; 3]> {
        let (sin_h, cos_h) = heading_deg.to_radians().sin_cos();
        let c = self.mass.com_m;
        let local = |p: [f64; 3]| {
            let r = sub(p, c);
            let (e, n) = (dot(r, rest.east), dot(r, rest.north));
            [
                e * cos_h + n * sin_h,
                n * cos_h - e * sin_h,
                dot(r, rest.up) + rest.h_m,
            ]
        };
        self.faces
            .iter()
            .map(|face| face.map(|i| local(self.vertices[i])))
            .collect()
    }

    /// The resting contact for the approximate up axis `up` and the contact tolerance
    /// `tolerance_m` (m, finite, ≥ 0).
    pub fn rest(&self, up: UpAxis, tolerance_m: f64) -> Result<RestingContact, MeshError> {
        let fail = |message: String| MeshError::Contact {
            source_name: self.source.clone(),
            message,
        };
        if !(0.0..=MAX_CONTACT_TOLERANCE_M).contains(&tolerance_m) {
            return Err(fail(format!(
                "contact tolerance {tolerance_m} m must be in [0, {MAX_CONTACT_TOLERANCE_M}] m"
            )));
        }
        let (up0, _, north0) = up.frame();
        let c = self.mass.com_m;
        let margin = 1e-9 * self.scale_m;
        let mut best: Option<(f64, &Facet)> = None;
        for facet in &self.facets {
            if !self.com_projects_inside(facet, margin) {
                continue;
            }
            let alignment = -dot(facet.normal, up0);
            if best.is_none_or(|(a, _)| alignment > a) {
                best = Some((alignment, facet));
            }
        }
        let Some((alignment, facet)) = best else {
            return Err(fail(
                "no facet of the convex hull has the centre of mass strictly above it: the \
                 body cannot rest (numerically degenerate mesh?)"
                    .into(),
            ));
        };
        let u = scale3(facet.normal, -1.0);
        let n_proj = sub(north0, scale3(u, dot(north0, u)));
        if norm(n_proj) < 1e-6 {
            return Err(fail(format!(
                "the resting facet is perpendicular to the mesh's north axis for up {}: choose \
                 the up axis the rock stands on",
                up.as_str()
            )));
        }
        let north = normalize(n_proj);
        let east = cross(north, u);
        let h_m = facet.offset - dot(facet.normal, c);
        let mut near: Vec<(f64, f64, f64)> = self
            .vertices
            .iter()
            .filter_map(|v| {
                let depth = facet.offset - dot(facet.normal, *v);
                (depth <= MAX_CONTACT_TOLERANCE_M + margin).then(|| {
                    let r = sub(*v, c);
                    (depth, dot(r, east), dot(r, north))
                })
            })
            .collect();
        near.sort_by(|a, b| a.0.total_cmp(&b.0));
        let on_facet = near.partition_point(|p| p.0 <= margin);
        let facet_polygon =
            SupportPolygon::hull_of(near[..on_facet].iter().map(|p| (p.1, p.2)), 0.0)
                .map_err(|e| fail(format!("support polygon of the resting facet: {e}")))?;
        Ok(RestingContact {
            up: u,
            east,
            north,
            h_m,
            tilt_deg: alignment.clamp(-1.0, 1.0).acos().to_degrees(),
            tolerance_m,
            facet_vertices: facet.polygon.len(),
            mass: self.mass,
            near,
            margin_m: margin,
            facet_polygon,
        })
    }

    /// Whether c, projected along the facet's normal, is inside its polygon by more than
    /// `margin` from every edge.
    fn com_projects_inside(&self, facet: &Facet, margin: f64) -> bool {
        let c = self.mass.com_m;
        let m = facet.polygon.len();
        if m < 3 {
            return false;
        }
        (0..m).all(|k| {
            let a = self.vertices[facet.polygon[k]];
            let b = self.vertices[facet.polygon[(k + 1) % m]];
            // Inward edge normal in the facet plane: n × (b − a) for a CCW polygon.
            let edge = sub(b, a);
            let inward = cross(facet.normal, edge);
            let len = norm(inward);
            len > 0.0 && dot(sub(c, a), inward) / len > margin
        })
    }
}

impl RestingContact {
    /// The contact patch at the tolerance `tolerance_m` (clamped to [0,
    /// [`MAX_CONTACT_TOLERANCE_M`]]): (depth above the resting plane, east, north) of each
    /// vertex relative to the centre of mass (m). Never empty: the resting facet's vertices
    /// are at depth 0.
    #[must_use]
    pub fn patch(&self, tolerance_m: f64) -> &[(f64, f64, f64)] {
        let tolerance_m = if tolerance_m.is_nan() {
            0.0
        } else {
            tolerance_m
        };
        let limit = tolerance_m.clamp(0.0, MAX_CONTACT_TOLERANCE_M) + self.margin_m;
        let n = self.near.partition_point(|p| p.0 <= limit);
        &self.near[..n]
    }

    /// The contact patch at the contact's own tolerance ([`RestingContact::patch`]).
    #[must_use]
    pub fn contact_vertices(&self) -> usize {
        self.patch(self.tolerance_m).len()
    }

    /// The planar body of the direction `azimuth_deg` (degrees clockwise from the mesh's
    /// north axis; any finite value, taken modulo 360) at the contact's tolerance.
    #[must_use]
    pub fn direction(&self, azimuth_deg: f64) -> DirectionBody {
        self.direction_at(azimuth_deg, self.tolerance_m)
    }

    /// The support polygon of the contact patch at the tolerance `tolerance_m` (m, clamped as
    /// in [`RestingContact::patch`]): the convex hull of the patch projected on the horizontal
    /// plane, (east, north) relative to the centre of mass.
    #[must_use]
    pub fn support_polygon(&self, tolerance_m: f64) -> SupportPolygon {
        let patch = self.patch(tolerance_m);
        if patch.len() == self.patch(0.0).len() {
            return self.facet_polygon.clone();
        }
        // The patch contains the resting facet, so its hull contains the facet's polygon and
        // the centre of mass strictly inside: this cannot fail, and if rounding ever made it,
        // the facet's polygon (a subset: smaller lever arms, the safe side) stands in.
        SupportPolygon::hull_of(patch.iter().map(|p| (p.1, p.2)), 0.0)
            .unwrap_or_else(|_| self.facet_polygon.clone())
    }

    /// The planar body of the direction `azimuth_deg` with the contact patch of another
    /// tolerance (m; the resting facet and frame do not depend on it).
    #[must_use]
    pub fn direction_at(&self, azimuth_deg: f64, tolerance_m: f64) -> DirectionBody {
        self.body(&self.support_polygon(tolerance_m), azimuth_deg)
    }

    /// The planar body of the direction `azimuth_deg` (degrees clockwise from north) on a
    /// support polygon of this contact ([`RestingContact::support_polygon`]): b± = r(±d).
    #[must_use]
    pub fn body(&self, polygon: &SupportPolygon, azimuth_deg: f64) -> DirectionBody {
        let (s, co) = azimuth_deg.to_radians().sin_cos();
        let b_plus = polygon.exit_distance(s, co);
        let b_minus = polygon.exit_distance(-s, -co);
        let d = [
            self.east[0] * s + self.north[0] * co,
            self.east[1] * s + self.north[1] * co,
            self.east[2] * s + self.north[2] * co,
        ];
        let axis = cross(self.up, d);
        let rho_m = (self.mass.moment_about(axis) / self.mass.volume_m3).sqrt();
        DirectionBody {
            azimuth_deg,
            b_plus_m: b_plus,
            b_minus_m: b_minus,
            h_m: self.h_m,
            rho_m,
            alpha_plus_deg: (b_plus / self.h_m).atan().to_degrees(),
            alpha_minus_deg: (b_minus / self.h_m).atan().to_degrees(),
        }
    }
}

/// Parses an azimuth list: `A:B:STEP` (from A up to but excluding B, B − A ≤ 360, STEP > 0,
/// at most 3600 directions) or a comma-separated list `0,90,180`. Degrees.
pub fn parse_azimuths(text: &str) -> Result<Vec<f64>, DirectionError> {
    let number = |w: &str| -> Result<f64, DirectionError> {
        let v: f64 = w
            .trim()
            .parse()
            .map_err(|_| DirectionError::NotANumber(w.to_owned()))?;
        if v.is_finite() {
            Ok(v)
        } else {
            Err(DirectionError::NotFinite(w.to_owned()))
        }
    };
    let parts: Vec<&str> = text.split(':').collect();
    match parts.as_slice() {
        [from, to, step] => azimuth_steps(number(from)?, number(to)?, number(step)?),
        [_] => {
            let list = text
                .split(',')
                .map(number)
                .collect::<Result<Vec<f64>, DirectionError>>()?;
            if list.is_empty() || list.len() > MAX_AZIMUTHS {
                return Err(DirectionError::Count(list.len()));
            }
            Ok(list)
        }
        _ => Err(DirectionError::Form(text.to_owned())),
    }
}

/// Most directions of one rock.
pub const MAX_AZIMUTHS: usize = 3600;

/// Why an up axis or an azimuth list (degrees) was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum DirectionError {
    #[error("up axis {0:?}: expected x, y or z, optionally signed (+z, -y)")]
    UpAxis(String),
    #[error("azimuth {0:?} is not a number")]
    NotANumber(String),
    #[error("azimuth {0:?} is not finite")]
    NotFinite(String),
    #[error("{0} azimuths: give 1 to {MAX_AZIMUTHS} azimuths")]
    Count(usize),
    #[error("azimuths {0:?}: give FROM:TO:STEP (degrees, TO excluded) or a list A,B,C")]
    Form(String),
    #[error("azimuth step {0} must be > 0")]
    Step(f64),
    #[error("azimuth range {0}:{1} must have FROM < TO ≤ FROM + 360")]
    Range(f64, f64),
    #[error("{} azimuths from {from}:{to}:{step}, more than {MAX_AZIMUTHS}", ((to - from) / step - 1e-9).ceil())]
    TooMany { from: f64, to: f64, step: f64 },
}

/// The azimuths `from`, `from + step`, … below `to` (degrees; `to − from` in (0, 360],
/// `step > 0`, at most [`MAX_AZIMUTHS`]).
pub fn azimuth_steps(from: f64, to: f64, step: f64) -> Result<Vec<f64>, DirectionError> {
    if !(step > 0.0 && step.is_finite()) {
        return Err(DirectionError::Step(step));
    }
    if !(to > from && to - from <= 360.0) {
        return Err(DirectionError::Range(from, to));
    }
    let n = ((to - from) / step - 1e-9).ceil().max(1.0);
    if n > MAX_AZIMUTHS as f64 {
        return Err(DirectionError::TooMany { from, to, step });
    }
    Ok((0..n as usize).map(|k| from + k as f64 * step).collect())
}
