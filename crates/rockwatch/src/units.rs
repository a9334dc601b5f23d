//! Units of accelerations in text output and plots (`--units g|m/s2`): the one conversion
//! of every table, summary line and plot axis that shows an acceleration IM (PGA, SA(T), and
//! the other IMs in m/s²: SMA, EDA, A_RMS). JSON and CSV files keep SI units whatever the
//! choice (their `unit` fields and column headers say m/s2), so that a program reading them
//! never depends on a display option; velocities, displacements and times are always SI.

use rockwatch_core::STANDARD_GRAVITY_MPS2;

/// How accelerations are shown.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum AccelUnits {
    /// m/s² (SI; written `m/s2`, as the JSON's `unit` fields).
    #[default]
    #[value(name = "m/s2")]
    Mps2,
    /// Standard gravity, g = 9.80665 m/s² exactly.
    #[value(name = "g")]
    G,
}

impl AccelUnits {
    /// The unit a value of SI unit `si_unit` is shown in, and the divisor from SI: `("g",
    /// 9.80665)` for an acceleration (`m/s2`) shown in g, `(si_unit, 1)` otherwise.
    #[must_use]
    pub fn show(self, si_unit: &str) -> (&str, f64) {
        match self {
            AccelUnits::G if si_unit == "m/s2" => ("g", STANDARD_GRAVITY_MPS2),
            _ => (si_unit, 1.0),
        }
    }

    /// `value_si` (in `si_unit`) in the shown unit.
    #[must_use]
    pub fn value(self, value_si: f64, si_unit: &str) -> f64 {
        value_si / self.show(si_unit).1
    }
}

#[cfg(test)]
mod tests {
    use super::AccelUnits;

    #[test]
    fn only_accelerations_change_and_g_is_standard_gravity() {
        assert_eq!(AccelUnits::G.show("m/s2"), ("g", 9.806_65));
        assert!((AccelUnits::G.value(9.806_65 * 0.3, "m/s2") - 0.3).abs() < 1e-15);
        assert_eq!(AccelUnits::G.show("m/s"), ("m/s", 1.0));
        assert_eq!(AccelUnits::G.show("s"), ("s", 1.0));
        assert_eq!(AccelUnits::Mps2.show("m/s2"), ("m/s2", 1.0));
    }
}
