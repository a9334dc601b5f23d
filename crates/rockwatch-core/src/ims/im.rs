//! The intensity measures by identity: [`Im`], the one type naming an IM everywhere (the
//! study, the fragility analysis, the hazard and the command line), with its spellings, its SI
//! unit, its value for a record (by [`crate::ims::compute_ims`], the `ims` command's code), how
//! it scales with the record, and its OpenQuake IMT; [`ImUnit`], the units an IM is given in
//! by hazard curves and fragility files, with their conversions.
//!
//! Spellings (all parsed by `Im::from_str`, case-insensitively):
//! - the canonical name ([`Im`]'s `Display`): `PGA`, `PGV/PGA`, `SA(1.0)`, `ASI(0.1-0.5)`, …,
//!   the key of `rockwatch fragility`'s fragility.json and runs.csv, and `--im`;
//! - the study's name ([`Im::study_name`]): `pha`, `pgv_pga`, `asi_0.1-0.5`, …, the columns of
//!   `rockwatch study`'s tables and the `im` of its fragility.json;
//! - aliases: `PHA`/`PHV`/`PHD`, `IA`, `ARMS`, `PGV_PGA`, `D5-75`, `D5-95`;
//! - the OpenQuake IMT ([`Im::from_openquake_imt`]): `PGA`, `PGV`, `SA(T)` only.
//!
//! Scaling a record by `s` (both components, every sample) multiplies an IM by `s^k`: k = 1
//! for the IMs linear in the record (PGA, PGV, PGD, CAV, SMA, EDA, EPV, a_rms, SA(T), ASI, SI,
//! VSI: peaks, integrals of |a|, linear filters and oscillators), k = 2 for Arias
//! (∫a²), k = 1.5 for Ic (a_rms^1.5·√D), k = 0 for PGV/PGA, Tp, the Husid times and the
//! significant durations (ratios and times). The fragility analysis computes each record's IMs
//! once, unscaled, and uses `s^k·IM` for every scaled copy (exact up to rounding;
//! `tests/fragility.rs` checks it against `compute_ims` of scaled records).

use std::fmt;
use std::str::FromStr;

use crate::ims::rotd::{oscillator_displacement, velocity_displacement, HorizontalDefinition};
use crate::ims::spectrum::{
    check_period, format_period_s, spectral_intensities, PeriodRange, STUDY_RANGES,
};
use crate::ims::{ImError, ImSet};

/// One intensity measure.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Im {
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

/// The IM names `Im::from_str` knows, for error messages.
pub const KNOWN_IMS: &str = "PGA, PGV, PGD, CAV, ARIAS, SMA, EDA, EPV, A_RMS, IC, PGV/PGA, \
                             D5_75, D5_95, T5, T75, T95, TP, SA(T), ASI(T1-T2), SI(T1-T2), \
                             VSI(T1-T2)";

/// Number of IMs in the seed's study.
pub const STUDY_IM_COUNT: usize = 37;

/// The 37 IMs of the seed's study, in the order of its tables ([`crate::ims::study_ims`]):
/// PHA, PHV, PHD, SMA, EDA, Tp, PGV/PGA, D5-95, a_rms, Ic, Arias, CAV, EPV, then SI, ASI and
/// VSI over each of [`STUDY_RANGES`].
pub const STUDY_IMS: [Im; STUDY_IM_COUNT] = {
    let mut ims = [Im::Pga; STUDY_IM_COUNT];
    let scalars = [
        Im::Pga,
        Im::Pgv,
        Im::Pgd,
        Im::Sma,
        Im::Eda,
        Im::Tp,
        Im::PgvPga,
        Im::D5_95,
        Im::ARms,
        Im::Ic,
        Im::Arias,
        Im::Cav,
        Im::Epv,
    ];
    let mut i = 0;
    while i < scalars.len() {
        ims[i] = scalars[i];
        i += 1;
    }
    let mut j = 0;
    while j < STUDY_RANGES.len() {
        ims[13 + j] = Im::Si(STUDY_RANGES[j]);
        ims[21 + j] = Im::Asi(STUDY_RANGES[j]);
        ims[29 + j] = Im::Vsi(STUDY_RANGES[j]);
        j += 1;
    }
    ims
};

