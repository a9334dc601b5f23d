//! Physical units of a channel's input as StationXML writes them (`M/S**2`, `m/s**2`,
//! `M/S2`, `nm/s**2`, `M/S`, `COUNTS`, `V`, …), classified for calibration.

/// What a unit string measures, with its factor to SI.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum UnitKind {
    /// Acceleration; `to_mps2` converts one unit to m/s² (1 for m/s², 1e-9 for nm/s²).
    Acceleration { to_mps2: f64 },
    /// Velocity; `to_mps` converts one unit to m/s.
    Velocity { to_mps: f64 },
    /// Displacement; `to_m` converts one unit to m.
    Displacement { to_m: f64 },
    /// Digitizer counts (the output of a sensitivity).
    Counts,
    /// Anything else (volts, pascals, degrees, unknown spellings).
    Other,
}

/// Classifies a unit name, ignoring case and blanks. Lengths may carry a metric prefix
/// (`nm`, `um`, `mm`, `cm`, `m`); time may be written `S` or `SEC`; the square as `**2`,
/// `^2` or `2`.
#[must_use]
pub fn classify_unit(name: &str) -> UnitKind {
    let unit: String = name
        .chars()
        .filter(|c| !c.is_whitespace())
        .flat_map(char::to_uppercase)
        .collect();
    if matches!(
        unit.as_str(),
        "COUNTS" | "COUNT" | "CNT" | "CNTS" | "DIGITAL" | "DU"
    ) {
        return UnitKind::Counts;
    }
    let (length, time) = match unit.split_once('/') {
        Some((l, t)) => (l, Some(t)),
        None => (unit.as_str(), None),
    };
    let Some(to_m) = metres(length) else {
        return UnitKind::Other;
    };
    match time {
        None => UnitKind::Displacement { to_m },
        Some("S" | "SEC") => UnitKind::Velocity { to_mps: to_m },
        Some("S**2" | "S^2" | "S2" | "SEC**2" | "SEC^2" | "SEC2" | "S/S") => {
            UnitKind::Acceleration { to_mps2: to_m }
        }
        Some(_) => UnitKind::Other,
    }
}

/// The length of one unit of `prefix`+metre, in metres.
fn metres(unit: &str) -> Option<f64> {
    Some(match unit {
        "M" => 1.0,
        "CM" => 1e-2,
        "MM" => 1e-3,
        "UM" | "µM" | "ΜM" => 1e-6,
        "NM" => 1e-9,
        _ => return None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spellings_of_acceleration_velocity_and_counts_are_recognised() {
        for a in [
            "M/S**2",
            "m/s**2",
            "M/S2",
            "m/s^2",
            "M/SEC**2",
            " m / s ** 2 ",
        ] {
            assert_eq!(
                classify_unit(a),
                UnitKind::Acceleration { to_mps2: 1.0 },
                "{a}"
            );
        }
        assert_eq!(
            classify_unit("nm/s**2"),
            UnitKind::Acceleration { to_mps2: 1e-9 }
        );
        assert_eq!(
            classify_unit("CM/S**2"),
            UnitKind::Acceleration { to_mps2: 1e-2 }
        );
        assert_eq!(classify_unit("M/S"), UnitKind::Velocity { to_mps: 1.0 });
        assert_eq!(classify_unit("nm/s"), UnitKind::Velocity { to_mps: 1e-9 });
        assert_eq!(classify_unit("M"), UnitKind::Displacement { to_m: 1.0 });
        for c in ["COUNTS", "counts", "count"] {
            assert_eq!(classify_unit(c), UnitKind::Counts);
        }
        for o in ["V", "PA", "hPa", "M/S**3", "DEGC", ""] {
            assert_eq!(classify_unit(o), UnitKind::Other, "{o}");
        }
    }
}
