//! The study's configuration: the blocks, the demand measures, the Mw–R pairs, the exclusion
//! rule and their defaults checked ([`StudyConfig::validate`]).

use super::{
    BlockResponse, StudyError, DEFAULT_DISTANCES_KM, DEFAULT_DT_S, DEFAULT_IM_PAD_S,
    DEFAULT_MAGNITUDES, DEFAULT_MAX_SLIDE_M, DEFAULT_PULSES_PER_PAIR, DEFAULT_SLIDE_FLOOR_M,
    DEFAULT_THETA_FLOOR_RAD, DEFAULT_T_EXTRA_S, DEFAULT_VECTOR_TOP,
};
use crate::dynamics::BlockParams;
use crate::ims::{Im, STUDY_IMS};
use crate::pulse::PulseScenario;

/// The demand measure (DM) regressed for a block.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum DemandMeasure {
    /// max |u|, the largest slip of the contact point relative to the ground (m).
    Slide,
    /// max |θ|, the largest rotation (rad).
    Theta,
}

impl DemandMeasure {
    /// Column name (with unit) in the CSV outputs.
    #[must_use]
    pub fn column(self) -> &'static str {
        match self {
            DemandMeasure::Slide => "max_abs_slide_m",
            DemandMeasure::Theta => "max_abs_theta_rad",
        }
    }

    /// Axis label for people.
    #[must_use]
    pub fn label(self) -> &'static str {
        match self {
            DemandMeasure::Slide => "max |slide| (m)",
            DemandMeasure::Theta => "max |θ| (rad)",
        }
    }

    /// Short name (`slide` or `theta`).
    #[must_use]
    pub fn as_str(self) -> &'static str {
        match self {
            DemandMeasure::Slide => "slide",
            DemandMeasure::Theta => "theta",
        }
    }

    /// The DM of a response (m or rad).
    #[must_use]
    pub fn of(self, r: &BlockResponse) -> f64 {
        match self {
            DemandMeasure::Slide => r.max_abs_slide_m,
            DemandMeasure::Theta => r.max_abs_theta_rad,
        }
    }
}

/// A block of the study with the DM regressed for it.
#[derive(Debug, Clone, PartialEq)]
pub struct StudyBlock {
    /// Name used in file names, tables and JSON (letters, digits, `-`, `_`).
    pub name: String,
    /// Geometry and friction.
    pub params: BlockParams,
    /// The demand measure of its regressions.
    pub dm: DemandMeasure,
}

impl StudyBlock {
    /// The seed's sliding block: α = 45°, μs = μk = 0.1, DM = max |slide|. The seed gives no
    /// size; R = 1.12 m is the block of its Figure 2 (pure sliding).
    pub fn seed_sliding() -> Result<Self, StudyError> {
        Self::from_r_alpha(
            "sliding",
            1.12,
            45f64.to_radians(),
            0.1,
            0.1,
            DemandMeasure::Slide,
        )
    }

    /// The seed's rocking block: α = 11.31°, μs = 1.5, μk = 1.0, DM = max |θ|. The seed gives
    /// no size; R = 3.29 m is the block of its Figure 2 (pure rocking).
    pub fn seed_rocking() -> Result<Self, StudyError> {
        Self::from_r_alpha(
            "rocking",
            3.29,
            11.31f64.to_radians(),
            1.5,
            1.0,
            DemandMeasure::Theta,
        )
    }

    fn from_r_alpha(
        name: &str,
        r_m: f64,
        alpha_rad: f64,
        mu_s: f64,
        mu_k: f64,
        dm: DemandMeasure,
    ) -> Result<Self, StudyError> {
        let params =
            BlockParams::from_r_alpha(r_m, alpha_rad, mu_s, mu_k, None).map_err(|source| {
                StudyError::Block {
                    name: name.to_string(),
                    source,
                }
            })?;
        Ok(StudyBlock {
            name: name.to_string(),
            params,
            dm,
        })
    }

