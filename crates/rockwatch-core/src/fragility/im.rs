//! The intensity measures of a fragility analysis: names as the user writes them, their value
//! for a record (by [`crate::ims::compute_ims`], the `ims` command's code), their unit, and how
//! they scale with the record.
//!
//! Scaling a record by `s` (both components, every sample) multiplies an IM by `s^k`: k = 1
//! for the IMs linear in the record (PGA, PGV, PGD, CAV, SMA, EDA, EPV, a_rms, SA(T), ASI, SI,
//! VSI: peaks, integrals of |a|, linear filters and oscillators), k = 2 for Arias
//! (∫a²), k = 1.5 for Ic (a_rms^1.5·√D), k = 0 for PGV/PGA, Tp, the Husid times and the
//! significant durations (ratios and times). The analysis computes each record's IMs once, unscaled, and uses
//! `s^k·IM` for every scaled copy (exact up to rounding; `tests/fragility.rs` checks it
//! against `compute_ims` of scaled records).

use crate::ims::rotd::{oscillator_displacement, velocity_displacement, HorizontalDefinition};
use crate::ims::spectrum::{format_period_s, spectral_intensities, PeriodRange};
use crate::ims::{ImError, ImSet};

/// One IM of the analysis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FragilityIm {
    Pga,
    Pgv,
    Pgd,
    Cav,
    Arias,
    Sma,
    Eda,
    Epv,
    ARms,
    Ic,
    PgvPga,
    D5_75,
    D5_95,
    /// Husid times (s from the record's start), as the `ims` command reports them.
    T5,
    T75,
    T95,
    Tp,
    /// 5 %-damped pseudo-spectral acceleration at a period (s).
    Sa(f64),
    /// ASI over a period range of the 0.10–3.00 s grid.
    Asi(PeriodRange),
    /// SI over a period range of the grid.
    Si(PeriodRange),
    /// VSI over a period range of the grid.
    Vsi(PeriodRange),
}

/// The IM names `parse` knows, for error messages.
pub const KNOWN_IMS: &str = "PGA, PGV, PGD, CAV, ARIAS, SMA, EDA, EPV, A_RMS, IC, PGV/PGA, \
                             D5_75, D5_95, T5, T75, T95, TP, SA(T), ASI(T1-T2), SI(T1-T2), \
                             VSI(T1-T2)";

impl FragilityIm {
    /// Parses a name, case-insensitively: `PGA`, `PGV`, `PGV/PGA`, `SA(1.0)`, `ASI(0.1-0.5)`, …
    /// (see [`KNOWN_IMS`]). Spectral ranges must lie on the 0.10–3.00 s grid.
    pub fn parse(text: &str) -> Result<FragilityIm, ImError> {
        let t = text.trim().to_ascii_uppercase();
        let inner = |prefix: &str| -> Option<String> {
            t.strip_prefix(prefix)
                .and_then(|r| r.strip_prefix('('))
                .and_then(|r| r.strip_suffix(')'))
                .map(str::to_owned)
        };
        let range = |r: String| -> Result<PeriodRange, ImError> {
            let range = PeriodRange::parse(&r)?;
            if range.from_centi < 10 || range.to_centi > 300 {
                return Err(ImError::BadRange(format!(
                    "{text:?}: spectrum intensities are integrated on the 0.10-3.00 s grid"
                )));
            }
            Ok(range)
        };
        Ok(match t.as_str() {
            "PGA" | "PHA" => FragilityIm::Pga,
            "PGV" | "PHV" => FragilityIm::Pgv,
            "PGD" | "PHD" => FragilityIm::Pgd,
            "CAV" => FragilityIm::Cav,
            "ARIAS" | "IA" => FragilityIm::Arias,
            "SMA" => FragilityIm::Sma,
            "EDA" => FragilityIm::Eda,
            "EPV" => FragilityIm::Epv,
            "A_RMS" | "ARMS" => FragilityIm::ARms,
            "IC" => FragilityIm::Ic,
            "PGV/PGA" | "PGV_PGA" => FragilityIm::PgvPga,
            "D5_75" | "D5-75" => FragilityIm::D5_75,
            "D5_95" | "D5-95" => FragilityIm::D5_95,
            "T5" => FragilityIm::T5,
            "T75" => FragilityIm::T75,
            "T95" => FragilityIm::T95,
            "TP" => FragilityIm::Tp,
            _ => {
                if let Some(p) = inner("SA") {
                    let period: f64 = p.trim().parse().map_err(|_| {
                        ImError::BadRange(format!("{text:?}: SA(T) needs a period in seconds"))
                    })?;
                    crate::ims::spectrum::check_period(period)?;
                    FragilityIm::Sa(period)
                } else if let Some(r) = inner("ASI") {
                    FragilityIm::Asi(range(r)?)
                } else if let Some(r) = inner("VSI") {
                    FragilityIm::Vsi(range(r)?)
                } else if let Some(r) = inner("SI") {
                    FragilityIm::Si(range(r)?)
                } else {
                    return Err(ImError::BadRange(format!(
                        "unknown IM {text:?} (known: {KNOWN_IMS})"
                    )));
                }
            }
        })
    }

