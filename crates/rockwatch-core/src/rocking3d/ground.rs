//! Three-component ground motion in the ground frame (east, north, up).

use crate::record::Record;

/// Ground acceleration at one instant (m/s²): + east, + north, + up.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct GroundAccel3d {
    pub east_mps2: f64,
    pub north_mps2: f64,
    pub up_mps2: f64,
}

impl GroundAccel3d {
    /// A horizontal acceleration of `a_mps2` along the azimuth `azimuth_deg` (degrees
    /// clockwise from north): east = a·sin az, north = a·cos az.
    #[must_use]
    pub fn horizontal(a_mps2: f64, azimuth_deg: f64) -> GroundAccel3d {
        let (s, c) = azimuth_deg.to_radians().sin_cos();
        GroundAccel3d {
            east_mps2: a_mps2 * s,
            north_mps2: a_mps2 * c,
            up_mps2: 0.0,
        }
    }

    /// Linear interpolation `self + (other − self)·w`.
    #[must_use]
    pub fn lerp(self, other: GroundAccel3d, w: f64) -> GroundAccel3d {
        GroundAccel3d {
            east_mps2: self.east_mps2 + (other.east_mps2 - self.east_mps2) * w,
            north_mps2: self.north_mps2 + (other.north_mps2 - self.north_mps2) * w,
            up_mps2: self.up_mps2 + (other.up_mps2 - self.up_mps2) * w,
        }
    }

    /// All three components finite.
    #[must_use]
    pub fn is_finite(self) -> bool {
        self.east_mps2.is_finite() && self.north_mps2.is_finite() && self.up_mps2.is_finite()
    }
}

/// A uniformly sampled three-component ground motion.
#[derive(Debug, Clone, PartialEq)]
pub struct GroundMotion3d {
    /// Sampling interval (s), > 0.
    pub dt_s: f64,
    pub samples: Vec<GroundAccel3d>,
}

/// Why records could not be combined into a ground motion.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MotionError {
    #[error("give at least one horizontal record")]
    NoRecord,
    #[error("azimuth {0} is not a finite number of degrees")]
    Azimuth(f64),
    #[error(
        "{source_name}: sampling interval {dt_s} s differs from the first record's {first_dt_s} s \
         (resample the records to one rate)"
    )]
    Rate {
        source_name: String,
        dt_s: f64,
        first_dt_s: f64,
    },
    #[error("{0}: a record needs a positive sampling interval and at least two samples")]
    Empty(String),
}

impl GroundMotion3d {
    /// Combines horizontal records, each given with the azimuth of its component (degrees
    /// clockwise from north), and an optional vertical one (its horizontal samples are the
    /// vertical acceleration, + up). A vertical component attached to a horizontal record
    /// ([`Record::vertical_mps2`]) is added too. All records must share the sampling interval;
    /// shorter ones are padded with zeros to the longest.
    pub fn from_records(
        horizontal: &[(&Record, f64)],
        vertical: Option<&Record>,
    ) -> Result<GroundMotion3d, MotionError> {
        let Some((first, _)) = horizontal.first() else {
            return Err(MotionError::NoRecord);
        };
        let dt = first.dt_s;
        let all = horizontal.iter().map(|(r, _)| *r).chain(vertical);
        let mut n = 0;
        for r in all {
            if !(r.dt_s > 0.0 && r.len() >= 2) {
                return Err(MotionError::Empty(r.source.clone()));
            }
            if r.dt_s != dt {
                return Err(MotionError::Rate {
                    source_name: r.source.clone(),
                    dt_s: r.dt_s,
                    first_dt_s: dt,
                });
            }
            n = n.max(r.len());
        }
        let mut samples = vec![GroundAccel3d::default(); n];
        for &(r, az) in horizontal {
            if !az.is_finite() {
                return Err(MotionError::Azimuth(az));
            }
            let (s, c) = az.to_radians().sin_cos();
            for (k, a) in r.horizontal_mps2.iter().enumerate() {
                samples[k].east_mps2 += a * s;
                samples[k].north_mps2 += a * c;
            }
            if let Some(v) = &r.vertical_mps2 {
                for (k, a) in v.iter().enumerate() {
                    samples[k].up_mps2 += a;
                }
            }
        }
        if let Some(v) = vertical {
            for (k, a) in v.horizontal_mps2.iter().enumerate() {
                samples[k].up_mps2 += a;
            }
        }
        Ok(GroundMotion3d { dt_s: dt, samples })
    }

    /// Number of samples.
    #[must_use]
    pub fn len(&self) -> usize {
        self.samples.len()
    }

    /// True when there are no samples.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.samples.is_empty()
    }
}
