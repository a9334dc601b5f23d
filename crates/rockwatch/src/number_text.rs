//! Numbers in text output: [`SIGNIFICANT_DIGITS`] significant digits, the one rule of every
//! text summary, table and plot label (JSON output keeps every digit). The inputs of the
//! models (sizes, friction, records, fragility fits) are not known to more, and a
//! `0.4458421458288538 m` reads as a precision the rock does not have.

use rockwatch_core::dynamics::BlockParams;

/// Significant digits of a number in text output.
pub const SIGNIFICANT_DIGITS: i32 = 4;

/// `x` in JSON output, every digit kept: a number, or null when it is not finite (JSON has no
/// infinity or NaN).
#[must_use]
pub fn json_number(x: f64) -> serde_json::Value {
    if x.is_finite() {
        serde_json::json!(x)
    } else {
        serde_json::Value::Null
    }
}

/// `x` with [`SIGNIFICANT_DIGITS`] significant digits at most, without trailing zeros
/// (`0.5806125` → `0.5806`, `1.25` → `1.25`, `2000` → `2000`, `123456.7` → `123457`), in
/// scientific notation below 10⁻⁴ and from 10⁷ in magnitude (`1.235e-5`, `1.2e9`), so that no
/// significant digit is lost to the decimals.
#[must_use]
pub fn short_number(x: f64) -> String {
    if x == 0.0 {
        // −0 too: a rounding of nothing has no sign worth printing.
        return "0".to_string();
    }
    if !x.is_finite() {
        return format!("{x}");
    }
    let magnitude = x.abs().log10().floor() as i32;
    if !(-4..7).contains(&magnitude) {
        let text = format!("{x:.prec$e}", prec = (SIGNIFICANT_DIGITS - 1) as usize);
        return match text.split_once('e') {
            Some((mantissa, exponent)) if mantissa.contains('.') => format!(
                "{}e{exponent}",
                mantissa.trim_end_matches('0').trim_end_matches('.')
            ),
            _ => text,
        };
    }
    let decimals = (SIGNIFICANT_DIGITS - 1 - magnitude).max(0) as usize;
    let text = format!("{x:.decimals$}");
    if text.contains('.') {
        text.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        text
    }
}

/// A planar block in words: its geometry (rectangle `B = …, H = …, α = …°`, or a general body
/// `b+ = …, b- = …, h = …, rho = …, α+ = …°, α- = …°`; lengths in m) and its friction
/// (`μs = …, μk = …`), every number through [`short_number`].
#[must_use]
pub fn block_label(params: &BlockParams) -> String {
    format!(
        "{}, μs = {}, μk = {}",
        params.geometry_label_with(short_number, short_number),
        short_number(params.mu_s),
        short_number(params.mu_k)
    )
}

#[cfg(test)]
mod tests {
    use super::short_number;

    #[test]
    fn short_numbers_keep_four_significant_digits_without_trailing_zeros() {
        assert_eq!(short_number(0.580_612_549_439_202_5), "0.5806");
        assert_eq!(short_number(12.097_519_329_225_65), "12.1");
        assert_eq!(short_number(0.445_842_145_828_853_8), "0.4458");
        assert_eq!(short_number(1.25), "1.25");
        assert_eq!(short_number(2000.0), "2000");
        assert_eq!(short_number(123_456.7), "123457");
        assert_eq!(short_number(-0.000_123_456), "-0.0001235");
        assert_eq!(short_number(0.0), "0");
        assert_eq!(short_number(-0.0), "0");
        // Beyond the fixed-point range: scientific, still four digits.
        assert_eq!(short_number(0.000_012_345_6), "1.235e-5");
        assert_eq!(short_number(-3.0e-9), "-3e-9");
        assert_eq!(short_number(1.234_56e9), "1.235e9");
        assert_eq!(short_number(f64::NAN), "NaN");
    }
}