    /// Canonical name (`PGA`, `SA(1.0)`, `ASI(0.1-0.5)`, `PGV/PGA`, …): the key of
    /// `fragility.json`, matched by `rockwatch hazard --im`.
    #[must_use]
    pub fn name(&self) -> String {
        match self {
            FragilityIm::Pga => "PGA".into(),
            FragilityIm::Pgv => "PGV".into(),
            FragilityIm::Pgd => "PGD".into(),
            FragilityIm::Cav => "CAV".into(),
            FragilityIm::Arias => "ARIAS".into(),
            FragilityIm::Sma => "SMA".into(),
            FragilityIm::Eda => "EDA".into(),
            FragilityIm::Epv => "EPV".into(),
            FragilityIm::ARms => "A_RMS".into(),
            FragilityIm::Ic => "IC".into(),
            FragilityIm::PgvPga => "PGV/PGA".into(),
            FragilityIm::D5_75 => "D5_75".into(),
            FragilityIm::D5_95 => "D5_95".into(),
            FragilityIm::T5 => "T5".into(),
            FragilityIm::T75 => "T75".into(),
            FragilityIm::T95 => "T95".into(),
            FragilityIm::Tp => "TP".into(),
            FragilityIm::Sa(t) => format!("SA({})", format_period_s(*t)),
            FragilityIm::Asi(r) => format!("ASI({})", r.label()),
            FragilityIm::Si(r) => format!("SI({})", r.label()),
            FragilityIm::Vsi(r) => format!("VSI({})", r.label()),
        }
    }