/// An IM name that is not one.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ImNameError {
    /// Not a name of any IM.
    #[error("unknown IM {name:?} (known: {KNOWN_IMS})")]
    Unknown { name: String },
    /// `SA(…)` without a number of seconds.
    #[error("{name:?}: SA(T) needs a period in seconds")]
    NoPeriod { name: String },
    /// A period or a period range that the spectra cannot have.
    #[error("{name:?}: {error}")]
    Period { name: String, error: ImError },
    /// A spectrum intensity over a range off the 0.10–3.00 s grid.
    #[error("{name:?}: spectrum intensities are integrated on the 0.10-3.00 s grid")]
    OffGrid { name: String },
    /// An OpenQuake IMT that rockwatch does not read.
    #[error("OpenQuake IMT {imt:?} is not supported (PGA, PGV, SA(T))")]
    NotOpenQuake { imt: String },
}

impl FromStr for Im {
    type Err = ImNameError;

    /// Parses any spelling of the module doc, case-insensitively: `PGA`, `pha`, `PGV/PGA`,
    /// `pgv_pga`, `SA(1.0)`, `ASI(0.1-0.5)`, `asi_0.1-0.5`, … (see [`KNOWN_IMS`]). Spectral
    /// ranges must lie on the 0.10–3.00 s grid.
    fn from_str(text: &str) -> Result<Im, ImNameError> {
        let t = text.trim().to_ascii_uppercase();
        let name = || text.to_owned();
        let inner = |prefix: &str| -> Option<&str> {
            let rest = t.strip_prefix(prefix)?;
            rest.strip_prefix('(')
                .and_then(|r| r.strip_suffix(')'))
                .or_else(|| rest.strip_prefix('_'))
        };
        let range = |r: &str| -> Result<PeriodRange, ImNameError> {
            let range = PeriodRange::parse(r).map_err(|error| ImNameError::Period {
                name: name(),
                error,
            })?;
            if range.from_centi < 10 || range.to_centi > 300 {
                return Err(ImNameError::OffGrid { name: name() });
            }
            Ok(range)
        };
        Ok(match t.as_str() {
            "PGA" | "PHA" => Im::Pga,
            "PGV" | "PHV" => Im::Pgv,
            "PGD" | "PHD" => Im::Pgd,
            "CAV" => Im::Cav,
            "ARIAS" | "IA" => Im::Arias,
            "SMA" => Im::Sma,
            "EDA" => Im::Eda,
            "EPV" => Im::Epv,
            "A_RMS" | "ARMS" => Im::ARms,
            "IC" => Im::Ic,
            "PGV/PGA" | "PGV_PGA" => Im::PgvPga,
            "D5_75" | "D5-75" => Im::D5_75,
            "D5_95" | "D5-95" => Im::D5_95,
            "T5" => Im::T5,
            "T75" => Im::T75,
            "T95" => Im::T95,
            "TP" => Im::Tp,
            _ => {
                if let Some(p) = t.strip_prefix("SA(").and_then(|r| r.strip_suffix(')')) {
                    let period: f64 = p
                        .trim()
                        .parse()
                        .map_err(|_| ImNameError::NoPeriod { name: name() })?;
                    check_period(period).map_err(|error| ImNameError::Period {
                        name: name(),
                        error,
                    })?;
                    Im::Sa(period)
                } else if let Some(r) = inner("ASI") {
                    Im::Asi(range(r)?)
                } else if let Some(r) = inner("VSI") {
                    Im::Vsi(range(r)?)
                } else if let Some(r) = inner("SI") {
                    Im::Si(range(r)?)
                } else {
                    return Err(ImNameError::Unknown { name: name() });
                }
            }
        })
    }
}

/// The canonical name: `PGA`, `SA(1.0)`, `ASI(0.1-0.5)`, `PGV/PGA`, … (the key of
/// `rockwatch fragility`'s fragility.json, matched by `rockwatch hazard --im`).
impl fmt::Display for Im {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Im::Sa(t) => write!(f, "SA({})", format_period_s(*t)),
            Im::Asi(r) => write!(f, "ASI({})", r.label()),
            Im::Si(r) => write!(f, "SI({})", r.label()),
            Im::Vsi(r) => write!(f, "VSI({})", r.label()),
            fixed => f.write_str(match fixed {
                Im::Pga => "PGA",
                Im::Pgv => "PGV",
                Im::Pgd => "PGD",
                Im::Cav => "CAV",
                Im::Arias => "ARIAS",
                Im::Sma => "SMA",
                Im::Eda => "EDA",
                Im::Epv => "EPV",
                Im::ARms => "A_RMS",
                Im::Ic => "IC",
                Im::PgvPga => "PGV/PGA",
                Im::D5_75 => "D5_75",
                Im::D5_95 => "D5_95",
                Im::T5 => "T5",
                Im::T75 => "T75",
                Im::T95 => "T95",
                _ => "TP",
            }),
        }
    }
}

