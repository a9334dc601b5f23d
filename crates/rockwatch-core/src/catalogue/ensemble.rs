//! The ensembles of an entry: [`Pbr::members`] (K blocks of a Latin hypercube over the
//! uncertain parameters) and [`Pbr::directions`] (every toppling direction of a meshed rock,
//! the same member i in each), seeded by `seed` or [`default_seed`] of the id.
//!
//! Column order: the geometry form's fields, then μs, μk, e (fixed ones skipped); each column
//! is mapped through its parameter's quantile function ([`Distribution`], truncated to the
//! parameter's domain). A member whose drawn μk exceeds its drawn μs gets μk = μs. Units are
//! those of the parameters (m, degrees, dimensionless).

use super::distribution::{Distribution, Domain, MU_K_DOMAIN, MU_S_DOMAIN, RESTITUTION_DOMAIN};
use super::geometry::{domain_of, MeshRock};
use super::pbr::Pbr;
use crate::azimuth::Azimuth;
use crate::dynamics::{BlockParams, ParamError};
use crate::lhs::latin_hypercube_seeded;

/// The default LHS seed of an entry without `seed`: the 64-bit FNV-1a hash of the UTF-8 bytes
/// of its `id` (offset basis 0xcbf29ce484222325, prime 0x100000001b3, xor then multiply).
/// Stable across platforms and versions, and different ids give unrelated ensembles.
#[must_use]
pub fn default_seed(id: &str) -> u64 {
    crate::partition::fnv1a64(id.as_bytes())
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

/// One rock of a `model = "3d"` entry: the parameters that vary between its members (the
/// body is the mesh's).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RigidMember {
    /// True azimuth of the mesh's north axis (degrees clockwise from north).
    pub heading_deg: f64,
    /// Static and kinetic friction coefficients (μk ≤ μs).
    pub mu_s: f64,
    pub mu_k: f64,
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

    /// The nominal rock and, for K = `ensemble` > 1, the K members of a `model = "3d"` entry
    /// (the same Latin hypercube as [`Pbr::directions_sized`]: member i is the same draw of
    /// heading, μs and μk); None for an entry integrated as planar bodies.
    #[must_use]
    pub fn rigid_members(&self, ensemble: usize) -> Option<(RigidMember, Vec<RigidMember>)> {
        self.mesh.as_ref()?.body()?;
        // Columns: heading, contact tolerance (not used in 3-D), μs, μk, e (refused in 3-D).
        let member = |values: &[f64]| RigidMember {
            heading_deg: values[0],
            mu_s: values[2],
            mu_k: values[3].min(values[2]),
        };
        let nominal_values: Vec<f64> = self
            .sampled_parameters()
            .iter()
            .map(|p| p.map_or(f64::NAN, |(d, _)| d.nominal()))
            .collect();
        let members = if ensemble > 1 {
            self.member_values(ensemble)
                .iter()
                .map(|v| member(v))
                .collect()
        } else {
            Vec::new()
        };
        Some((member(&nominal_values), members))
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
            id: self.id.to_string(),
            member,
            reason,
        })
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
                    id: self.id.to_string(),
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
}
