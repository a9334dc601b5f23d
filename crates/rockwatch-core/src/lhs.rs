//! Latin-hypercube sampling (McKay, Beckman & Conover 1979) and the small numerical tools
//! that go with it: a reproducible random generator, unbiased integers, the standard normal
//! quantile.
//!
//! A Latin hypercube of `n` samples in `d` dimensions is an `n × d` table of numbers in the
//! open interval (0, 1) such that, in every column (margin), each of the `n` strata
//! `[k/n, (k+1)/n)` holds exactly one value. The stratum of sample `i` in column `j` is
//! `perm_j[i]` for an independent uniformly random permutation `perm_j` of `0..n`, and the
//! value is jittered uniformly within its stratum. Margins can then be mapped to any
//! distribution through its quantile function (e.g. [`standard_normal_quantile`]).
//!
//! # Reproducibility
//! Everything is driven by [`SampleRng`] (ChaCha with 8 rounds) created by [`rng_from_seed`],
//! and uses only the generator's raw `u64` stream (no library distribution code whose
//! algorithm could change between versions): floats by [`uniform_open01`], integers by
//! [`uniform_below`] (Lemire's multiply-and-reject), permutations by Fisher–Yates. The same
//! seed therefore gives bit-identical samples on every platform.
//!
//! Consumption order in [`latin_hypercube`]: for column `j = 0, 1, …, d−1`: first the
//! Fisher–Yates shuffle of `0..n` (`n − 1` bounded integers, `i = n−1` down to `1`), then one
//! jitter per sample `i = 0..n`.

use rand::rngs::ChaCha8Rng;
use rand::{Rng, SeedableRng};

/// The random generator used for all reproducible sampling in rockwatch: ChaCha8.
pub type SampleRng = ChaCha8Rng;

/// The seed of stream `index` derived from `seed`: SplitMix64 of `seed + (index + 1)·γ`
/// (γ = 0x9E3779B97F4A7C15), so streams (the study's pulse pairs, the fragility's bootstrap
/// replicates) get unrelated, reproducible random sequences.
#[must_use]
pub fn derived_seed(seed: u64, index: usize) -> u64 {
    let mut z = seed.wrapping_add((index as u64 + 1).wrapping_mul(0x9E37_79B9_7F4A_7C15));
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// A [`SampleRng`] keyed by `seed`: the 256-bit ChaCha key is `seed` in little-endian order in
/// bytes 0–7 followed by 24 zero bytes, stream 0, position 0. Fully specified by the ChaCha
/// algorithm, so stable across platforms and `rand` versions.
#[must_use]
pub fn rng_from_seed(seed: u64) -> SampleRng {
    let mut key = [0u8; 32];
    key[..8].copy_from_slice(&seed.to_le_bytes());
    SampleRng::from_seed(key)
}

/// 2⁻⁵³: the spacing of the 53-bit grid used by [`uniform_open01`].
const TWO_POW_MINUS_53: f64 = 1.0 / 9_007_199_254_740_992.0;

/// A uniform number in the open interval (0, 1): `(k + ½)·2⁻⁵³` with `k` the top 53 bits of
/// one `u64` from `rng`. Never returns 0 or 1, so it is safe to feed to quantile functions.
pub fn uniform_open01<R: Rng + ?Sized>(rng: &mut R) -> f64 {
    ((rng.next_u64() >> 11) as f64 + 0.5) * TWO_POW_MINUS_53
}

/// An unbiased uniform integer in `0..n` (Lemire 2019, multiply and reject). Returns 0 when
/// `n` is 0 or 1 without consuming randomness.
pub fn uniform_below<R: Rng + ?Sized>(rng: &mut R, n: u64) -> u64 {
    if n <= 1 {
        return 0;
    }
    let mut product = u128::from(rng.next_u64()) * u128::from(n);
    if (product as u64) < n {
        // Values of the low word below 2⁶⁴ mod n would over-represent some results.
        let threshold = n.wrapping_neg() % n;
        while (product as u64) < threshold {
            product = u128::from(rng.next_u64()) * u128::from(n);
        }
    }
    (product >> 64) as u64
}

/// Shuffles `items` in place with the Fisher–Yates algorithm (index `i` from `len−1` down to
/// 1 swaps with `uniform_below(i + 1)`): every permutation is equally likely.
pub fn shuffle<T, R: Rng + ?Sized>(rng: &mut R, items: &mut [T]) {
    for i in (1..items.len()).rev() {
        let j = uniform_below(rng, i as u64 + 1) as usize;
        items.swap(i, j);
    }
}

/// An `n_samples × n_dims` Latin hypercube: values in (0, 1), row-major.
#[derive(Debug, Clone, PartialEq)]
pub struct LatinHypercube {
    n_samples: usize,
    n_dims: usize,
    values: Vec<f64>,
}

impl LatinHypercube {
    /// Number of samples (rows).
    #[must_use]
    pub fn n_samples(&self) -> usize {
        self.n_samples
    }

    /// Number of dimensions (columns, margins).
    #[must_use]
    pub fn n_dims(&self) -> usize {
        self.n_dims
    }

    /// Sample `i` (its `n_dims` coordinates in (0, 1)), or `None` if `i` is out of range.
    #[must_use]
    pub fn sample(&self, i: usize) -> Option<&[f64]> {
        (i < self.n_samples).then(|| &self.values[i * self.n_dims..(i + 1) * self.n_dims])
    }

    /// Iterates over the samples (rows), each a slice of `n_dims` values in (0, 1).
    pub fn samples(&self) -> impl Iterator<Item = &[f64]> {
        // `max(1)` keeps `chunks_exact` valid when there are no dimensions (no values).
        self.values.chunks_exact(self.n_dims.max(1))
    }

    /// Iterates over margin `j` (column `j`, one value per sample); empty if `j` is out of
    /// range.
    pub fn margin(&self, j: usize) -> impl Iterator<Item = f64> + '_ {
        let n = if j < self.n_dims { self.n_samples } else { 0 };
        (0..n).map(move |i| self.values[i * self.n_dims + j])
    }
}

