//! WGS84 geodetic positions in a local east-north-up (ENU) frame, and the pose of a rocking
//! block in that frame: what a 3-D view of the rocks (the ROS 2 markers and transforms) needs.
//!
//! **Projection.** A local tangent plane: geodetic (φ, λ, h) on the WGS84 ellipsoid
//! (a = 6 378 137 m, f = 1/298.257 223 563) → ECEF
//! `X = (N + h) cos φ cos λ`, `Y = (N + h) cos φ sin λ`, `Z = (N (1 − e²) + h) sin φ` with
//! `N = a / √(1 − e² sin² φ)`, then the ECEF offset from the origin rotated into the
//! origin's east, north, up axes:
//! `e = −sin λ₀ dX + cos λ₀ dY`,
//! `n = −sin φ₀ cos λ₀ dX − sin φ₀ sin λ₀ dY + cos φ₀ dZ`,
//! `u = cos φ₀ cos λ₀ dX + cos φ₀ sin λ₀ dY + sin φ₀ dZ`.
//! It is exact (a rigid rotation of ECEF, no flattening of the map): a point on the ellipsoid
//! away from the origin lies below the plane (u ≈ −d²/2R, 8 cm at 1 km). Axes as REP 103's ENU:
//! x east, y north, z up, metres.
//!
//! **Tilt.** A block's rocking angle θ (rad) is a rotation about the horizontal axis
//! perpendicular to its direction (azimuth az of its +x axis): θ > 0 tips it towards +x about
//! its +x pivot (spec/block-dynamics.md §1, `PbrState.theta`). In ENU, with
//! `d = (sin az, cos az, 0)` the direction, the rotation is by +θ (right hand) about
//! `z × d = (−cos az, sin az, 0)`, which turns up (z) towards d. The pivot is the base corner
//! at `+b₊ d` (θ > 0) or `−b₋ d` (θ < 0) from the point of the ground below the centre of
//! mass at rest, shifted by the slide u along d ([`RockingPose`]).

use nalgebra::{Unit, UnitQuaternion, Vector3};

/// WGS84 semi-major axis (m).
pub const WGS84_A_M: f64 = 6_378_137.0;
/// WGS84 flattening.
pub const WGS84_F: f64 = 1.0 / 298.257_223_563;

/// WGS84 first eccentricity squared, e² = f (2 − f).
const E2: f64 = WGS84_F * (2.0 - WGS84_F);

/// A geodetic position out of range.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum GeodesyError {
    #[error("latitude {0}° is not in [-90, 90]")]
    Latitude(f64),
    #[error("longitude {0}° is not in [-180, 180]")]
    Longitude(f64),
    #[error("altitude {0} m is not a finite number of metres in [-11000, 100000]")]
    Altitude(f64),
}

/// A WGS84 position: latitude and longitude (degrees, north and east positive), height above
/// the ellipsoid (m).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Geodetic {
    pub lat_deg: f64,
    pub lon_deg: f64,
    pub alt_m: f64,
}

impl Geodetic {
    /// A checked position: latitude in [−90, 90], longitude in [−180, 180], altitude finite
    /// within [−11 000, 100 000] m (the Mariana trench to the Kármán line).
    pub fn new(lat_deg: f64, lon_deg: f64, alt_m: f64) -> Result<Geodetic, GeodesyError> {
        if !(lat_deg.is_finite() && (-90.0..=90.0).contains(&lat_deg)) {
            return Err(GeodesyError::Latitude(lat_deg));
        }
        if !(lon_deg.is_finite() && (-180.0..=180.0).contains(&lon_deg)) {
            return Err(GeodesyError::Longitude(lon_deg));
        }
        if !(alt_m.is_finite() && (-11_000.0..=100_000.0).contains(&alt_m)) {
            return Err(GeodesyError::Altitude(alt_m));
        }
        Ok(Geodetic {
            lat_deg,
            lon_deg,
            alt_m,
        })
    }

