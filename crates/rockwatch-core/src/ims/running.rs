//! Running (streaming) intensity measures of one component.
//!
//! [`RunningIms::push`] takes one acceleration sample (m/s²) and updates every running IM in
//! O(1) (O(number of oscillators) for the spectra). At any time each value equals the offline
//! value ([`super::compute_ims`], same definitions) computed on the samples received so far,
//! up to rounding (most are bit-identical: the same sums are formed in the same order).
//!
//! How the "so far" values are kept:
//! - PGA, PGV, PGD, CAV, Arias: running peaks and trapezoid sums.
//! - t5, t75, t95: the Husid time `t_p` is found from the first sample index `i` with
//!   `E_i ≥ p·E_n` (`E` the cumulative trapezoid of a², `E_n` its total so far). `E_i` is
//!   non-decreasing in `i` and `E_n` non-decreasing in `n`, so that index never moves back:
//!   one pointer per fraction is advanced after each push, at most `n` steps in total, i.e.
//!   amortised O(1) per sample. The cumulative-energy history must be kept (a later, larger
//!   total can move t5 anywhere after its current position); it lives in a buffer
//!   preallocated for [`RunningConfig::capacity_samples`] samples, and `push` allocates only
//!   when a window outgrows it (the buffer then doubles: amortised O(1), 8 bytes per sample).
//!   The interpolation between the bracketing samples is done when a value is read.
//! - D5-75, D5-95, a_rms, Ic: from the above when read.
//! - SMA: the peak of the open half-cycle and the three largest closed half-cycle peaks;
//!   the open half-cycle counts when the value is read, as it does offline at the record's end.
//! - Spectra: one Nigam–Jennings oscillator per distinct period (the configured SA periods
//!   and the grid points of the configured ranges, shared when equal), each holding its
//!   state and its peaks |u| and |u̇|; ASI, SI and VSI are integrated over the grid points
//!   when read.

use super::spectrum::{
    centi_to_s, check_damping, check_dt, check_period, NigamJennings, PeriodRange,
    SpectralIntensities, SpectralValues, DEFAULT_DAMPING, STUDY_RANGES,
};
use super::{ImError, DEFAULT_SA_PERIODS_S, HUSID_FRACTIONS};
use crate::record::STANDARD_GRAVITY_MPS2;

/// What a [`RunningIms`] computes besides the non-spectral IMs.
#[derive(Debug, Clone, PartialEq)]
pub struct RunningConfig {
    /// Damping ratio of the oscillators (default 0.05).
    pub damping: f64,
    /// Periods (s) at which SA (and PSV, SV) are kept.
    pub sa_periods_s: Vec<f64>,
    /// Period ranges over which ASI, SI and VSI are kept.
    pub spectral_ranges: Vec<PeriodRange>,
    /// Step of the period grid used for the range integrals, in hundredths of a second: the
    /// grid points of a range are the multiples of the step inside it (1 → the standard
    /// 0.01 s grid, the one the offline IMs use).
    pub grid_step_centi: u32,
    /// Number of samples the cumulative-energy history is preallocated for; `push` does not
    /// allocate while a window stays within it.
    pub capacity_samples: usize,
}

impl RunningConfig {
    /// The live node's default set: SA at 0.3, 1.0 and 3.0 s, and ASI/SI/VSI over 0.1–0.5 s
    /// on the 0.02 s grid (21 grid oscillators; 23 in all), 5 % damping, room for 2¹⁷ samples
    /// (over 10 min at 200 samples/s) before the history grows.
    #[must_use]
    pub fn live_default() -> Self {
        RunningConfig {
            damping: DEFAULT_DAMPING,
            sa_periods_s: vec![0.3, 1.0, 3.0],
            spectral_ranges: vec![PeriodRange::new(10, 50)],
            grid_step_centi: 2,
            capacity_samples: 1 << 17,
        }
    }

    /// The offline set: SA at the default periods (0.1 … 3.0 s) and the eight study ranges on
    /// the 0.01 s grid, so the running values equal [`super::compute_ims`]'s.
    #[must_use]
    pub fn study() -> Self {
        RunningConfig {
            damping: DEFAULT_DAMPING,
            sa_periods_s: DEFAULT_SA_PERIODS_S.to_vec(),
            spectral_ranges: STUDY_RANGES.to_vec(),
            grid_step_centi: 1,
            capacity_samples: 1 << 17,
        }
    }
}

/// One linear oscillator: recursion coefficients, state and running peaks.
#[derive(Debug, Clone, Copy)]
struct Oscillator {
    nj: NigamJennings,
    /// Relative displacement (m).
    u_m: f64,
    /// Relative velocity (m/s).
    v_mps: f64,
    /// Peak |u| so far (m).
    sd_m: f64,
    /// Peak |u̇| so far (m/s).
    sv_mps: f64,
}