/// Largest `f64` below 1 (1 − 2⁻⁵³).
const ONE_MINUS_ULP: f64 = 1.0 - f64::EPSILON / 2.0;

/// Draws an `n_samples × n_dims` Latin hypercube from `rng` (see the module doc for the
/// algorithm and the order in which randomness is consumed). Each margin has exactly one
/// value in each stratum `[k/n, (k+1)/n)`, `k = 0..n`; all values are in (0, 1).
pub fn latin_hypercube<R: Rng + ?Sized>(
    n_samples: usize,
    n_dims: usize,
    rng: &mut R,
) -> LatinHypercube {
    let mut values = vec![0.0; n_samples * n_dims];
    let mut strata: Vec<usize> = Vec::with_capacity(n_samples);
    let n = n_samples as f64;
    for j in 0..n_dims {
        strata.clear();
        strata.extend(0..n_samples);
        shuffle(rng, &mut strata);
        for (i, &stratum) in strata.iter().enumerate() {
            let u = uniform_open01(rng);
            // (k + u)/n can round up to exactly 1 for the top stratum; the largest double
            // below 1 is still inside that stratum.
            values[i * n_dims + j] = ((stratum as f64 + u) / n).min(ONE_MINUS_ULP);
        }
    }
    LatinHypercube {
        n_samples,
        n_dims,
        values,
    }
}

/// [`latin_hypercube`] driven by [`rng_from_seed`]`(seed)`: same seed, same table.
#[must_use]
pub fn latin_hypercube_seeded(n_samples: usize, n_dims: usize, seed: u64) -> LatinHypercube {
    latin_hypercube(n_samples, n_dims, &mut rng_from_seed(seed))
}

/// Evaluates the polynomial `c[0] + c[1]·x + … + c[7]·x⁷` (Horner).
fn horner8(c: &[f64; 8], x: f64) -> f64 {
    c.iter().rev().fold(0.0, |acc, &ci| acc * x + ci)
}