    /// Parses `NAME:key=value,key=value,…`. Keys: `r` (half-diagonal, m) with `alpha-deg` or
    /// `alpha` (rad), or `width` and `height` (m); `mu-s`, `mu-k` (μk defaults to μs);
    /// `restitution` (optional, in [0, 1]); `dm` = `slide` or `theta` (default: `theta` when
    /// the block can rock before it slides, μs > tan α, else `slide`).
    /// Example: `slide-rock:r=1.5,alpha-deg=10,mu-s=0.2,mu-k=0.19`.
    pub fn parse_spec(spec: &str) -> Result<Self, StudyError> {
        let bad = |problem: String| StudyError::BlockSpec {
            spec: spec.to_string(),
            problem,
        };
        let (name, rest) = spec
            .split_once(':')
            .ok_or_else(|| bad("expected NAME:key=value,... ".to_string()))?;
        let name = name.trim();
        if name.is_empty()
            || !name
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_')
        {
            return Err(bad(format!(
                "block name {name:?} must be non-empty letters, digits, '-' or '_'"
            )));
        }
        let mut r = None;
        let mut alpha_rad = None;
        let mut width = None;
        let mut height = None;
        let mut mu_s = None;
        let mut mu_k = None;
        let mut restitution = None;
        let mut dm = None;
        for item in rest.split(',').map(str::trim).filter(|s| !s.is_empty()) {
            let (key, value) = item
                .split_once('=')
                .ok_or_else(|| bad(format!("{item:?} is not key=value")))?;
            let (key, value) = (key.trim(), value.trim());
            if key == "dm" {
                dm = Some(match value {
                    "slide" => DemandMeasure::Slide,
                    "theta" => DemandMeasure::Theta,
                    _ => return Err(bad(format!("dm must be slide or theta, got {value:?}"))),
                });
                continue;
            }
            let number: f64 = value
                .parse()
                .map_err(|_| bad(format!("{key} = {value:?} is not a number")))?;
            let slot = match key {
                "r" => &mut r,
                "alpha" => &mut alpha_rad,
                "alpha-deg" => {
                    alpha_rad = Some(number.to_radians());
                    continue;
                }
                "width" => &mut width,
                "height" => &mut height,
                "mu-s" => &mut mu_s,
                "mu-k" => &mut mu_k,
                "restitution" => &mut restitution,
                _ => {
                    return Err(bad(format!(
                        "unknown key {key:?} (known: r, alpha, alpha-deg, width, height, \
                         mu-s, mu-k, restitution, dm)"
                    )))
                }
            };
            *slot = Some(number);
        }
        let mu_s = mu_s.ok_or_else(|| bad("mu-s is required".to_string()))?;
        let mu_k = mu_k.unwrap_or(mu_s);
        let result = match (r, alpha_rad, width, height) {
            (Some(r), Some(a), None, None) => {
                BlockParams::from_r_alpha(r, a, mu_s, mu_k, restitution)
            }
            (None, None, Some(w), Some(h)) => {
                BlockParams::from_width_height(w, h, mu_s, mu_k, restitution)
            }
            _ => {
                return Err(bad(
                    "give either r with alpha (or alpha-deg), or width with height".to_string(),
                ))
            }
        };
        let params = result.map_err(|source| StudyError::Block {
            name: name.to_string(),
            source,
        })?;
        let dm = dm.unwrap_or(
            if params.mu_s > params.plus.tan_alpha.min(params.minus.tan_alpha) {
                DemandMeasure::Theta
            } else {
                DemandMeasure::Slide
            },
        );
        Ok(StudyBlock {
            name: name.to_string(),
            params,
            dm,
        })
    }
}

/// Which responses are left out of the regressions (the seed drops "excessive" responses).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct ExclusionRule {
    /// Exclude runs in which the block overturned (default true).
    pub exclude_overturned: bool,
    /// Exclude runs with max |slide| above this (m); `f64::INFINITY` disables it.
    pub max_slide_m: f64,
    /// Exclude runs with max |θ| above this (rad); `f64::INFINITY` disables it.
    pub max_theta_rad: f64,
}

impl Default for ExclusionRule {
    fn default() -> Self {
        ExclusionRule {
            exclude_overturned: true,
            max_slide_m: DEFAULT_MAX_SLIDE_M,
            max_theta_rad: f64::INFINITY,
        }
    }
}

/// The configuration of a study.
#[derive(Debug, Clone, PartialEq)]
pub struct StudyConfig {
    /// Moment magnitudes Mw.
    pub magnitudes: Vec<f64>,
    /// Rupture distances R (km).
    pub distances_km: Vec<f64>,
    /// Pulses per Mw–R pair.
    pub pulses_per_pair: usize,
    /// Seed of the whole study.
    pub seed: u64,
    /// Sampling interval of the pulse records (s).
    pub dt_s: f64,
    /// Zeros appended to each pulse for its IMs (s).
    pub im_pad_s: f64,
    /// Free vibration simulated after each pulse (s).
    pub t_extra_s: f64,
    /// The blocks.
    pub blocks: Vec<StudyBlock>,
    /// Exclusion rule of the regressions.
    pub exclusion: ExclusionRule,
    /// Smallest max |slide| counted as a response (m): below it, "no response".
    pub slide_floor_m: f64,
    /// Smallest max |θ| counted as a response (rad).
    pub theta_floor_rad: f64,
    /// Number of best vector IMs reported per block.
    pub vector_top: usize,
    /// IM of the fragility curves (`None`: the IM of largest likelihood).
    pub fragility_im: Option<Im>,
}