impl Im {
    /// The canonical name ([`Im`]'s `Display`).
    #[must_use]
    pub fn name(&self) -> String {
        self.to_string()
    }

    /// The study's spelling (the columns of `rockwatch study`'s tables, the `im` of its
    /// fragility.json): `pha`, `phv`, `phd` for the peaks, `pgv_pga`, `si_0.1-0.5`, …; the
    /// canonical name in lower case for the others.
    #[must_use]
    pub fn study_name(&self) -> String {
        match self {
            Im::Pga => "pha".into(),
            Im::Pgv => "phv".into(),
            Im::Pgd => "phd".into(),
            Im::PgvPga => "pgv_pga".into(),
            Im::Asi(r) => format!("asi_{}", r.label()),
            Im::Si(r) => format!("si_{}", r.label()),
            Im::Vsi(r) => format!("vsi_{}", r.label()),
            other => other.to_string().to_ascii_lowercase(),
        }
    }

    /// SI unit as files write it (`m/s2`, `m/s`, `m`, `s`, `m^1.5/s^2.5`); `rockwatch hazard`
    /// reads the first two ([`ImUnit::parse`]).
    #[must_use]
    pub fn unit(&self) -> &'static str {
        match self {
            Im::Pga | Im::Sma | Im::Eda | Im::ARms | Im::Sa(_) => "m/s2",
            Im::Pgv | Im::Cav | Im::Arias | Im::Epv | Im::Asi(_) => "m/s",
            Im::Pgd | Im::Si(_) | Im::Vsi(_) => "m",
            Im::Ic => "m^1.5/s^2.5",
            Im::PgvPga | Im::D5_75 | Im::D5_95 | Im::T5 | Im::T75 | Im::T95 | Im::Tp => "s",
        }
    }

    /// The IM of an OpenQuake IMT (an `imt='…'` of a hazard curve's comment line): `PGA`,
    /// `PGV` or `SA(T)`, case-insensitive, T a period as [`Im::Sa`] takes it; every other IMT
    /// is refused.
    pub fn from_openquake_imt(imt: &str) -> Result<Im, ImNameError> {
        let refused = || ImNameError::NotOpenQuake {
            imt: imt.trim().to_ascii_uppercase(),
        };
        let upper = imt.trim().to_ascii_uppercase();
        if !(upper == "PGA" || upper == "PGV" || upper.starts_with("SA(")) {
            return Err(refused());
        }
        let im: Im = upper.parse()?;
        match im {
            Im::Pga | Im::Pgv | Im::Sa(_) => Ok(im),
            _ => Err(refused()),
        }
    }

    /// The unit of this IM in OpenQuake's hazard curves: g for PGA and SA(T), cm/s for PGV;
    /// None for the IMs OpenQuake does not have.
    #[must_use]
    pub fn openquake_unit(&self) -> Option<ImUnit> {
        match self {
            Im::Pga | Im::Sa(_) => Some(ImUnit::G),
            Im::Pgv => Some(ImUnit::CentimetrePerSecond),
            _ => None,
        }
    }

    /// The exponent k with IM(s·record) = s^k·IM(record) (see the module doc).
    #[must_use]
    pub fn scale_exponent(&self) -> f64 {
        match self {
            Im::Arias => 2.0,
            Im::Ic => 1.5,
            Im::PgvPga | Im::D5_75 | Im::D5_95 | Im::T5 | Im::T75 | Im::T95 | Im::Tp => 0.0,
            _ => 1.0,
        }
    }

    /// The period at which the record's SA must be computed, if any.
    #[must_use]
    pub fn sa_period(&self) -> Option<f64> {
        match self {
            Im::Sa(t) => Some(*t),
            _ => None,
        }
    }

    /// True for the IMs with a two-component definition (RotD50, GM, …): PGA, PGV, PGD,
    /// SA(T) and PGV/PGA (the ratio of the PGV and PGA in that definition). The others are of
    /// the first component as recorded.
    #[must_use]
    pub fn has_horizontal_definition(&self) -> bool {
        matches!(self, Im::Pga | Im::Pgv | Im::Pgd | Im::Sa(_) | Im::PgvPga)
    }

    /// This IM (one of [`Im::has_horizontal_definition`], NaN for the others) of the
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
            Im::Pga => pga(),
            Im::Pgv => pgv_pgd().0,
            Im::Pgd => pgv_pgd().1,
            Im::PgvPga => {
                let a = pga();
                if a > 0.0 {
                    pgv_pgd().0 / a
                } else {
                    0.0
                }
            }
            Im::Sa(t) => {
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
            Im::Pga => set.pga_mps2,
            Im::Pgv => set.pgv_mps,
            Im::Pgd => set.pgd_m,
            Im::Cav => set.cav_mps,
            Im::Arias => set.arias_mps,
            Im::Sma => set.sma_mps2,
            Im::Eda => set.eda_mps2,
            Im::Epv => set.epv_mps,
            Im::ARms => set.a_rms_mps2,
            Im::Ic => set.ic,
            Im::PgvPga => set.pgv_pga_s,
            Im::D5_75 => set.d5_75_s,
            Im::D5_95 => set.d5_95_s,
            Im::T5 => set.t5_s,
            Im::T75 => set.t75_s,
            Im::T95 => set.t95_s,
            Im::Tp => set.tp_s,
            Im::Sa(t) => set
                .spectral
                .iter()
                .find(|p| p.period_s == *t)
                .map_or(f64::NAN, |p| p.sa_mps2),
            Im::Asi(r) => spectral_intensities(&set.grid_spectrum, *r).asi_mps,
            Im::Si(r) => spectral_intensities(&set.grid_spectrum, *r).si_m,
            Im::Vsi(r) => spectral_intensities(&set.grid_spectrum, *r).vsi_m,
        }
    }
}

