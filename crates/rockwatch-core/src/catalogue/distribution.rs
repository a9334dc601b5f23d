//! A possibly uncertain parameter of a catalogue entry ([`Distribution`]: a number, a uniform
//! range or a normal) and the valid domain of each parameter ([`Domain`]).
//!
//! Units are the parameter's own (metres for sizes, degrees for `alpha_deg` and
//! `heading_deg`, dimensionless for μs, μk, e). The nominal value is the number, the midpoint
//! of a range or the mean of a normal. Sampling goes through [`Distribution::quantile`]: the
//! normal is truncated to the parameter's domain and sampled by inverse CDF, so every margin
//! is exactly stratified in the law actually sampled and no value is clipped onto a bound
//! (the module doc of [`crate::catalogue`], "Uncertainty and ensembles").

use std::fmt;

use serde::de::{self, Deserializer, MapAccess, Visitor};
use serde::Deserialize;

use crate::lhs::standard_normal_quantile;
use crate::stats::normal_cdf;

/// A possibly uncertain scalar parameter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Distribution {
    /// A known value.
    Fixed(f64),
    /// Uniform on `[min, max]` (`min < max`). Nominal value: the midpoint.
    Uniform { min: f64, max: f64 },
    /// Normal with mean `mean` and standard deviation `sd > 0`, truncated to the parameter's
    /// valid domain when sampled. Nominal value: `mean`.
    Normal { mean: f64, sd: f64 },
}

impl Distribution {
    /// The nominal value: the value itself, the midpoint of a range, the mean of a normal.
    #[must_use]
    pub fn nominal(&self) -> f64 {
        match *self {
            Distribution::Fixed(v) => v,
            Distribution::Uniform { min, max } => 0.5 * (min + max),
            Distribution::Normal { mean, .. } => mean,
        }
    }

    /// Whether the value is known exactly (not sampled in an ensemble).
    #[must_use]
    pub fn is_fixed(&self) -> bool {
        matches!(self, Distribution::Fixed(_))
    }

    /// The value at cumulative probability `u` ∈ (0, 1) of the distribution restricted to
    /// `domain` (see the module doc), always inside `domain`.
    pub(super) fn quantile(&self, u: f64, domain: Domain) -> f64 {
        let x = match *self {
            Distribution::Fixed(v) => v,
            Distribution::Uniform { min, max } => min + u * (max - min),
            Distribution::Normal { mean, sd } => {
                let p_lo = normal_cdf((domain.lo - mean) / sd);
                let p_hi = normal_cdf((domain.hi - mean) / sd);
                // Keep p strictly inside (0, 1) so that Φ⁻¹ stays finite whatever the rounding.
                let p = (p_lo + u * (p_hi - p_lo)).clamp(f64::MIN_POSITIVE, 1.0 - f64::EPSILON);
                mean + sd * standard_normal_quantile(p)
            }
        };
        domain.clamp(x)
    }
}

/// The set of valid values of one parameter: from `lo` to `hi`, each end open or closed.
#[derive(Debug, Clone, Copy)]
pub(super) struct Domain {
    lo: f64,
    lo_open: bool,
    hi: f64,
    hi_open: bool,
    /// "must be …" completion for error messages.
    pub(super) requirement: &'static str,
}

pub(super) const SIZE_DOMAIN: Domain = Domain {
    lo: 0.0,
    lo_open: true,
    hi: f64::INFINITY,
    hi_open: true,
    requirement: "a finite length > 0 (metres)",
};
pub(super) const ALPHA_DEG_DOMAIN: Domain = Domain {
    lo: 0.0,
    lo_open: true,
    hi: 90.0,
    hi_open: true,
    requirement: "in (0, 90) degrees",
};
pub(super) const MU_S_DOMAIN: Domain = Domain {
    lo: 0.0,
    lo_open: true,
    hi: f64::INFINITY,
    hi_open: true,
    requirement: "a finite number > 0",
};
pub(super) const MU_K_DOMAIN: Domain = Domain {
    lo: 0.0,
    lo_open: false,
    hi: 4.0 / 3.0,
    hi_open: true,
    requirement: "in [0, 4/3) (mu_k ≥ 4/3 makes slide-rocking ill-posed: Painlevé paradox)",
};
pub(super) const HEADING_DOMAIN: Domain = Domain {
    lo: -360.0,
    lo_open: false,
    hi: 360.0,
    hi_open: false,
    requirement: "in [-360, 360] degrees clockwise from north",
};
pub(super) const CONTACT_TOLERANCE_DOMAIN: Domain = Domain {
    lo: 0.0,
    lo_open: false,
    hi: 1.0,
    hi_open: false,
    requirement: "in [0, 1] m",
};
pub(super) const RESTITUTION_DOMAIN: Domain = Domain {
    lo: 0.0,
    lo_open: false,
    hi: 1.0,
    hi_open: false,
    requirement: "in [0, 1]",
};