/// Running IMs of one component (see the module documentation).
#[derive(Debug, Clone)]
pub struct RunningIms {
    dt_s: f64,
    damping: f64,
    npts: usize,
    previous_mps2: f64,
    pga_mps2: f64,
    velocity_mps: f64,
    displacement_m: f64,
    pgv_mps: f64,
    pgd_m: f64,
    cav_mps: f64,
    /// Cumulative trapezoid of a² at each sample (m²/s³).
    energy: Vec<f64>,
    /// Per Husid fraction: first index with `energy[i] ≥ fraction·total`.
    husid_index: [usize; 3],
    /// Sign of the open half-cycle: +1, −1, or 0 when none is open.
    run_sign: i8,
    /// Peak |a| of the open half-cycle (m/s²).
    run_peak_mps2: f64,
    /// The three largest closed half-cycle peaks, descending; 0 = none.
    top_peaks_mps2: [f64; 3],
    /// Oscillators sorted by increasing period.
    oscillators: Vec<Oscillator>,
    periods_s: Vec<f64>,
    /// Per configured SA period: its index in `oscillators`.
    sa_index: Vec<usize>,
    /// Per configured range: indices (ascending period) of its grid oscillators.
    ranges: Vec<(PeriodRange, Vec<usize>)>,
}

impl RunningIms {
    /// A running set for samples every `dt_s` s.
    pub fn new(dt_s: f64, config: &RunningConfig) -> Result<Self, ImError> {
        check_dt(dt_s)?;
        check_damping(config.damping)?;
        let step = config.grid_step_centi.max(1);
        let mut periods_s = Vec::new();
        for &t in &config.sa_periods_s {
            check_period(t)?;
            periods_s.push(t);
        }
        let grid_of = |range: &PeriodRange| -> Vec<f64> {
            (range.from_centi.div_ceil(step) * step..=range.to_centi)
                .step_by(step as usize)
                .filter(|&k| k > 0)
                .map(centi_to_s)
                .collect()
        };
        for range in &config.spectral_ranges {
            if range.from_centi > range.to_centi {
                return Err(ImError::BadRange(range.label()));
            }
            periods_s.extend(grid_of(range));
        }
        periods_s.sort_by(f64::total_cmp);
        periods_s.dedup();
        let index_of = |t: f64| periods_s.iter().position(|&p| p == t).unwrap_or(0);
        let sa_index = config.sa_periods_s.iter().map(|&t| index_of(t)).collect();
        let ranges = config
            .spectral_ranges
            .iter()
            .map(|r| (*r, grid_of(r).into_iter().map(index_of).collect()))
            .collect();
        let oscillators = periods_s
            .iter()
            .map(|&t| {
                Ok(Oscillator {
                    nj: NigamJennings::new(t, config.damping, dt_s)?,
                    u_m: 0.0,
                    v_mps: 0.0,
                    sd_m: 0.0,
                    sv_mps: 0.0,
                })
            })
            .collect::<Result<Vec<_>, ImError>>()?;
        Ok(RunningIms {
            dt_s,
            damping: config.damping,
            npts: 0,
            previous_mps2: 0.0,
            pga_mps2: 0.0,
            velocity_mps: 0.0,
            displacement_m: 0.0,
            pgv_mps: 0.0,
            pgd_m: 0.0,
            cav_mps: 0.0,
            energy: Vec::with_capacity(config.capacity_samples.max(1)),
            husid_index: [0; 3],
            run_sign: 0,
            run_peak_mps2: 0.0,
            top_peaks_mps2: [0.0; 3],
            oscillators,
            periods_s,
            sa_index,
            ranges,
        })
    }

    /// Starts a new window: forgets every sample, keeps the configuration and the buffers.
    pub fn reset(&mut self) {
        self.npts = 0;
        self.previous_mps2 = 0.0;
        self.pga_mps2 = 0.0;
        self.velocity_mps = 0.0;
        self.displacement_m = 0.0;
        self.pgv_mps = 0.0;
        self.pgd_m = 0.0;
        self.cav_mps = 0.0;
        self.energy.clear();
        self.husid_index = [0; 3];
        self.run_sign = 0;
        self.run_peak_mps2 = 0.0;
        self.top_peaks_mps2 = [0.0; 3];
        for osc in &mut self.oscillators {
            osc.u_m = 0.0;
            osc.v_mps = 0.0;
            osc.sd_m = 0.0;
            osc.sv_mps = 0.0;
        }
    }