/// An [`Im`] in JSON (serde's `with`) as the study spells it ([`Im::study_name`]): the `im` of
/// `rockwatch study`'s fragility.json; read back by any spelling.
pub mod study_spelling {
    use super::Im;

    /// Writes `im` as [`Im::study_name`].
    pub fn serialize<S: serde::Serializer>(im: &Im, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.serialize_str(&im.study_name())
    }

    /// Reads any spelling `Im::from_str` takes.
    pub fn deserialize<'de, D: serde::Deserializer<'de>>(deserializer: D) -> Result<Im, D::Error> {
        let text = <std::borrow::Cow<'de, str> as serde::Deserialize>::deserialize(deserializer)?;
        text.parse().map_err(serde::de::Error::custom)
    }
}

/// Units an IM is given in by a hazard curve or a fragility file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ImUnit {
    /// Standard gravity g = 9.80665 m/s².
    G,
    MetrePerSecond2,
    CentimetrePerSecond2,
    MetrePerSecond,
    CentimetrePerSecond,
}

/// A unit that is not one, or a conversion between an acceleration and a velocity.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ImUnitError {
    /// Not a unit [`ImUnit::parse`] knows.
    #[error("unknown IM unit {0:?} (known: g, m/s2, cm/s2, m/s, cm/s)")]
    Unknown(String),
    /// A hazard curve and a fragility of different quantities.
    #[error(
        "unit mismatch: the hazard curve is in {from} and the fragility in {to} (an \
         acceleration and a velocity)"
    )]
    Mismatch { from: ImUnit, to: ImUnit },
}

impl ImUnit {
    /// Parses `g`, `m/s2` (or `m/s²`, `m/s^2`), `cm/s2` (`gal`), `m/s`, `cm/s`.
    pub fn parse(text: &str) -> Result<ImUnit, ImUnitError> {
        match text.trim().to_ascii_lowercase().as_str() {
            "g" => Ok(ImUnit::G),
            "m/s2" | "m/s²" | "m/s^2" => Ok(ImUnit::MetrePerSecond2),
            "cm/s2" | "cm/s²" | "cm/s^2" | "gal" => Ok(ImUnit::CentimetrePerSecond2),
            "m/s" => Ok(ImUnit::MetrePerSecond),
            "cm/s" => Ok(ImUnit::CentimetrePerSecond),
            other => Err(ImUnitError::Unknown(other.to_owned())),
        }
    }