impl Domain {
    pub(super) fn contains(&self, x: f64) -> bool {
        let above_lo = if self.lo_open {
            x > self.lo
        } else {
            x >= self.lo
        };
        let below_hi = if self.hi_open {
            x < self.hi
        } else {
            x <= self.hi
        };
        x.is_finite() && above_lo && below_hi
    }

    /// The nearest value inside the domain (for rounding at the ends of a quantile map).
    fn clamp(&self, x: f64) -> f64 {
        let lo = if self.lo_open {
            self.lo.next_up()
        } else {
            self.lo
        };
        let hi = if self.hi_open {
            self.hi.next_down()
        } else {
            self.hi
        };
        if x.is_nan() {
            lo
        } else {
            x.clamp(lo, hi)
        }
    }
}

impl<'de> Deserialize<'de> for Distribution {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        deserializer.deserialize_any(DistributionVisitor)
    }
}

struct DistributionVisitor;

impl<'de> Visitor<'de> for DistributionVisitor {
    type Value = Distribution;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("a number, a range { min = .., max = .. } or a normal { mean = .., sd = .. }")
    }

    fn visit_f64<E: de::Error>(self, v: f64) -> Result<Distribution, E> {
        Ok(Distribution::Fixed(v))
    }

    fn visit_i64<E: de::Error>(self, v: i64) -> Result<Distribution, E> {
        Ok(Distribution::Fixed(v as f64))
    }

    fn visit_u64<E: de::Error>(self, v: u64) -> Result<Distribution, E> {
        Ok(Distribution::Fixed(v as f64))
    }

    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Distribution, A::Error> {
        let (mut min, mut max, mut mean, mut sd) = (None, None, None, None);
        while let Some(key) = map.next_key::<String>()? {
            let slot = match key.as_str() {
                "min" => &mut min,
                "max" => &mut max,
                "mean" => &mut mean,
                "sd" => &mut sd,
                _ => {
                    return Err(de::Error::custom(format!(
                        "unknown key `{key}`: a distribution is {{ min, max }} (uniform) or \
                         {{ mean, sd }} (normal)"
                    )))
                }
            };
            *slot = Some(map.next_value::<f64>()?);
        }
        match (min, max, mean, sd) {
            (Some(min), Some(max), None, None) => Ok(Distribution::Uniform { min, max }),
            (None, None, Some(mean), Some(sd)) => Ok(Distribution::Normal { mean, sd }),
            _ => {
                let given: Vec<&str> = [("min", min), ("max", max), ("mean", mean), ("sd", sd)]
                    .iter()
                    .filter(|(_, v)| v.is_some())
                    .map(|(k, _)| *k)
                    .collect();
                Err(de::Error::custom(format!(
                    "a distribution is {{ min, max }} (uniform) or {{ mean, sd }} (normal), got \
                     {{ {} }}",
                    given.join(", ")
                )))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn domain_clamp_stays_inside_open_and_closed_ends() {
        assert!(SIZE_DOMAIN.contains(SIZE_DOMAIN.clamp(-1.0)));
        assert!(SIZE_DOMAIN.contains(SIZE_DOMAIN.clamp(0.0)));
        assert!(MU_K_DOMAIN.contains(MU_K_DOMAIN.clamp(4.0 / 3.0)));
        assert_eq!(MU_K_DOMAIN.clamp(-0.5), 0.0);
        assert_eq!(RESTITUTION_DOMAIN.clamp(1.5), 1.0);
        assert!(!MU_K_DOMAIN.contains(4.0 / 3.0));
        assert!(!SIZE_DOMAIN.contains(f64::INFINITY));
    }

    #[test]
    fn truncated_normal_quantile_hits_the_domain_ends_at_u_extremes() {
        // A normal with mean 0.05, sd 0.1 on [0, 4/3): u → 0 gives values near 0 (never below),
        // u = ½ gives the median of the truncated law: Φ⁻¹(Φ(−0.5) + ½(1 − Φ(−0.5)))·sd + mean.
        let d = Distribution::Normal {
            mean: 0.05,
            sd: 0.1,
        };
        let lo = d.quantile(1e-12, MU_K_DOMAIN);
        assert!((0.0..1e-9).contains(&lo), "{lo}");
        // Φ(−0.5) = 0.308537538725987; median p = 0.654268769362994, Φ⁻¹(p) = 0.396...
        let p_med = 0.308_537_538_725_987 + 0.5 * (1.0 - 0.308_537_538_725_987);
        let expected = 0.05 + 0.1 * standard_normal_quantile(p_med);
        assert!((d.quantile(0.5, MU_K_DOMAIN) - expected).abs() < 1e-12);
    }
}
