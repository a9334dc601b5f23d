//! The pre-event baseline of a record: a DC offset (a constant added to the acceleration, as
//! raw strong-motion records often carry from their digitizer or a tilt) integrates into a
//! linear velocity and a quadratic displacement, so PGV and PGD of such a record mean nothing.
//! The IMs are defined on the record as given (spec/intensity-measures.md: no mean removal);
//! this module measures the offset so that the caller can warn, and removes it on request.
//!
//! The pre-event part is the first [`PRE_EVENT_FRACTION`] of the record (at least
//! [`MIN_PRE_EVENT_SAMPLES`] samples): triggered records (K-NET, K2, …) keep several seconds
//! before the shaking, and processed records (PEER NGA) start near zero.

/// Fraction of the record taken as its pre-event part.
pub const PRE_EVENT_FRACTION: f64 = 0.05;
/// Fewest samples of a pre-event part; a shorter record has none.
pub const MIN_PRE_EVENT_SAMPLES: usize = 20;
/// An offset beyond this fraction of the record's peak |a| is reported by [`PreEvent::is_offset`].
pub const OFFSET_FRACTION_OF_PEAK: f64 = 0.05;

/// The pre-event part of a record and its mean.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PreEvent {
    /// Number of samples of the pre-event part (from the first one).
    pub samples: usize,
    /// Its duration `samples·dt` (s).
    pub duration_s: f64,
    /// Mean acceleration over it (same unit as the record, m/s²).
    pub mean: f64,
    /// Peak |a| of the whole record as given (same unit).
    pub peak: f64,
}

impl PreEvent {
    /// Whether the mean is a DC offset worth reporting: beyond
    /// [`OFFSET_FRACTION_OF_PEAK`] of the peak.
    #[must_use]
    pub fn is_offset(&self) -> bool {
        self.mean.abs() > OFFSET_FRACTION_OF_PEAK * self.peak
    }
}

/// The pre-event part of `acceleration` sampled every `dt_s`, or `None` when the record is too
/// short to have one (fewer than [`MIN_PRE_EVENT_SAMPLES`]/[`PRE_EVENT_FRACTION`] samples).
#[must_use]
pub fn pre_event(acceleration: &[f64], dt_s: f64) -> Option<PreEvent> {
    let samples = (acceleration.len() as f64 * PRE_EVENT_FRACTION).floor() as usize;
    if samples < MIN_PRE_EVENT_SAMPLES {
        return None;
    }
    let mean = acceleration[..samples].iter().sum::<f64>() / samples as f64;
    let peak = acceleration.iter().fold(0.0f64, |m, a| m.max(a.abs()));
    Some(PreEvent {
        samples,
        duration_s: samples as f64 * dt_s,
        mean,
        peak,
    })
}

/// Subtracts `offset` from every sample.
pub fn remove_offset(acceleration: &mut [f64], offset: f64) {
    for a in acceleration {
        *a -= offset;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_constant_offset_on_a_quiet_start_is_found_and_removed_exactly() {
        // 1000 samples: 0.5 m/s² of offset, a 2 m/s² sine burst after the pre-event part.
        let dt = 0.01;
        let mut a: Vec<f64> = (0..1000)
            .map(|i| {
                let t = i as f64 * dt;
                let burst = if (3.0..6.0).contains(&t) {
                    2.0 * (2.0 * std::f64::consts::PI * t).sin()
                } else {
                    0.0
                };
                0.5 + burst
            })
            .collect();
        let p = pre_event(&a, dt).unwrap();
        assert_eq!(p.samples, 50);
        assert!((p.duration_s - 0.5).abs() < 1e-12);
        assert!((p.mean - 0.5).abs() < 1e-15, "{}", p.mean);
        assert!(p.is_offset());
        remove_offset(&mut a, p.mean);
        let q = pre_event(&a, dt).unwrap();
        assert!(q.mean.abs() < 1e-15 && !q.is_offset());
    }

    #[test]
    fn short_records_have_no_pre_event_part() {
        assert_eq!(pre_event(&[1.0; 399], 0.01), None);
        assert!(pre_event(&[1.0; 400], 0.01).is_some());
    }
}