    /// Adds the next acceleration sample (m/s², finite; a NaN or infinite sample poisons the
    /// sums). No allocation unless the window outgrows `capacity_samples` (see the module
    /// documentation).
    pub fn push(&mut self, accel_mps2: f64) {
        let a1 = accel_mps2;
        self.pga_mps2 = self.pga_mps2.max(a1.abs());
        self.update_half_cycles(a1);
        if self.npts == 0 {
            self.energy.push(0.0);
            self.previous_mps2 = a1;
            self.npts = 1;
            return;
        }
        let a0 = self.previous_mps2;
        let dt = self.dt_s;

        let v_next = self.velocity_mps + 0.5 * dt * (a0 + a1);
        self.displacement_m += 0.5 * dt * (self.velocity_mps + v_next);
        self.velocity_mps = v_next;
        self.pgv_mps = self.pgv_mps.max(v_next.abs());
        self.pgd_m = self.pgd_m.max(self.displacement_m.abs());
        self.cav_mps += 0.5 * dt * (a0.abs() + a1.abs());

        let total = self.energy.last().copied().unwrap_or(0.0) + 0.5 * dt * (a0 * a0 + a1 * a1);
        self.energy.push(total);
        let last = self.energy.len() - 1;
        for (index, fraction) in self.husid_index.iter_mut().zip(HUSID_FRACTIONS) {
            let target = fraction * total;
            while *index < last && self.energy[*index] < target {
                *index += 1;
            }
        }

        for osc in &mut self.oscillators {
            let (u, v) = osc.nj.step(osc.u_m, osc.v_mps, a0, a1);
            osc.u_m = u;
            osc.v_mps = v;
            osc.sd_m = osc.sd_m.max(u.abs());
            osc.sv_mps = osc.sv_mps.max(v.abs());
        }

        self.previous_mps2 = a1;
        self.npts += 1;
    }

    /// Closes or extends the open half-cycle with sample `a` (m/s²).
    fn update_half_cycles(&mut self, a: f64) {
        let sign: i8 = if a > 0.0 {
            1
        } else if a < 0.0 {
            -1
        } else {
            0
        };
        if sign != 0 && sign == self.run_sign {
            self.run_peak_mps2 = self.run_peak_mps2.max(a.abs());
            return;
        }
        if self.run_sign != 0 {
            insert_top3(&mut self.top_peaks_mps2, self.run_peak_mps2);
        }
        self.run_sign = sign;
        self.run_peak_mps2 = if sign != 0 { a.abs() } else { 0.0 };
    }

    /// Samples received so far.
    #[must_use]
    pub fn npts(&self) -> usize {
        self.npts
    }

    /// Sampling interval (s).
    #[must_use]
    pub fn dt_s(&self) -> f64 {
        self.dt_s
    }

    /// Damping ratio of the oscillators.
    #[must_use]
    pub fn damping(&self) -> f64 {
        self.damping
    }

    /// Number of distinct oscillators updated per sample.
    #[must_use]
    pub fn oscillator_count(&self) -> usize {
        self.oscillators.len()
    }

    /// PGA so far (m/s²).
    #[must_use]
    pub fn pga_mps2(&self) -> f64 {
        self.pga_mps2
    }

    /// PGV so far (m/s).
    #[must_use]
    pub fn pgv_mps(&self) -> f64 {
        self.pgv_mps
    }

    /// PGD so far (m).
    #[must_use]
    pub fn pgd_m(&self) -> f64 {
        self.pgd_m
    }

    /// CAV so far (m/s).
    #[must_use]
    pub fn cav_mps(&self) -> f64 {
        self.cav_mps
    }

    /// `∫a²dt` so far (m²/s³).
    fn total_energy(&self) -> f64 {
        self.energy.last().copied().unwrap_or(0.0)
    }

    /// Arias intensity so far (m/s).
    #[must_use]
    pub fn arias_mps(&self) -> f64 {
        std::f64::consts::PI / (2.0 * STANDARD_GRAVITY_MPS2) * self.total_energy()
    }

    /// Husid time for the `j`-th fraction of [`HUSID_FRACTIONS`] (s).
    fn husid_time(&self, j: usize) -> f64 {
        let total = self.total_energy();
        if total <= 0.0 {
            return 0.0;
        }
        let i = self.husid_index[j];
        if i == 0 {
            return 0.0;
        }
        let target = HUSID_FRACTIONS[j] * total;
        let (e0, e1) = (self.energy[i - 1], self.energy[i]);
        self.dt_s * ((i - 1) as f64 + (target - e0) / (e1 - e0))
    }

