//! A 3-D rock described in the terms of the planar outputs (states, alerts, traces, plots):
//! one place for what θ, θ/α, the slide, the direction and the mode mean in 3-D, used by the
//! engine (`engine::rigid_rock`) and by the traces of `simulate --model 3d`.
//!
//! - θ: the tilt (rad, ≥ 0), the angle between the body's up axis at rest and the vertical;
//! - θ/α: the tilt over the uplift angle α(d) = atan(r(d)/h) of the direction d it tilts
//!   towards (≥ 0; 1 = the centre of mass above the support polygon's edge); at rest, 0;
//! - the direction: the azimuth d towards which the top leans (degrees clockwise from the
//!   mesh's north axis, [0, 360)); at rest, the weakest direction (the support polygon's
//!   nearest edge);
//! - the slide: the horizontal displacement over the ground of the base point below the
//!   centre of mass at rest (m): the slip of the rock's foot, which pure rocking about an edge
//!   barely moves (r·(1 − cos θ)), unlike the centre of mass (h·sin θ);
//! - the mode: `rest`, `overturned`, and while moving `rock` when tilted by more than
//!   [`TILT_ROCKING_RAD`], else `slide` (slide-rock is reported as rock; a flight is modelled,
//!   not reported).

use nalgebra::Vector3;

use super::rock::{Mode3d, Rock3d};
use crate::dynamics::Mode;

/// A moving rock tilted by more than this (rad) is reported as rocking, else as sliding.
pub const TILT_ROCKING_RAD: f64 = 1e-6;

/// A rock's pose in the planar outputs' terms (module doc; [`Rock3d::planar_view`] gives the
/// direction in the mesh's frame, the engine turns it to a true azimuth).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlanarView {
    pub mode: Mode,
    /// Tilt (rad, ≥ 0).
    pub theta_rad: f64,
    /// Tilt / α(d) (≥ 0).
    pub theta_over_alpha: f64,
    /// Slip of the foot (m).
    pub slide_m: f64,
    /// Azimuth the top leans towards, or the weakest one at rest (degrees, [0, 360)).
    pub direction_deg: f64,
}

impl Rock3d {
    /// The rock's pose in the planar outputs' terms (module doc).
    #[must_use]
    pub fn planar_view(&self) -> PlanarView {
        let (tilt, azimuth) = self.tilt();
        let body = self.body();
        let (direction_deg, alpha) = if tilt > 0.0 {
            let (s, c) = azimuth.to_radians().sin_cos();
            (azimuth, body.alpha_towards(s, c))
        } else {
            body.weakest_direction()
        };
        let mode = match self.mode() {
            Mode3d::Rest => Mode::Rest,
            Mode3d::Overturned => Mode::Overturned,
            Mode3d::Moving if tilt > TILT_ROCKING_RAD => Mode::Rock,
            Mode3d::Moving => Mode::Slide,
        };
        PlanarView {
            mode,
            theta_rad: tilt,
            theta_over_alpha: if alpha > 0.0 { tilt / alpha } else { 0.0 },
            slide_m: self.foot_slide_m(),
            direction_deg,
        }
    }

    /// Horizontal displacement (m) of the base point below the centre of mass at rest.
    #[must_use]
    pub fn foot_slide_m(&self) -> f64 {
        let foot: Vector3<f64> =
            self.position() + self.rotation() * Vector3::new(0.0, 0.0, -self.body().h_m());
        foot.x.hypot(foot.y)
    }
}