    /// Earth-centred, Earth-fixed coordinates (m).
    #[must_use]
    pub fn ecef(&self) -> [f64; 3] {
        let (sin_phi, cos_phi) = self.lat_deg.to_radians().sin_cos();
        let (sin_lambda, cos_lambda) = self.lon_deg.to_radians().sin_cos();
        let n = WGS84_A_M / (1.0 - E2 * sin_phi * sin_phi).sqrt();
        [
            (n + self.alt_m) * cos_phi * cos_lambda,
            (n + self.alt_m) * cos_phi * sin_lambda,
            (n * (1.0 - E2) + self.alt_m) * sin_phi,
        ]
    }
}

/// The local tangent plane at an origin: ENU coordinates of geodetic positions (module doc).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LocalEnu {
    origin: Geodetic,
    origin_ecef: [f64; 3],
    /// Rows: east, north, up unit vectors in ECEF.
    axes: [[f64; 3]; 3],
}

impl LocalEnu {
    /// The frame whose origin is `origin`.
    #[must_use]
    pub fn new(origin: Geodetic) -> LocalEnu {
        let (sp, cp) = origin.lat_deg.to_radians().sin_cos();
        let (sl, cl) = origin.lon_deg.to_radians().sin_cos();
        LocalEnu {
            origin,
            origin_ecef: origin.ecef(),
            axes: [
                [-sl, cl, 0.0],
                [-sp * cl, -sp * sl, cp],
                [cp * cl, cp * sl, sp],
            ],
        }
    }

    /// The origin.
    #[must_use]
    pub fn origin(&self) -> Geodetic {
        self.origin
    }

    /// East, north, up (m) of `p` from the origin.
    #[must_use]
    pub fn enu(&self, p: &Geodetic) -> [f64; 3] {
        let x = p.ecef();
        let d = [
            x[0] - self.origin_ecef[0],
            x[1] - self.origin_ecef[1],
            x[2] - self.origin_ecef[2],
        ];
        self.axes
            .map(|row| row[0] * d[0] + row[1] * d[1] + row[2] * d[2])
    }
}

/// The pose of a rocking block relative to its rest pose, in ENU axes (module doc): a point
/// `p` of the block at rest (m, from the ground point below its centre of mass) is at
/// `rotation · p + translation` now.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RockingPose {
    /// m, ENU.
    pub translation: [f64; 3],
    /// Unit quaternion (x, y, z, w), ENU.
    pub rotation_xyzw: [f64; 4],
}

impl RockingPose {
    /// The pose of a block whose direction is `azimuth_deg` (degrees clockwise from north),
    /// tilted by `theta_rad` about the pivot `+b_plus_m` (θ > 0) or `−b_minus_m` (θ < 0)
    /// along it (m, from the ground point below the centre of mass), after sliding `slide_m`
    /// along it. Non-finite inputs give the rest pose (identity).
    #[must_use]
    pub fn new(
        azimuth_deg: f64,
        theta_rad: f64,
        b_plus_m: f64,
        b_minus_m: f64,
        slide_m: f64,
    ) -> RockingPose {
        let finite = [azimuth_deg, theta_rad, b_plus_m, b_minus_m, slide_m]
            .iter()
            .all(|v| v.is_finite());
        if !finite {
            return RockingPose {
                translation: [0.0; 3],
                rotation_xyzw: [0.0, 0.0, 0.0, 1.0],
            };
        }
        let (sin_az, cos_az) = azimuth_deg.to_radians().sin_cos();
        let d = Vector3::new(sin_az, cos_az, 0.0);
        let axis = Unit::new_normalize(Vector3::z().cross(&d));
        let q = UnitQuaternion::from_axis_angle(&axis, theta_rad);
        let pivot = if theta_rad >= 0.0 {
            d * b_plus_m
        } else {
            -d * b_minus_m
        };
        let t = d * slide_m + pivot - q * pivot;
        RockingPose {
            translation: [t.x, t.y, t.z],
            rotation_xyzw: [q.i, q.j, q.k, q.w],
        }
    }

    /// `p` (m, ENU, block at rest) moved by the pose.
    #[must_use]
    pub fn apply(&self, p: [f64; 3]) -> [f64; 3] {
        let [x, y, z, w] = self.rotation_xyzw;
        let q = UnitQuaternion::new_unchecked(nalgebra::Quaternion::new(w, x, y, z));
        let r = q * Vector3::from(p) + Vector3::from(self.translation);
        [r.x, r.y, r.z]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: [f64; 3], b: [f64; 3], tol: f64) -> bool {
        a.iter().zip(b).all(|(x, y)| (x - y).abs() <= tol)
    }

