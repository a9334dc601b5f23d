//! Planar rigid-body dynamics (spec: shared/spec/block-dynamics.md, generalised in
//! docs/general-body.md): a body with a flat base between two pivots (a rectangular block or
//! a real rock's measured section) that rests, slides, rocks, slide-rocks, overturns or lifts
//! off under horizontal and vertical ground acceleration.
//!
//! - [`params`]: geometry and friction, validated;
//! - [`equations`]: the equations of motion and contact forces as pure functions;
//! - [`impact`]: the impact map of §9.1;
//! - [`block`]: the real-time stepper [`RigidBlock`] (modes, events, transitions).
//!
//! Architecture invariant: this module does no I/O and never allocates in
//! [`RigidBlock::advance`].

pub mod block;
pub mod equations;
pub mod impact;
pub mod params;

pub use block::{
    AdvanceError, BlockEvent, BlockOptions, Mode, ResponseStats, RestLimit, RigidBlock,
};
pub use equations::GroundAccel;
pub use impact::ImpactKind;
pub use params::{BlockParams, ParamError, PivotSide};
