//! Horizontal directions given as azimuths, and the rotations between east/north components
//! and components along such directions.
//!
//! Conventions (used by the catalogue, the engine, the MiniSEED records and the replay):
//! - An azimuth is measured in degrees **clockwise from north**: 0° = north, 90° = east,
//!   180° = south, 270° = west.
//! - East components are positive towards east, north components positive towards north.
//! - The component of a horizontal vector (a_E, a_N) along azimuth az is
//!   `a_x = a_E·sin(az) + a_N·cos(az)`, positive towards the azimuth (for a block, towards
//!   its +x axis: the sign convention of the horizontal input of the dynamics).
//! - Conversely, a component `a` along az is the vector `(a_E, a_N) = (a·sin(az), a·cos(az))`.
//!   For two orthogonal channels 1 and 2 at azimuths h1 and h2, the east/north vector is the
//!   sum of the two: `a_E = c1·sin(h1) + c2·sin(h2)`, `a_N = c1·cos(h1) + c2·cos(h2)`.
//!
//! Any consistent unit works for the components (m/s², counts, …): the maps are linear.
//!
//! In three dimensions (StationXML channels), a sensor's axis is an azimuth and a **dip** in
//! degrees **down** from horizontal (SEED: −90° points up, a usual vertical channel; +90°
//! down). Its unit vector on (east, north, up) is
//! `(cos dip·sin az, cos dip·cos az, −sin dip)` ([`ChannelAxis`]), and a channel reads the
//! projection of the ground motion on it. [`ChannelsToEnu`] inverts those projections for two
//! or three channels of any orientation (as ObsPy's `rotate2zne`), with each channel's gain.

/// A horizontal direction: an azimuth in degrees clockwise from north, finite, with its sine
/// and cosine computed once.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Azimuth {
    degrees: f64,
    sin: f64,
    cos: f64,
}

/// An azimuth that is not a finite number of degrees.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[error("azimuth must be a finite number of degrees, got {degrees}")]
pub struct AzimuthError {
    /// The value refused.
    pub degrees: f64,
}

impl Azimuth {
    /// The direction `degrees` clockwise from north (any finite value; 450° is the same
    /// direction as 90°).
    pub fn from_degrees(degrees: f64) -> Result<Azimuth, AzimuthError> {
        if !degrees.is_finite() {
            return Err(AzimuthError { degrees });
        }
        let (sin, cos) = degrees.to_radians().sin_cos();
        Ok(Azimuth { degrees, sin, cos })
    }

    /// The azimuth in degrees clockwise from north, as given.
    #[must_use]
    pub fn degrees(self) -> f64 {
        self.degrees
    }

    /// The component along this direction of the horizontal vector (`east`, `north`):
    /// `east·sin(az) + north·cos(az)`, positive towards the azimuth.
    #[must_use]
    pub fn component(self, east: f64, north: f64) -> f64 {
        east * self.sin + north * self.cos
    }

    /// The horizontal vector `(east, north)` of a component `along` this direction:
    /// `(along·sin(az), along·cos(az))`.
    #[must_use]
    pub fn to_east_north(self, along: f64) -> (f64, f64) {
        (along * self.sin, along * self.cos)
    }
}

/// A sensor's sensitive axis: an azimuth and a dip (degrees down from horizontal, −90 to 90).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ChannelAxis {
    azimuth: Azimuth,
    dip_deg: f64,
}

/// A dip outside −90°…90° (or not finite).
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[error("dip must be -90 to 90 degrees, got {dip_deg}")]
pub struct DipError {
    /// The value refused.
    pub dip_deg: f64,
}

impl ChannelAxis {
    /// The axis at `azimuth`, `dip_deg` degrees below horizontal (−90 = up).
    pub fn new(azimuth: Azimuth, dip_deg: f64) -> Result<ChannelAxis, DipError> {
        if !(-90.0..=90.0).contains(&dip_deg) {
            return Err(DipError { dip_deg });
        }
        Ok(ChannelAxis { azimuth, dip_deg })
    }

    #[must_use]
    pub fn azimuth(self) -> Azimuth {
        self.azimuth
    }