    #[test]
    fn ecef_matches_the_closed_forms_on_the_equator_and_at_the_poles() {
        let b = WGS84_A_M * (1.0 - WGS84_F); // semi-minor axis
        let at = |lat, lon, alt| Geodetic::new(lat, lon, alt).unwrap().ecef();
        assert!(close(at(0.0, 0.0, 0.0), [WGS84_A_M, 0.0, 0.0], 1e-6));
        assert!(close(
            at(0.0, 90.0, 10.0),
            [0.0, WGS84_A_M + 10.0, 0.0],
            1e-6
        ));
        assert!(close(at(90.0, 0.0, 0.0), [0.0, 0.0, b], 1e-6));
        assert!(close(at(-90.0, 45.0, 5.0), [0.0, 0.0, -b - 5.0], 1e-6));
        // At 45°: the point lies on the ellipse x²/a² + z²/b² = 1 (meridian section).
        let [x, _, z] = at(45.0, 0.0, 0.0);
        assert!((x * x / (WGS84_A_M * WGS84_A_M) + z * z / (b * b) - 1.0).abs() < 1e-12);
        // ... and its normal (the geodetic latitude) is 45°: tan φ = (a²/b²) z / x.
        let phi = (WGS84_A_M * WGS84_A_M / (b * b) * z / x)
            .atan()
            .to_degrees();
        assert!((phi - 45.0).abs() < 1e-12, "{phi}");
    }

    #[test]
    fn enu_matches_the_closed_forms_of_the_equator_and_the_vertical() {
        // On the equator, a point Δλ east: e = a sin Δλ, n = 0, u = a (cos Δλ − 1).
        let frame = LocalEnu::new(Geodetic::new(0.0, 10.0, 0.0).unwrap());
        for dl in [1e-5_f64, 0.01, 1.0, 30.0] {
            let p = Geodetic::new(0.0, 10.0 + dl, 0.0).unwrap();
            let want = [
                WGS84_A_M * dl.to_radians().sin(),
                0.0,
                WGS84_A_M * (dl.to_radians().cos() - 1.0),
            ];
            assert!(
                close(frame.enu(&p), want, 1e-6),
                "{dl}: {:?}",
                frame.enu(&p)
            );
        }
        // Straight up anywhere: (0, 0, Δh); the origin itself: 0.
        for (lat, lon) in [(34.28, -118.48), (-60.0, 170.0), (89.9, 0.0)] {
            let frame = LocalEnu::new(Geodetic::new(lat, lon, 250.0).unwrap());
            let up = frame.enu(&Geodetic::new(lat, lon, 1250.0).unwrap());
            assert!(close(up, [0.0, 0.0, 1000.0], 1e-6), "{up:?}");
            let o = frame.enu(&Geodetic::new(lat, lon, 250.0).unwrap());
            assert!(close(o, [0.0; 3], 1e-9), "{o:?}");
        }
    }

    #[test]
    fn a_small_step_north_and_east_is_the_arc_on_the_meridian_and_the_parallel() {
        // Radii of curvature: meridian M = a(1−e²)/(1−e² sin²φ)^{3/2}, prime vertical
        // N = a/(1−e² sin²φ)^{1/2}; a step of 1e-4 rad is M·Δφ north, N cos φ·Δλ east (to
        // the arc's second order: under 1 mm at 600 m).
        let phi: f64 = 34.28;
        let s2 = phi.to_radians().sin().powi(2);
        let m = WGS84_A_M * (1.0 - E2) / (1.0 - E2 * s2).powf(1.5);
        let n = WGS84_A_M / (1.0 - E2 * s2).sqrt();
        let frame = LocalEnu::new(Geodetic::new(phi, -118.48, 0.0).unwrap());
        let step = 1e-4_f64.to_degrees();
        let north = frame.enu(&Geodetic::new(phi + step, -118.48, 0.0).unwrap());
        assert!(
            (north[1] - m * 1e-4).abs() < 1e-3,
            "{north:?} vs {}",
            m * 1e-4
        );
        assert!(north[0].abs() < 1e-9, "{north:?}");
        let east = frame.enu(&Geodetic::new(phi, -118.48 + step, 0.0).unwrap());
        let want = n * phi.to_radians().cos() * 1e-4;
        assert!((east[0] - want).abs() < 1e-3, "{east:?} vs {want}");
        // Below the plane by ≈ d²/2R.
        assert!(east[2] < 0.0 && north[2] < 0.0);
    }