    /// Value of one unit in SI (m/s² or m/s).
    #[must_use]
    pub fn to_si(self) -> f64 {
        match self {
            ImUnit::G => crate::STANDARD_GRAVITY_MPS2,
            ImUnit::MetrePerSecond2 | ImUnit::MetrePerSecond => 1.0,
            ImUnit::CentimetrePerSecond2 | ImUnit::CentimetrePerSecond => 0.01,
        }
    }

    /// The SI unit of the same quantity: m/s² for an acceleration, m/s for a velocity.
    #[must_use]
    pub fn si(self) -> ImUnit {
        if self.is_acceleration() {
            ImUnit::MetrePerSecond2
        } else {
            ImUnit::MetrePerSecond
        }
    }

    /// True for accelerations, false for velocities.
    #[must_use]
    pub fn is_acceleration(self) -> bool {
        matches!(
            self,
            ImUnit::G | ImUnit::MetrePerSecond2 | ImUnit::CentimetrePerSecond2
        )
    }

    /// The factor that converts a value in `self` into `to`; an error between an
    /// acceleration and a velocity.
    pub fn factor_to(self, to: ImUnit) -> Result<f64, ImUnitError> {
        if self.is_acceleration() != to.is_acceleration() {
            return Err(ImUnitError::Mismatch { from: self, to });
        }
        Ok(self.to_si() / to.to_si())
    }
}

impl fmt::Display for ImUnit {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            ImUnit::G => "g",
            ImUnit::MetrePerSecond2 => "m/s2",
            ImUnit::CentimetrePerSecond2 => "cm/s2",
            ImUnit::MetrePerSecond => "m/s",
            ImUnit::CentimetrePerSecond => "cm/s",
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(name: &str) -> Result<Im, ImNameError> {
        name.parse()
    }

    /// Every IM's canonical and study names parse back to it, in any case.
    #[test]
    fn every_name_round_trips() {
        let range = PeriodRange::new(50, 100);
        let all = [
            Im::Pga,
            Im::Pgv,
            Im::Pgd,
            Im::Cav,
            Im::Arias,
            Im::Sma,
            Im::Eda,
            Im::Epv,
            Im::ARms,
            Im::Ic,
            Im::PgvPga,
            Im::D5_75,
            Im::D5_95,
            Im::T5,
            Im::T75,
            Im::T95,
            Im::Tp,
            Im::Sa(1.0),
            Im::Sa(0.25),
            Im::Asi(range),
            Im::Si(range),
            Im::Vsi(range),
        ];
        for im in all.into_iter().chain(STUDY_IMS) {
            for name in [im.name(), im.study_name()] {
                assert_eq!(parse(&name), Ok(im), "{name}");
                assert_eq!(parse(&name.to_lowercase()), Ok(im), "{name}");
                assert_eq!(parse(&name.to_uppercase()), Ok(im), "{name}");
            }
        }
        for (name, im) in [
            ("PGA", Im::Pga),
            ("PGV/PGA", Im::PgvPga),
            ("SA(1.0)", Im::Sa(1.0)),
            ("SA(0.25)", Im::Sa(0.25)),
            ("ASI(0.1-0.5)", Im::Asi(PeriodRange::new(10, 50))),
            ("SI(1.0-2.5)", Im::Si(PeriodRange::new(100, 250))),
            ("VSI(0.5-1.0)", Im::Vsi(range)),
            ("ARIAS", Im::Arias),
            ("IC", Im::Ic),
            ("TP", Im::Tp),
        ] {
            assert_eq!(im.to_string(), name);
        }
    }