/// The standard normal quantile Φ⁻¹(p): the `z` with P(Z ≤ z) = p for Z ~ N(0, 1).
///
/// Wichura's algorithm AS 241 (PPND16, Applied Statistics 37(3), 1988, 477–484): rational
/// approximations with relative accuracy about 1e−16 over the whole range. Returns −∞ at
/// `p = 0`, +∞ at `p = 1`, and NaN for `p` outside [0, 1] or NaN.
// The coefficients are kept with all the digits Wichura published (they round to the same f64).
#[allow(clippy::excessive_precision)]
#[must_use]
pub fn standard_normal_quantile(p: f64) -> f64 {
    const A: [f64; 8] = [
        3.387_132_872_796_366_608_0,
        1.331_416_678_917_843_774_5e2,
        1.971_590_950_306_551_442_7e3,
        1.373_169_376_550_946_112_5e4,
        4.592_195_393_154_987_145_7e4,
        6.726_577_092_700_870_085_3e4,
        3.343_057_558_358_812_810_5e4,
        2.509_080_928_730_122_672_7e3,
    ];
    const B: [f64; 8] = [
        1.0,
        4.231_333_070_160_091_125_2e1,
        6.871_870_074_920_579_083_0e2,
        5.394_196_021_424_751_107_7e3,
        2.121_379_430_158_659_586_7e4,
        3.930_789_580_009_271_061_0e4,
        2.872_908_573_572_194_267_4e4,
        5.226_495_278_852_854_561_0e3,
    ];
    const C: [f64; 8] = [
        1.423_437_110_749_683_577_34,
        4.630_337_846_156_545_295_90,
        5.769_497_221_460_691_405_50,
        3.647_848_324_763_204_605_04,
        1.270_458_252_452_368_382_58,
        2.417_807_251_774_506_117_70e-1,
        2.272_384_498_926_918_458_33e-2,
        7.745_450_142_783_414_076_40e-4,
    ];
    const D: [f64; 8] = [
        1.0,
        2.053_191_626_637_758_821_87,
        1.676_384_830_183_803_849_40,
        6.897_673_349_851_000_045_50e-1,
        1.481_039_764_274_800_745_90e-1,
        1.519_866_656_361_645_719_66e-2,
        5.475_938_084_995_344_946_00e-4,
        1.050_750_071_644_416_843_24e-9,
    ];
    const E: [f64; 8] = [
        6.657_904_643_501_103_777_20,
        5.463_784_911_164_114_369_90,
        1.784_826_539_917_291_335_80,
        2.965_605_718_285_048_912_30e-1,
        2.653_218_952_657_612_309_30e-2,
        1.242_660_947_388_078_438_60e-3,
        2.711_555_568_743_487_578_15e-5,
        2.010_334_399_292_288_132_65e-7,
    ];
    const F: [f64; 8] = [
        1.0,
        5.998_322_065_558_879_376_90e-1,
        1.369_298_809_227_358_053_10e-1,
        1.487_536_129_085_061_485_25e-2,
        7.868_691_311_456_132_591_00e-4,
        1.846_318_317_510_054_681_80e-5,
        1.421_511_758_316_445_888_70e-7,
        2.044_263_103_389_939_785_64e-15,
    ];

    if !(0.0..=1.0).contains(&p) {
        return f64::NAN;
    }
    if p == 0.0 {
        return f64::NEG_INFINITY;
    }
    if p == 1.0 {
        return f64::INFINITY;
    }
    let q = p - 0.5;
    if q.abs() <= 0.425 {
        let r = 0.180_625 - q * q;
        return q * horner8(&A, r) / horner8(&B, r);
    }
    let tail = if q < 0.0 { p } else { 1.0 - p };
    let r = (-tail.ln()).sqrt();
    let z = if r <= 5.0 {
        let r = r - 1.6;
        horner8(&C, r) / horner8(&D, r)
    } else {
        let r = r - 5.0;
        horner8(&E, r) / horner8(&F, r)
    };
    if q < 0.0 {
        -z
    } else {
        z
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Φ(x) for x ≤ 0 by composite Simpson integration of the normal density over
    /// [−40, x] (independent of AS 241; Φ(−40) < 1e−300 is negligible). Integrating the tail
    /// directly keeps the *relative* error small: with 40 000 panels, the Simpson bound
    /// h⁴·max|f⁗/f|/180 is about 1e−11 relative, and rounding in the sum adds ~1e−13.
    fn lower_tail_by_quadrature(x: f64) -> f64 {
        let pdf = |t: f64| (-0.5 * t * t).exp() / (2.0 * std::f64::consts::PI).sqrt();
        let (a, n) = (-40.0, 40_000);
        let h = (x - a) / n as f64;
        let mut sum = pdf(a) + pdf(x);
        for k in 1..n {
            let w = if k % 2 == 1 { 4.0 } else { 2.0 };
            sum += w * pdf(a + k as f64 * h);
        }
        sum * h / 3.0
    }

    #[test]
    fn normal_quantile_matches_published_values() {
        // Tabulated quantiles (e.g. Abramowitz & Stegun 26.2; R qnorm), to 1e-12.
        let cases = [
            (0.5, 0.0),
            (0.975, 1.959_963_984_540_054),
            (0.995, 2.575_829_303_548_901),
            (0.9, 1.281_551_565_544_601),
            (0.1, -1.281_551_565_544_601),
            (0.841_344_746_068_542_9, 1.0),
        ];
        for (p, z) in cases {
            let got = standard_normal_quantile(p);
            assert!((got - z).abs() < 1e-12, "p={p}: got {got}, expected {z}");
        }
        // Far tail (third rational branch, r > 5): qnorm(1e-20) = -9.262340089798408.
        let got = standard_normal_quantile(1e-20);
        assert!((got + 9.262_340_089_798_408).abs() < 1e-9, "{got}");
    }

    #[test]
    fn normal_quantile_inverts_quadrature_cdf_on_all_branches() {
        // x covers the central branch (x > -1.44), the middle tail and the far tail
        // (x < -8.3 has sqrt(-ln p) > 5).
        for &x in &[-12.0, -9.0, -6.0, -4.5, -2.0, -1.0, -0.3, 0.0] {
            let p = lower_tail_by_quadrature(x);
            let z = standard_normal_quantile(p);
            // A relative error e in p moves z by e·p/φ(x) ≤ e/|x| (Mills ratio) ≤ e; with
            // e ≈ 1e-11 from the quadrature, 1e-9 is a safe bound (AS 241 itself is ~1e-16).
            assert!((z - x).abs() < 1e-9, "x={x}: got {z}");
        }
    }

    #[test]
    fn normal_quantile_is_antisymmetric_and_handles_edges() {
        // Dyadic p make 1 - p exact, so the two results must be exact negatives; the list
        // visits all three rational branches.
        for &p in &[
            0.25,
            0.375,
            0.468_75,
            0.0625,
            2f64.powi(-20),
            2f64.powi(-40),
        ] {
            assert_eq!(
                standard_normal_quantile(p),
                -standard_normal_quantile(1.0 - p)
            );
        }
        assert_eq!(standard_normal_quantile(0.0), f64::NEG_INFINITY);
        assert_eq!(standard_normal_quantile(1.0), f64::INFINITY);
        assert!(standard_normal_quantile(-0.1).is_nan());
        assert!(standard_normal_quantile(1.5).is_nan());
        assert!(standard_normal_quantile(f64::NAN).is_nan());
    }

    #[test]
    fn latin_hypercube_puts_exactly_one_sample_in_each_stratum_of_each_margin() {
        for &(n, d) in &[(1, 3), (7, 1), (250, 4), (1000, 5)] {
            let lhs = latin_hypercube_seeded(n, d, 42);
            assert_eq!((lhs.n_samples(), lhs.n_dims()), (n, d));
            for j in 0..d {
                let mut seen = vec![0usize; n];
                for u in lhs.margin(j) {
                    assert!(u > 0.0 && u < 1.0, "value {u} outside (0, 1)");
                    seen[(u * n as f64).floor() as usize] += 1;
                }
                assert!(seen.iter().all(|&c| c == 1), "n={n} margin {j}: {seen:?}");
            }
        }
    }

    #[test]
    fn latin_hypercube_rows_and_margins_agree() {
        let lhs = latin_hypercube_seeded(5, 3, 9);
        for (i, row) in lhs.samples().enumerate() {
            assert_eq!(Some(row), lhs.sample(i));
            for (j, &v) in row.iter().enumerate() {
                assert_eq!(lhs.margin(j).nth(i), Some(v));
            }
        }
        assert_eq!(lhs.sample(5), None);
        assert_eq!(lhs.margin(3).count(), 0);
        assert_eq!(latin_hypercube_seeded(0, 4, 1).samples().count(), 0);
    }

    #[test]
    fn latin_hypercube_same_seed_same_table_different_seed_different() {
        let a = latin_hypercube_seeded(100, 4, 7);
        assert_eq!(a, latin_hypercube_seeded(100, 4, 7));
        assert_ne!(a, latin_hypercube_seeded(100, 4, 8));
    }

    #[test]
    fn latin_hypercube_margins_are_independently_permuted() {
        // Two margins with the same stratum order would have correlation ~1. For independent
        // random permutations the rank correlation has sd 1/sqrt(n-1) ≈ 0.02 (n = 2000), so
        // |r| < 0.1 is a 5-sigma bound.
        let n = 2000;
        let lhs = latin_hypercube_seeded(n, 3, 3);
        let mean = 0.5;
        for (j, k) in [(0, 1), (0, 2), (1, 2)] {
            let (mut sxy, mut sxx, mut syy) = (0.0, 0.0, 0.0);
            for (x, y) in lhs.margin(j).zip(lhs.margin(k)) {
                sxy += (x - mean) * (y - mean);
                sxx += (x - mean) * (x - mean);
                syy += (y - mean) * (y - mean);
            }
            let r = sxy / (sxx * syy).sqrt();
            assert!(r.abs() < 0.1, "margins {j},{k}: correlation {r}");
        }
    }

    #[test]
    fn uniform_below_is_in_range_and_unbiased() {
        // Chi-square with 6 degrees of freedom for n = 7 over 70 000 draws: the 99.99 %
        // point is 27.9.
        let mut rng = rng_from_seed(5);
        let mut counts = [0u32; 7];
        for _ in 0..70_000 {
            counts[uniform_below(&mut rng, 7) as usize] += 1;
        }
        let expected = 10_000.0;
        let chi2: f64 = counts
            .iter()
            .map(|&c| (f64::from(c) - expected).powi(2) / expected)
            .sum();
        assert!(chi2 < 27.9, "chi2 = {chi2}, counts {counts:?}");
        assert_eq!(uniform_below(&mut rng, 0), 0);
        assert_eq!(uniform_below(&mut rng, 1), 0);
    }

    #[test]
    fn uniform_open01_matches_its_formula_on_the_raw_stream() {
        // Independent check against the documented construction on a twin generator.
        let mut a = rng_from_seed(11);
        let mut b = rng_from_seed(11);
        for _ in 0..1000 {
            let u = uniform_open01(&mut a);
            let k = b.next_u64() >> 11;
            assert_eq!(u, (k as f64 + 0.5) / 2f64.powi(53));
            assert!(u > 0.0 && u < 1.0);
        }
    }

    #[test]
    fn shuffle_is_a_permutation() {
        let mut rng = rng_from_seed(1);
        let mut items: Vec<u32> = (0..100).collect();
        shuffle(&mut rng, &mut items);
        let mut sorted = items.clone();
        sorted.sort_unstable();
        assert_eq!(sorted, (0..100).collect::<Vec<_>>());
        assert_ne!(
            items, sorted,
            "a 100-element shuffle left everything in place"
        );
    }
}
