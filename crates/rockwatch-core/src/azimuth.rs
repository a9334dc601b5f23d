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