    /// The spellings the three former identity systems accepted still parse: the fragility's
    /// aliases, the study's 37 names (the former `STUDY_IM_NAMES`, with their units, the
    /// former `STUDY_IM_UNITS`), and hazard's `pha`/`phv`.
    #[test]
    fn every_former_spelling_still_parses() {
        for (alias, im) in [
            ("PHA", Im::Pga),
            ("pha", Im::Pga),
            ("PHV", Im::Pgv),
            ("phv", Im::Pgv),
            ("PHD", Im::Pgd),
            ("IA", Im::Arias),
            ("ARMS", Im::ARms),
            ("PGV_PGA", Im::PgvPga),
            ("D5-75", Im::D5_75),
            ("D5-95", Im::D5_95),
            (" sa(1) ", Im::Sa(1.0)),
        ] {
            assert_eq!(parse(alias), Ok(im), "{alias}");
        }
        let former_names = [
            "pha",
            "phv",
            "phd",
            "sma",
            "eda",
            "tp",
            "pgv_pga",
            "d5_95",
            "a_rms",
            "ic",
            "arias",
            "cav",
            "epv",
            "si_0.1-0.5",
            "si_0.1-2.5",
            "si_0.5-1.0",
            "si_1.0-1.5",
            "si_1.5-2.0",
            "si_2.0-2.5",
            "si_2.5-3.0",
            "si_1.0-2.5",
            "asi_0.1-0.5",
            "asi_0.1-2.5",
            "asi_0.5-1.0",
            "asi_1.0-1.5",
            "asi_1.5-2.0",
            "asi_2.0-2.5",
            "asi_2.5-3.0",
            "asi_1.0-2.5",
            "vsi_0.1-0.5",
            "vsi_0.1-2.5",
            "vsi_0.5-1.0",
            "vsi_1.0-1.5",
            "vsi_1.5-2.0",
            "vsi_2.0-2.5",
            "vsi_2.5-3.0",
            "vsi_1.0-2.5",
        ];
        let former_units = [
            "m/s2",
            "m/s",
            "m",
            "m/s2",
            "m/s2",
            "s",
            "s",
            "s",
            "m/s2",
            "m^1.5/s^2.5",
            "m/s",
            "m/s",
            "m/s",
            "m",
            "m",
            "m",
            "m",
            "m",
            "m",
            "m",
            "m",
            "m/s",
            "m/s",
            "m/s",
            "m/s",
            "m/s",
            "m/s",
            "m/s",
            "m/s",
            "m",
            "m",
            "m",
            "m",
            "m",
            "m",
            "m",
            "m",
        ];
        for (j, im) in STUDY_IMS.iter().enumerate() {
            assert_eq!(im.study_name(), former_names[j]);
            assert_eq!(im.unit(), former_units[j], "{}", former_names[j]);
            assert_eq!(parse(former_names[j]), Ok(*im));
        }
        let mut names: Vec<String> = STUDY_IMS.iter().map(Im::study_name).collect();
        names.sort_unstable();
        names.dedup();
        assert_eq!(names.len(), STUDY_IM_COUNT);
        assert!(matches!(parse("SA(x)"), Err(ImNameError::NoPeriod { .. })));
        assert!(matches!(parse("SA(0)"), Err(ImNameError::Period { .. })));
        assert!(matches!(
            parse("ASI(0.05-0.5)"),
            Err(ImNameError::OffGrid { .. })
        ));
        assert!(matches!(
            parse("asi_0.5-0.1"),
            Err(ImNameError::Period { .. })
        ));
        assert!(matches!(parse("PGX"), Err(ImNameError::Unknown { .. })));
        assert!(parse("PGX").unwrap_err().to_string().contains("unknown IM"));
    }

    /// `hazard::canonical_im` as it was before `Im` (kept only to check the table below).
    fn former_canonical_im(name: &str) -> String {
        let upper = name.trim().to_ascii_uppercase();
        match upper.as_str() {
            "PHA" => "PGA".to_owned(),
            "PHV" => "PGV".to_owned(),
            _ => upper,
        }
    }

    /// `hazard::ImUnit::of_openquake_imt` as it was before `Im` (kept only to check the table
    /// below; None for its error).
    fn former_unit_of_openquake_imt(imt: &str) -> Option<ImUnit> {
        let imt = imt.trim().to_ascii_uppercase();
        if imt == "PGA" || imt.starts_with("SA(") {
            Some(ImUnit::G)
        } else if imt == "PGV" {
            Some(ImUnit::CentimetrePerSecond)
        } else {
            None
        }
    }

