//! 3-D rigid-body rocking of a mesh rock on a rigid horizontal ground (issue 18 §2,
//! docs/rocking-3d.md).
//!
//! One rigid body (mass, centre of mass and inertia tensor of the closed mesh, the convex
//! hull's vertices as its contact shape) stands on its resting facet
//! ([`crate::mesh::contact::RestingContact`]) and is driven by the three components of the
//! ground acceleration. Coulomb friction (μs, μk), plastic impacts (no bounce, Coulomb
//! friction during the impact), gravity [`crate::STANDARD_GRAVITY_MPS2`].
//!
//! # Frames and signs
//! Everything is written in the **ground frame** G, which moves with the ground: X = east,
//! Y = north, Z = up (right-handed: east × north = up), origin on the ground surface below the
//! centre of mass at t = 0. The body feels gravity −g·Z and the inertial pseudo-force
//! m·(−a_g(t)) at its centre of mass, a_g = (a_E, a_N, a_U) the ground acceleration (m/s²,
//! positive east / north / up). The **body frame** is the ground frame of the rock at rest: body
//! vectors are (east, north, up) of the resting pose relative to the centre of mass, so the
//! initial rotation is the identity and the centre of mass starts at (0, 0, h).
//!
//! # Formulation
//! While the rock rests on its facet it is not integrated: [`rest::RestCondition`] decides in
//! closed form, per input sample, whether rest still holds (no lift-off about any support-
//! polygon edge, no slip). Otherwise a velocity-level complementarity time-stepper
//! ([`rock::Rock3d`]: Moreau–Jean with speculative gaps, [`solver`]: projected Gauss–Seidel
//! on the exact Coulomb cone over every hull vertex near the ground) advances the body.
//!
//! - [`body`]: the rigid body from a mesh;
//! - [`ground`]: three-component ground motion;
//! - [`rest`]: the closed-form rest test;
//! - [`solver`]: the contact impulses of one step;
//! - [`rock`]: the real-time stepper (one call per input interval);
//! - [`report`]: the rock in the planar outputs' terms (θ, θ/α, slide, direction, mode);
//! - [`simulate`]: a whole record, and the serialisable [`simulate::Summary3d`].
//!
//! Architecture invariants: no I/O, no allocation in [`rock::Rock3d::advance`], no threads,
//! no hash-map iteration: bit-identical results on every run and thread
//! (tests/rocking_3d.rs).

pub mod body;
pub mod ground;
pub mod report;
pub mod rest;
pub mod rock;
pub mod simulate;
pub mod solver;

pub use body::{BodyError, RockBody};
pub use ground::{GroundAccel3d, GroundMotion3d, MotionError};
pub use rest::RestCondition;
pub use rock::{Advance3dError, Mode3d, Rock3d, Rock3dOptions, Stats3d};
pub use simulate::{
    simulate_3d, simulate_3d_outcome, simulate_3d_traced, Outcome3d, Simulate3dError,
    Simulation3dOptions, Status3d, Summary3d, Trace3d,
};