    /// SI unit, written as `rockwatch hazard` reads it (`m/s2`, `m/s`) where it applies.
    #[must_use]
    pub fn unit(&self) -> &'static str {
        match self {
            FragilityIm::Pga
            | FragilityIm::Sma
            | FragilityIm::Eda
            | FragilityIm::ARms
            | FragilityIm::Sa(_) => "m/s2",
            FragilityIm::Pgv
            | FragilityIm::Cav
            | FragilityIm::Arias
            | FragilityIm::Epv
            | FragilityIm::Asi(_) => "m/s",
            FragilityIm::Pgd | FragilityIm::Si(_) | FragilityIm::Vsi(_) => "m",
            FragilityIm::Ic => "m^1.5/s^2.5",
            FragilityIm::PgvPga
            | FragilityIm::D5_75
            | FragilityIm::D5_95
            | FragilityIm::T5
            | FragilityIm::T75
            | FragilityIm::T95
            | FragilityIm::Tp => "s",
        }
    }

    /// The exponent k with IM(s·record) = s^k·IM(record) (see the module doc).
    #[must_use]
    pub fn scale_exponent(&self) -> f64 {
        match self {
            FragilityIm::Arias => 2.0,
            FragilityIm::Ic => 1.5,
            FragilityIm::PgvPga
            | FragilityIm::D5_75
            | FragilityIm::D5_95
            | FragilityIm::T5
            | FragilityIm::T75
            | FragilityIm::T95
            | FragilityIm::Tp => 0.0,
            _ => 1.0,
        }
    }

    /// The period at which the record's SA must be computed, if any.
    #[must_use]
    pub fn sa_period(&self) -> Option<f64> {
        match self {
            FragilityIm::Sa(t) => Some(*t),
            _ => None,
        }
    }

    /// True for the IMs with a two-component definition (RotD50, GM, …): PGA, PGV, PGD,
    /// SA(T) and PGV/PGA (the ratio of the PGV and PGA in that definition). The others are of
    /// the first component as recorded.
    #[must_use]
    pub fn has_horizontal_definition(&self) -> bool {
        matches!(
            self,
            FragilityIm::Pga
                | FragilityIm::Pgv
                | FragilityIm::Pgd
                | FragilityIm::Sa(_)
                | FragilityIm::PgvPga
        )
    }

    /// This IM (one of [`FragilityIm::has_horizontal_definition`], NaN for the others) of the
    /// pair `x`, `y` (m/s², orthogonal horizontal components, every `dt_s` s) in the
    /// definition `definition` ([`crate::ims::rotd`]): of the accelerations, velocities,
    /// displacements or oscillator displacements (damping ratio `damping`; SA = ω²·Sd).
    pub fn two_component_value(
        &self,
        definition: HorizontalDefinition,
        x: &[f64],
        y: &[f64],
        dt_s: f64,
        damping: f64,
    ) -> Result<f64, ImError> {
        let pga = || definition.combine(x, y);
        let pgv_pgd = || {
            let (vx, dx) = velocity_displacement(x, dt_s);
            let (vy, dy) = velocity_displacement(y, dt_s);
            (definition.combine(&vx, &vy), definition.combine(&dx, &dy))
        };
        Ok(match self {
            FragilityIm::Pga => pga(),
            FragilityIm::Pgv => pgv_pgd().0,
            FragilityIm::Pgd => pgv_pgd().1,
            FragilityIm::PgvPga => {
                let a = pga();
                if a > 0.0 {
                    pgv_pgd().0 / a
                } else {
                    0.0
                }
            }
            FragilityIm::Sa(t) => {
                let w = 2.0 * std::f64::consts::PI / t;
                let ux = oscillator_displacement(x, dt_s, *t, damping)?;
                let uy = oscillator_displacement(y, dt_s, *t, damping)?;
                w * w * definition.combine(&ux, &uy)
            }
            _ => f64::NAN,
        })
    }

    /// The value of this IM in an [`ImSet`] computed with this IM's SA period among
    /// `ImOptions::periods_s` (NaN if it is missing).
    #[must_use]
    pub fn value(&self, set: &ImSet) -> f64 {
        match self {
            FragilityIm::Pga => set.pga_mps2,
            FragilityIm::Pgv => set.pgv_mps,
            FragilityIm::Pgd => set.pgd_m,
            FragilityIm::Cav => set.cav_mps,
            FragilityIm::Arias => set.arias_mps,
            FragilityIm::Sma => set.sma_mps2,
            FragilityIm::Eda => set.eda_mps2,
            FragilityIm::Epv => set.epv_mps,
            FragilityIm::ARms => set.a_rms_mps2,
            FragilityIm::Ic => set.ic,
            FragilityIm::PgvPga => set.pgv_pga_s,
            FragilityIm::D5_75 => set.d5_75_s,
            FragilityIm::D5_95 => set.d5_95_s,
            FragilityIm::T5 => set.t5_s,
            FragilityIm::T75 => set.t75_s,
            FragilityIm::T95 => set.t95_s,
            FragilityIm::Tp => set.tp_s,
            FragilityIm::Sa(t) => set
                .spectral
                .iter()
                .find(|p| p.period_s == *t)
                .map_or(f64::NAN, |p| p.sa_mps2),
            FragilityIm::Asi(r) => spectral_intensities(&set.grid_spectrum, *r).asi_mps,
            FragilityIm::Si(r) => spectral_intensities(&set.grid_spectrum, *r).si_m,
            FragilityIm::Vsi(r) => spectral_intensities(&set.grid_spectrum, *r).vsi_m,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip() {
        for name in [
            "PGA",
            "PGV",
            "PGV/PGA",
            "SA(1.0)",
            "SA(0.25)",
            "ASI(0.1-0.5)",
            "SI(1.0-2.5)",
            "VSI(0.5-1.0)",
            "ARIAS",
            "IC",
            "TP",
        ] {
            let im = FragilityIm::parse(name).unwrap();
            assert_eq!(im.name(), name);
            assert_eq!(FragilityIm::parse(&name.to_lowercase()).unwrap(), im);
        }
        assert!(FragilityIm::parse("SA(x)").is_err());
        assert!(FragilityIm::parse("ASI(0.05-0.5)").is_err());
        assert!(FragilityIm::parse("PGX").is_err());
    }
}