    #[test]
    fn enu_is_a_rigid_rotation_of_ecef() {
        let frame = LocalEnu::new(Geodetic::new(34.28, -118.48, 300.0).unwrap());
        let p = Geodetic::new(34.4, -118.2, 1500.0).unwrap();
        let (a, b) = (frame.origin().ecef(), p.ecef());
        let chord = ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt();
        let e = frame.enu(&p);
        let norm = (e[0] * e[0] + e[1] * e[1] + e[2] * e[2]).sqrt();
        assert!((norm - chord).abs() < 1e-6, "{norm} vs {chord}");
    }

    #[test]
    fn positions_out_of_range_are_refused() {
        assert_eq!(
            Geodetic::new(91.0, 0.0, 0.0),
            Err(GeodesyError::Latitude(91.0))
        );
        assert!(Geodetic::new(0.0, -180.5, 0.0).is_err());
        assert!(Geodetic::new(0.0, 0.0, f64::NAN).is_err());
        assert!(Geodetic::new(f64::INFINITY, 0.0, 0.0).is_err());
    }

    /// The tilted block against spec/block-dynamics.md §1: the centroid relative to the pivot
    /// is `(−σR sin φ, R cos φ)` in (x along the direction, up), φ = α − |θ|, for a
    /// rectangle of half-width b and centroid height h (R = √(b²+h²), tan α = b/h).
    #[test]
    fn a_tilted_block_s_centroid_is_where_the_planar_kinematics_put_it() {
        let (b, h): (f64, f64) = (0.15, 0.75);
        let (r, alpha) = ((b * b + h * h).sqrt(), (b / h).atan());
        for az in [0.0_f64, 90.0, 228.0, 315.0] {
            let d = [az.to_radians().sin(), az.to_radians().cos(), 0.0];
            for theta in [0.3_f64, -0.2, alpha, -1.4, std::f64::consts::FRAC_PI_2] {
                let slide = 0.02;
                let pose = RockingPose::new(az, theta, b, b, slide);
                let c = pose.apply([0.0, 0.0, h]);
                let sigma = theta.signum();
                let phi = alpha - theta.abs();
                // Pivot on the ground at σb + u along the direction.
                let pivot_x = sigma * b + slide;
                let want_x = pivot_x - sigma * r * phi.sin();
                let want = [want_x * d[0], want_x * d[1], r * phi.cos()];
                assert!(
                    close(c, want, 1e-12),
                    "az {az} θ {theta}: {c:?} vs {want:?}"
                );
                // The pivot stays on the ground where it was.
                let p = pose.apply([sigma * b * d[0], sigma * b * d[1], 0.0]);
                assert!(
                    close(p, [pivot_x * d[0], pivot_x * d[1], 0.0], 1e-12),
                    "{p:?}"
                );
                // The horizontal axis across the direction does not move (rotation axis).
                let across = [-d[1], d[0], 0.0];
                let moved = RockingPose::new(az, theta, b, b, 0.0);
                let a = moved.apply([
                    across[0] + sigma * b * d[0],
                    across[1] + sigma * b * d[1],
                    0.0,
                ]);
                assert!(
                    close(
                        a,
                        [
                            across[0] + sigma * b * d[0],
                            across[1] + sigma * b * d[1],
                            0.0
                        ],
                        1e-12
                    ),
                    "{a:?}"
                );
            }
        }
        // θ > 0 tips the top towards +x (the direction): east for azimuth 90°.
        let top = RockingPose::new(90.0, 0.5, b, b, 0.0).apply([0.0, 0.0, 2.0 * h]);
        assert!(top[0] > b && top[1].abs() < 1e-12, "{top:?}");
        let q = RockingPose::new(f64::NAN, 0.5, b, b, 0.0);
        assert_eq!(q.rotation_xyzw, [0.0, 0.0, 0.0, 1.0]);
    }
}