impl StudyConfig {
    /// The seed's study: 5 magnitudes × 3 distances × 250 pulses, its sliding and rocking
    /// blocks, and this crate's defaults for everything the seed does not state.
    pub fn seed_default() -> Result<Self, StudyError> {
        Ok(StudyConfig {
            magnitudes: DEFAULT_MAGNITUDES.to_vec(),
            distances_km: DEFAULT_DISTANCES_KM.to_vec(),
            pulses_per_pair: DEFAULT_PULSES_PER_PAIR,
            seed: 1,
            dt_s: DEFAULT_DT_S,
            im_pad_s: DEFAULT_IM_PAD_S,
            t_extra_s: DEFAULT_T_EXTRA_S,
            blocks: vec![StudyBlock::seed_sliding()?, StudyBlock::seed_rocking()?],
            exclusion: ExclusionRule::default(),
            slide_floor_m: DEFAULT_SLIDE_FLOOR_M,
            theta_floor_rad: DEFAULT_THETA_FLOOR_RAD,
            vector_top: DEFAULT_VECTOR_TOP,
            fragility_im: None,
        })
    }

    /// The Mw–R pairs, magnitude-major (all distances of the first magnitude first).
    #[must_use]
    pub fn pairs(&self) -> Vec<Pair> {
        self.magnitudes
            .iter()
            .flat_map(|&mw| self.distances_km.iter().map(move |&r_km| Pair { mw, r_km }))
            .collect()
    }

    /// The response floor of a DM (m or rad).
    #[must_use]
    pub fn floor(&self, dm: DemandMeasure) -> f64 {
        match dm {
            DemandMeasure::Slide => self.slide_floor_m,
            DemandMeasure::Theta => self.theta_floor_rad,
        }
    }

    /// Checks every value (counts, finiteness, unique block names, known fragility IM).
    pub fn validate(&self) -> Result<(), StudyError> {
        let bad = |m: String| Err(StudyError::Config(m));
        if self.magnitudes.is_empty() || self.distances_km.is_empty() {
            return bad("at least one magnitude and one distance are needed".into());
        }
        if self.pulses_per_pair == 0 || self.pulses_per_pair > 1_000_000 {
            return bad(format!(
                "pulses per pair must be in 1..=1000000, got {}",
                self.pulses_per_pair
            ));
        }
        if !(self.dt_s.is_finite() && self.dt_s > 0.0 && self.dt_s <= 0.1) {
            return bad(format!("dt must be in (0, 0.1] s, got {}", self.dt_s));
        }
        for (name, v) in [("im pad", self.im_pad_s), ("t_extra", self.t_extra_s)] {
            if !(v.is_finite() && v >= 0.0) {
                return bad(format!(
                    "{name} must be a finite number of seconds >= 0, got {v}"
                ));
            }
        }
        for (name, v) in [
            ("slide floor", self.slide_floor_m),
            ("theta floor", self.theta_floor_rad),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return bad(format!("{name} must be a positive finite number, got {v}"));
            }
        }
        for (name, v) in [
            ("max slide", self.exclusion.max_slide_m),
            ("max theta", self.exclusion.max_theta_rad),
        ] {
            if v.is_nan() || v <= 0.0 {
                return bad(format!("{name} must be > 0 (or inf to disable), got {v}"));
            }
        }
        if self.blocks.is_empty() {
            return bad("no blocks to study".into());
        }
        for (i, b) in self.blocks.iter().enumerate() {
            if self.blocks[..i].iter().any(|o| o.name == b.name) {
                return bad(format!("two blocks are named {:?}", b.name));
            }
        }
        if let Some(im) = &self.fragility_im {
            if !STUDY_IMS.contains(im) {
                return bad(format!(
                    "fragility IM {:?} is not one of the study's IMs",
                    im.study_name()
                ));
            }
        }
        for pair in self.pairs() {
            PulseScenario::new(pair.mw, pair.r_km).map_err(|source| StudyError::Pulse {
                mw: pair.mw,
                r_km: pair.r_km,
                source,
            })?;
        }
        Ok(())
    }
}

/// A magnitude–distance pair.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Pair {
    /// Moment magnitude.
    pub mw: f64,
    /// Rupture distance (km).
    pub r_km: f64,
}

impl Pair {
    /// Label in the seed's style: `M6.5-R10`, `M7-R5`.
    #[must_use]
    pub fn label(&self) -> String {
        format!("M{}-R{}", self.mw, self.r_km)
    }
}