    /// Degrees down from horizontal.
    #[must_use]
    pub fn dip_deg(self) -> f64 {
        self.dip_deg
    }

    /// The unit vector `[east, north, up]` of the axis:
    /// `(cos dip·sin az, cos dip·cos az, −sin dip)`.
    #[must_use]
    pub fn unit_enu(self) -> [f64; 3] {
        let (sin_dip, cos_dip) = self.dip_deg.to_radians().sin_cos();
        let (east, north) = self.azimuth.to_east_north(cos_dip);
        [east, north, -sin_dip]
    }
}

/// The linear map from the raw readings of two or three channels (counts, or any unit their
/// gains convert) to ground motion on (east, north, up): readings are scaled by their gains,
/// then the projections on the channels' axes are inverted. With two channels both must be
/// horizontal (dip 0) and up is 0.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ChannelsToEnu {
    /// `enu = matrix · readings` (columns: channels; a missing third channel's column is 0).
    matrix: [[f64; 3]; 3],
    has_up: bool,
}

/// Channels whose axes cannot be inverted to east/north/up.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RotationError {
    #[error("{0} channels given: need 2 horizontal or 3")]
    Count(usize),
    #[error("no vertical channel and channel {index} is not horizontal (dip {dip_deg}°)")]
    NotHorizontal { index: usize, dip_deg: f64 },
    #[error("the channel axes are (nearly) {what}: |det| = {det:.2e} < {MIN_AXES_DETERMINANT}")]
    Degenerate { what: &'static str, det: f64 },
    #[error("gain {0} is not a finite non-zero number")]
    Gain(f64),
}

/// Smallest |determinant| of the matrix of unit axes accepted (1 for orthogonal axes): below,
/// the axes are so close to coplanar (or, for two channels, parallel) that noise would be
/// amplified more than a thousandfold.
pub const MIN_AXES_DETERMINANT: f64 = 1e-3;

/// Largest |dip| (degrees) treated as horizontal when there is no vertical channel.
const HORIZONTAL_DIP_TOLERANCE_DEG: f64 = 1e-6;

impl ChannelsToEnu {
    /// The map for channels `(axis, gain)`: gains in output units per reading unit (m/s² per
    /// count), sign included.
    pub fn new(channels: &[(ChannelAxis, f64)]) -> Result<ChannelsToEnu, RotationError> {
        if let Some(&(_, gain)) = channels.iter().find(|(_, g)| !(g.is_finite() && *g != 0.0)) {
            return Err(RotationError::Gain(gain));
        }
        let mut matrix = [[0.0; 3]; 3];
        match channels {
            [a, b, c] => {
                let rows = [a.0.unit_enu(), b.0.unit_enu(), c.0.unit_enu()];
                let m = nalgebra::Matrix3::from_fn(|i, j| rows[i][j]);
                let det = m.determinant();
                let inverse = m
                    .try_inverse()
                    .filter(|_| det.abs() >= MIN_AXES_DETERMINANT)
                    .ok_or(RotationError::Degenerate {
                        what: "coplanar",
                        det,
                    })?;
                for (i, row) in matrix.iter_mut().enumerate() {
                    for (j, value) in row.iter_mut().enumerate() {
                        *value = inverse[(i, j)] * channels[j].1;
                    }
                }
            }
            [a, b] => {
                for (index, (axis, _)) in [a, b].into_iter().enumerate() {
                    if axis.dip_deg.abs() > HORIZONTAL_DIP_TOLERANCE_DEG {
                        return Err(RotationError::NotHorizontal {
                            index,
                            dip_deg: axis.dip_deg,
                        });
                    }
                }
                let (e1, n1) = a.0.azimuth.to_east_north(1.0);
                let (e2, n2) = b.0.azimuth.to_east_north(1.0);
                // Readings r1 = e1·E + n1·N, r2 = e2·E + n2·N: invert the 2×2 system.
                let det = e1 * n2 - n1 * e2;
                if det.abs() < MIN_AXES_DETERMINANT {
                    return Err(RotationError::Degenerate {
                        what: "parallel",
                        det,
                    });
                }
                let inverse = [[n2 / det, -n1 / det], [-e2 / det, e1 / det]];
                for i in 0..2 {
                    for j in 0..2 {
                        matrix[i][j] = inverse[i][j] * channels[j].1;
                    }
                }
            }
            _ => return Err(RotationError::Count(channels.len())),
        }
        Ok(ChannelsToEnu {
            matrix,
            has_up: channels.len() == 3,
        })
    }