    /// The OpenQuake IMTs hazard reads, before (the removed `ImUnit::of_openquake_imt` and
    /// `hazard::canonical_im`) and after: the unit of each accepted IMT, and whether a curve
    /// of that IMT matches `--im`.
    #[test]
    fn openquake_imts_map_as_hazard_read_them() {
        // (IMT in the file, unit before, unit after (None: refused)).
        // Before, any text starting with "SA(" was taken as an SA in g; now the period must be
        // one (0 < T ≤ 100 s), as `--im` requires.
        let units = [
            ("PGA", Some(ImUnit::G), Some(ImUnit::G)),
            ("pga", Some(ImUnit::G), Some(ImUnit::G)),
            (
                " PGV ",
                Some(ImUnit::CentimetrePerSecond),
                Some(ImUnit::CentimetrePerSecond),
            ),
            ("SA(1.0)", Some(ImUnit::G), Some(ImUnit::G)),
            ("SA(0.2)", Some(ImUnit::G), Some(ImUnit::G)),
            ("sa(3)", Some(ImUnit::G), Some(ImUnit::G)),
            ("SA(x)", Some(ImUnit::G), None),
            ("SA(0)", Some(ImUnit::G), None),
            ("PGD", None, None),
            ("PHA", None, None),
            ("MMI", None, None),
            ("AvgSA", None, None),
            ("", None, None),
        ];
        for (imt, before, after) in units {
            assert_eq!(former_unit_of_openquake_imt(imt), before, "{imt:?}");
            let now = Im::from_openquake_imt(imt)
                .ok()
                .and_then(|im| im.openquake_unit());
            assert_eq!(now, after, "{imt:?}");
            // Nothing refused before is accepted now.
            assert!(before.is_some() || now.is_none(), "{imt:?}");
            if let Err(e) = Im::from_openquake_imt(imt) {
                assert!(e.to_string().contains("is not supported") || imt.starts_with("SA("));
            }
        }
        // (IMT, --im, matched before (upper-case equality, pha/phv as PGA/PGV), matched now
        // (the same Im)). Now SA periods compare as numbers.
        let matches = [
            ("PGA", "PGA", true, true),
            ("PGA", "pga", true, true),
            ("PGA", "pha", true, true),
            ("PGV", "phv", true, true),
            ("PGV", "PGA", false, false),
            ("SA(1.0)", "SA(1.0)", true, true),
            ("SA(1.0)", "sa(1.0)", true, true),
            ("SA(1.0)", "SA(1)", false, true),
            ("SA(1.0)", "SA(0.3)", false, false),
            ("SA(0.3)", "PGA", false, false),
        ];
        for (imt, wanted, before, now) in matches {
            assert_eq!(
                former_canonical_im(imt) == former_canonical_im(wanted),
                before,
                "{imt} vs {wanted}"
            );
            let file = Im::from_openquake_imt(imt).unwrap();
            assert_eq!(file == parse(wanted).unwrap(), now, "{imt} vs {wanted}");
        }
    }

    #[test]
    fn unit_factors_and_mismatch() {
        assert_eq!(
            ImUnit::CentimetrePerSecond
                .factor_to(ImUnit::MetrePerSecond)
                .unwrap(),
            0.01
        );
        assert_eq!(
            ImUnit::G.factor_to(ImUnit::MetrePerSecond2).unwrap(),
            crate::STANDARD_GRAVITY_MPS2
        );
        assert!(ImUnit::G
            .factor_to(ImUnit::MetrePerSecond)
            .unwrap_err()
            .to_string()
            .contains("unit mismatch"));
        assert_eq!(ImUnit::parse("cm/s").unwrap(), ImUnit::CentimetrePerSecond);
        assert!(ImUnit::parse("inch/s").is_err());
        for unit in [
            ImUnit::G,
            ImUnit::MetrePerSecond2,
            ImUnit::CentimetrePerSecond2,
            ImUnit::MetrePerSecond,
            ImUnit::CentimetrePerSecond,
        ] {
            assert_eq!(ImUnit::parse(&unit.to_string()), Ok(unit));
            assert_eq!(unit.si().to_si(), 1.0);
            assert_eq!(unit.si().is_acceleration(), unit.is_acceleration());
        }
        // An IM's SI unit string is the SI ImUnit's spelling where ImUnit has it.
        for im in [Im::Pga, Im::Sa(1.0), Im::Pgv] {
            let si = im.openquake_unit().unwrap().si();
            assert_eq!(si.to_string(), im.unit());
        }
    }
}