    /// t5 so far (s from the first sample).
    #[must_use]
    pub fn t5_s(&self) -> f64 {
        self.husid_time(0)
    }

    /// t75 so far (s).
    #[must_use]
    pub fn t75_s(&self) -> f64 {
        self.husid_time(1)
    }

    /// t95 so far (s).
    #[must_use]
    pub fn t95_s(&self) -> f64 {
        self.husid_time(2)
    }

    /// D5-75 so far (s).
    #[must_use]
    pub fn d5_75_s(&self) -> f64 {
        self.t75_s() - self.t5_s()
    }

    /// D5-95 so far (s).
    #[must_use]
    pub fn d5_95_s(&self) -> f64 {
        self.t95_s() - self.t5_s()
    }

    /// a_rms so far, `sqrt(0.90·∫a²dt / D5-95)` (m/s²); 0 while D5-95 is 0.
    #[must_use]
    pub fn a_rms_mps2(&self) -> f64 {
        super::offline::rms_and_characteristic(self.total_energy(), self.d5_95_s()).0
    }

    /// Characteristic intensity so far (m^1.5·s^-2.5).
    #[must_use]
    pub fn ic(&self) -> f64 {
        super::offline::rms_and_characteristic(self.total_energy(), self.d5_95_s()).1
    }

    /// SMA so far: 3rd-largest half-cycle peak, the open half-cycle included (m/s²).
    #[must_use]
    pub fn sma_mps2(&self) -> f64 {
        let mut top = self.top_peaks_mps2;
        if self.run_sign != 0 {
            insert_top3(&mut top, self.run_peak_mps2);
        }
        top[2]
    }

    fn spectral_at(&self, index: usize) -> SpectralValues {
        let osc = &self.oscillators[index];
        SpectralValues::from_peaks(self.periods_s[index], osc.sd_m, osc.sv_mps)
    }

    /// SA, PSV and SV so far at each configured SA period, in the configured order.
    pub fn spectral(&self) -> impl Iterator<Item = SpectralValues> + '_ {
        self.sa_index.iter().map(|&i| self.spectral_at(i))
    }

    /// SA so far (m/s²) at `period_s`, if it is one of the configured SA periods.
    #[must_use]
    pub fn sa_mps2(&self, period_s: f64) -> Option<f64> {
        self.spectral()
            .find(|p| p.period_s == period_s)
            .map(|p| p.sa_mps2)
    }

    /// ASI, SI and VSI so far over each configured range, in the configured order.
    pub fn intensities(&self) -> impl Iterator<Item = SpectralIntensities> + '_ {
        self.ranges.iter().map(|(range, indices)| {
            let mut si = SpectralIntensities {
                range: *range,
                asi_mps: 0.0,
                si_m: 0.0,
                vsi_m: 0.0,
            };
            let mut previous: Option<SpectralValues> = None;
            for &i in indices {
                let p = self.spectral_at(i);
                if let Some(q) = previous {
                    let half_dt = 0.5 * (p.period_s - q.period_s);
                    si.asi_mps += half_dt * (q.sa_mps2 + p.sa_mps2);
                    si.si_m += half_dt * (q.psv_mps + p.psv_mps);
                    si.vsi_m += half_dt * (q.sv_mps + p.sv_mps);
                }
                previous = Some(p);
            }
            si
        })
    }
}

/// Inserts `x` into `top`, kept in descending order (largest three).
fn insert_top3(top: &mut [f64; 3], x: f64) {
    if x > top[0] {
        *top = [x, top[0], top[1]];
    } else if x > top[1] {
        *top = [top[0], x, top[1]];
    } else if x > top[2] {
        top[2] = x;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn live_default_shares_oscillators() {
        let r = RunningIms::new(0.005, &RunningConfig::live_default()).unwrap();
        // 0.10, 0.12, …, 0.50 (21) plus 1.0 and 3.0; 0.3 is on the grid.
        assert_eq!(r.oscillator_count(), 23);
    }

    #[test]
    fn sma_includes_open_half_cycle() {
        let mut r = RunningIms::new(0.01, &RunningConfig::live_default()).unwrap();
        for a in [3.0, -2.0, 1.0] {
            r.push(a);
        }
        assert_eq!(r.sma_mps2(), 1.0);
        r.push(5.0);
        assert_eq!(r.sma_mps2(), 2.0);
    }

    #[test]
    fn bad_config_is_an_error() {
        let mut c = RunningConfig::live_default();
        c.sa_periods_s.push(0.0);
        assert!(RunningIms::new(0.01, &c).is_err());
        assert!(RunningIms::new(-1.0, &RunningConfig::live_default()).is_err());
    }
}