    /// Whether the map gives a vertical component (three channels).
    #[must_use]
    pub fn has_up(&self) -> bool {
        self.has_up
    }

    /// `[east, north, up]` from the channels' `readings` in the order given to
    /// [`ChannelsToEnu::new`] (the third is ignored for two channels).
    #[must_use]
    pub fn apply(&self, readings: [f64; 3]) -> [f64; 3] {
        self.matrix
            .map(|row| row[0] * readings[0] + row[1] * readings[1] + row[2] * readings[2])
    }
}

impl serde::Serialize for Azimuth {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.serialize_f64(self.degrees)
    }
}

impl<'de> serde::Deserialize<'de> for Azimuth {
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        let degrees = f64::deserialize(deserializer)?;
        Azimuth::from_degrees(degrees).map_err(serde::de::Error::custom)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn az(degrees: f64) -> Azimuth {
        Azimuth::from_degrees(degrees).unwrap()
    }

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() < 1e-12
    }

    #[test]
    fn north_takes_the_north_component_and_east_the_east_one() {
        let (east, north) = (0.3, -1.7);
        assert!(close(az(0.0).component(east, north), north));
        assert!(close(az(90.0).component(east, north), east));
        assert!(close(az(180.0).component(east, north), -north));
        assert!(close(az(270.0).component(east, north), -east));
    }

    #[test]
    fn component_along_az_points_to_az() {
        let (e, n) = az(90.0).to_east_north(2.0);
        assert!(close(e, 2.0) && close(n, 0.0));
        let (e, n) = az(0.0).to_east_north(2.0);
        assert!(close(e, 0.0) && close(n, 2.0));
        let (e, n) = az(30.0).to_east_north(1.0);
        assert!(close(e, 0.5) && close(n, 3f64.sqrt() / 2.0));
    }

    #[test]
    fn channels_1_and_2_round_trip_through_east_north() {
        // Channels 1 and 2 at 228° and 318° (orthogonal) record the components of (e, n);
        // summing their vectors gives (e, n) back.
        let (h1, h2) = (az(228.0), az(318.0));
        let (east, north) = (0.8, -0.25);
        let (c1, c2) = (h1.component(east, north), h2.component(east, north));
        let ((e1, n1), (e2, n2)) = (h1.to_east_north(c1), h2.to_east_north(c2));
        assert!(close(e1 + e2, east) && close(n1 + n2, north));
    }

    #[test]
    fn non_finite_degrees_are_refused_with_the_value() {
        let e = Azimuth::from_degrees(f64::NAN).unwrap_err();
        assert_eq!(
            e.to_string(),
            "azimuth must be a finite number of degrees, got NaN"
        );
        assert!(Azimuth::from_degrees(f64::INFINITY).is_err());
    }

    fn axis(az_deg: f64, dip_deg: f64) -> ChannelAxis {
        ChannelAxis::new(az(az_deg), dip_deg).unwrap()
    }

    #[test]
    fn axes_of_the_usual_channels_are_east_north_up() {
        let near = |a: [f64; 3], b: [f64; 3]| a.iter().zip(b).all(|(x, y)| close(*x, y));
        assert!(near(axis(90.0, 0.0).unit_enu(), [1.0, 0.0, 0.0]));
        assert!(near(axis(0.0, 0.0).unit_enu(), [0.0, 1.0, 0.0]));
        assert!(near(axis(0.0, -90.0).unit_enu(), [0.0, 0.0, 1.0]));
        assert!(near(axis(0.0, 90.0).unit_enu(), [0.0, 0.0, -1.0]));
        assert!(ChannelAxis::new(az(0.0), 91.0).is_err());
        assert!(ChannelAxis::new(az(0.0), f64::NAN).is_err());
    }

    #[test]
    fn channels_to_enu_inverts_projections_for_any_non_degenerate_axes() {
        // Independent check: readings are the projections r_i = u_i · a (scaled by 1/gain);
        // the map must give back a for orthogonal, tilted and non-orthogonal axes.
        let ground = [0.3, -1.1, 0.45];
        let sets = [
            [axis(90.0, 0.0), axis(0.0, 0.0), axis(0.0, -90.0)],
            [axis(228.0, 0.0), axis(318.0, 0.0), axis(0.0, 90.0)],
            [axis(30.0, 10.0), axis(125.0, -5.0), axis(200.0, -80.0)],
        ];
        for axes in sets {
            let gains = [2e-6, -3e-6, 5e-7];
            let readings: Vec<f64> = axes
                .iter()
                .zip(gains)
                .map(|(a, g)| {
                    a.unit_enu()
                        .iter()
                        .zip(ground)
                        .map(|(u, x)| u * x)
                        .sum::<f64>()
                        / g
                })
                .collect();
            let map = ChannelsToEnu::new(&[
                (axes[0], gains[0]),
                (axes[1], gains[1]),
                (axes[2], gains[2]),
            ])
            .unwrap();
            let enu = map.apply([readings[0], readings[1], readings[2]]);
            // Round-off of a 3×3 inverse on O(1) values: far below 1e-12.
            for (x, y) in enu.iter().zip(ground) {
                assert!((x - y).abs() < 1e-12, "{enu:?} vs {ground:?}");
            }
        }
    }

    #[test]
    fn two_horizontal_channels_give_east_north_and_no_up() {
        let (h1, h2) = (axis(10.0, 0.0), axis(100.0, 0.0));
        let (east, north) = (0.8, -0.25);
        let r1 = h1.azimuth().component(east, north);
        let r2 = h2.azimuth().component(east, north);
        let map = ChannelsToEnu::new(&[(h1, 1.0), (h2, 1.0)]).unwrap();
        assert!(!map.has_up());
        let [e, n, u] = map.apply([r1, r2, 123.0]);
        assert!(close(e, east) && close(n, north) && u == 0.0);
    }

    #[test]
    fn degenerate_axes_and_bad_gains_are_refused() {
        let flat = [axis(0.0, 0.0), axis(90.0, 0.0), axis(45.0, 0.0)];
        let e = ChannelsToEnu::new(&[(flat[0], 1.0), (flat[1], 1.0), (flat[2], 1.0)]).unwrap_err();
        assert!(
            matches!(
                e,
                RotationError::Degenerate {
                    what: "coplanar",
                    ..
                }
            ),
            "{e}"
        );
        let e = ChannelsToEnu::new(&[(axis(0.0, 0.0), 1.0), (axis(180.0, 0.0), 1.0)]).unwrap_err();
        assert!(
            matches!(
                e,
                RotationError::Degenerate {
                    what: "parallel",
                    ..
                }
            ),
            "{e}"
        );
        let e = ChannelsToEnu::new(&[(axis(0.0, 0.0), 1.0), (axis(90.0, 5.0), 1.0)]).unwrap_err();
        assert!(
            matches!(e, RotationError::NotHorizontal { index: 1, .. }),
            "{e}"
        );
        assert!(ChannelsToEnu::new(&[(axis(0.0, 0.0), 0.0), (axis(90.0, 0.0), 1.0)]).is_err());
        assert!(ChannelsToEnu::new(&[(axis(0.0, 0.0), 1.0)]).is_err());
    }

    #[test]
    fn serde_reads_and_writes_plain_degrees() {
        #[derive(serde::Deserialize, serde::Serialize)]
        struct S {
            h: Azimuth,
        }
        let s: S = toml::from_str("h = 45.0").unwrap();
        assert!(close(s.h.component(1.0, 1.0), 2f64.sqrt()));
        assert_eq!(toml::to_string(&s).unwrap().trim(), "h = 45.0");
        assert!(toml::from_str::<S>("h = nan").is_err());
    }
}
