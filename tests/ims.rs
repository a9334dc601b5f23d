//! Intensity measures: checked against published values, closed forms and naive
//! implementations written here (never against the library's own output), plus
//! running == offline on every developer record, plus the `rockwatch ims` CLI.

use rockwatch_core::ims::spectrum::{period_grid_s, response_spectrum, spectral_intensities};
use rockwatch_core::ims::{
    compute_ims, response, study_ims, ImOptions, ImSet, PeriodRange, RunningConfig, RunningIms,
    STUDY_RANGES,
};
use rockwatch_core::record::{Record, STANDARD_GRAVITY_MPS2};
use rockwatch_test_harness::rockwatch_bin;
use std::f64::consts::PI;
use std::path::{Path, PathBuf};
use std::process::Command;

fn records_dir() -> PathBuf {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../..")).join("tests/data/records")
}

fn read_record(name: &str) -> Record {
    Record::read(&records_dir().join(name)).unwrap()
}

/// Every developer record (file name, record), sorted by name.
fn all_records() -> Vec<(String, Record)> {
    let mut names: Vec<String> = std::fs::read_dir(records_dir())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.to_ascii_lowercase().ends_with(".at2"))
        .collect();
    names.sort();
    assert_eq!(names.len(), 8, "expected the 8 developer records");
    names
        .into_iter()
        .map(|n| {
            let r = read_record(&n);
            (n, r)
        })
        .collect()
}

fn assert_close(what: &str, got: f64, want: f64, rel: f64, abs: f64) {
    let tol = abs + rel * want.abs();
    assert!(
        (got - want).abs() <= tol,
        "{what}: got {got:e}, want {want:e} (diff {:e} > tol {tol:e})",
        (got - want).abs()
    );
}

/// `n` samples of `amplitude·sin(2π·i/samples_per_cycle)`.
fn sine(amplitude: f64, samples_per_cycle: usize, n: usize) -> Vec<f64> {
    (0..n)
        .map(|i| amplitude * (2.0 * PI * i as f64 / samples_per_cycle as f64).sin())
        .collect()
}

// ---------------------------------------------------------------------------------------
// Naive reference implementations (independent of the library).

/// SDOF `ü + 2ξωu̇ + ω²u = −a(t)` from rest, `a` linear between samples, integrated by
/// classical RK4 with sub-steps of `ω·h ≤ 0.02`. Returns the peaks of |u| and |u̇| at the
/// input instants.
fn naive_sdof_peaks(accel: &[f64], dt: f64, period: f64, xi: f64) -> (f64, f64) {
    let w = 2.0 * PI / period;
    let substeps = ((w * dt / 0.02).ceil() as usize).max(1);
    let h = dt / substeps as f64;
    let (mut u, mut v) = (0.0_f64, 0.0_f64);
    let (mut sd, mut sv) = (0.0_f64, 0.0_f64);
    for pair in accel.windows(2) {
        let (a0, a1) = (pair[0], pair[1]);
        let ground = |tau: f64| a0 + (a1 - a0) * tau / dt;
        let f = |tau: f64, u: f64, v: f64| (v, -ground(tau) - 2.0 * xi * w * v - w * w * u);
        for s in 0..substeps {
            let tau = s as f64 * h;
            let (k1u, k1v) = f(tau, u, v);
            let (k2u, k2v) = f(tau + h / 2.0, u + h / 2.0 * k1u, v + h / 2.0 * k1v);
            let (k3u, k3v) = f(tau + h / 2.0, u + h / 2.0 * k2u, v + h / 2.0 * k2v);
            let (k4u, k4v) = f(tau + h, u + h * k3u, v + h * k3v);
            u += h / 6.0 * (k1u + 2.0 * k2u + 2.0 * k3u + k4u);
            v += h / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v);
        }
        sd = sd.max(u.abs());
        sv = sv.max(v.abs());
    }
    (sd, sv)
}

/// Husid times by direct loops: normalised Husid curve, first sample reaching p, linear
/// interpolation.
fn naive_husid_times(accel: &[f64], dt: f64) -> [f64; 3] {
    let mut cumulative = vec![0.0];
    for i in 1..accel.len() {
        let previous = cumulative[i - 1];
        cumulative.push(previous + dt * (accel[i - 1].powi(2) + accel[i].powi(2)) / 2.0);
    }
    let total = *cumulative.last().unwrap();
    let husid: Vec<f64> = cumulative.iter().map(|e| e / total).collect();
    [0.05, 0.75, 0.95].map(|p| {
        let mut i = 0;
        while husid[i] < p {
            i += 1;
        }
        if i == 0 {
            0.0
        } else {
            (i - 1) as f64 * dt + dt * (p - husid[i - 1]) / (husid[i] - husid[i - 1])
        }
    })
}

/// SMA by splitting the record into explicit half-cycles.
fn naive_sma(accel: &[f64]) -> f64 {
    let mut half_cycles: Vec<Vec<f64>> = Vec::new();
    let mut current: Vec<f64> = Vec::new();
    for &a in accel {
        let same = current
            .last()
            .is_some_and(|&b: &f64| a != 0.0 && a.signum() == b.signum());
        if !same && !current.is_empty() {
            half_cycles.push(std::mem::take(&mut current));
        }
        if a != 0.0 {
            current.push(a);
        }
    }
    if !current.is_empty() {
        half_cycles.push(current);
    }
    let mut peaks: Vec<f64> = half_cycles
        .iter()
        .map(|c| c.iter().map(|a| a.abs()).fold(0.0, f64::max))
        .collect();
    peaks.sort_by(|a, b| b.partial_cmp(a).unwrap());
    peaks.get(2).copied().unwrap_or(0.0)
}

// ---------------------------------------------------------------------------------------
// Published values.

#[test]
fn pga_cav_arias_match_published_values_for_all_records() {
    let text = std::fs::read_to_string(records_dir().join("im_expected.json")).unwrap();
    let expected: serde_json::Value = serde_json::from_str(&text).unwrap();
    let entries = expected["records"].as_array().unwrap();
    assert_eq!(entries.len(), 8);
    for entry in entries {
        let name = entry["file"].as_str().unwrap();
        let record = read_record(name);
        assert_eq!(record.len() as u64, entry["npts"].as_u64().unwrap());
        let ims = compute_ims(&record.horizontal_mps2, record.dt_s, &ImOptions::default()).unwrap();
        // PGA is one file value × 9.80665: only the rounding of that product.
        assert_close(
            name,
            ims.pga_mps2,
            entry["pga_mps2"].as_f64().unwrap(),
            1e-14,
            0.0,
        );
        // CAV and Arias are sums of ~1e4 terms; a different summation order (the reference
        // tooling is NumPy, pairwise) changes them by up to ~N·ε ≈ 1e-12 relative: tol 1e-11.
        assert_close(
            name,
            ims.cav_mps,
            entry["cav_mps"].as_f64().unwrap(),
            1e-11,
            0.0,
        );
        assert_close(
            name,
            ims.arias_mps,
            entry["arias_mps"].as_f64().unwrap(),
            1e-11,
            0.0,
        );
    }
}

// ---------------------------------------------------------------------------------------
// Closed forms.

#[test]
fn arias_of_sine_matches_closed_form() {
    // a = A sin(2πt/P) over whole cycles. For M ≥ 3 uniform samples per cycle,
    // Σ sin² = M/2 exactly and the end samples are 0, so the trapezoid of a² is exactly
    // A²·Td/2: Ia = π/(2g)·A²·Td/2 up to rounding.
    let (amplitude, per_cycle, cycles, dt) = (3.0, 50, 40, 0.004);
    let accel = sine(amplitude, per_cycle, per_cycle * cycles + 1);
    let td = (per_cycle * cycles) as f64 * dt;
    let ims = compute_ims(&accel, dt, &ImOptions::default()).unwrap();
    let want = PI / (2.0 * STANDARD_GRAVITY_MPS2) * amplitude * amplitude * td / 2.0;
    assert_close("Arias", ims.arias_mps, want, 1e-12, 0.0);
}

#[test]
fn cav_pgv_pgd_of_sine_match_closed_forms() {
    // a = A sin ωt over whole cycles: CAV = 2A·Td/π, v = A/ω·(1 − cos ωt) so PGV = 2A/ω,
    // d = A/ω·(t − sin(ωt)/ω) is increasing so PGD = A·Td/ω. The trapezoid rule with
    // M = 1000 samples per cycle is off by about (2π/M)²/12 ≈ 3.3e-6 relative: tol 1e-5.
    let (amplitude, per_cycle, cycles, dt) = (2.0, 1000, 5, 0.001);
    let accel = sine(amplitude, per_cycle, per_cycle * cycles + 1);
    let td = (per_cycle * cycles) as f64 * dt;
    let w = 2.0 * PI / (per_cycle as f64 * dt);
    let ims = compute_ims(&accel, dt, &ImOptions::default()).unwrap();
    assert_close("CAV", ims.cav_mps, 2.0 * amplitude * td / PI, 1e-5, 0.0);
    assert_close("PGV", ims.pgv_mps, 2.0 * amplitude / w, 1e-5, 0.0);
    assert_close("PGD", ims.pgd_m, amplitude * td / w, 1e-5, 0.0);
    assert_close("PGA", ims.pga_mps2, amplitude, 1e-12, 0.0);
    assert_close("PGV/PGA", ims.pgv_pga_s, 2.0 / w, 1e-5, 0.0);
}

#[test]
fn durations_of_constant_record_match_closed_form() {
    // a = c: the Husid curve is exactly linear, t_p = p·Td, D5-95 = 0.9·Td, a_rms = c,
    // Ic = c^1.5·sqrt(0.9·Td). Only rounding separates the values: tol 1e-12.
    let (c, n, dt) = (1.5, 2001, 0.005);
    let td = (n - 1) as f64 * dt;
    let ims = compute_ims(&vec![c; n], dt, &ImOptions::default()).unwrap();
    assert_close("t5", ims.t5_s, 0.05 * td, 1e-12, 0.0);
    assert_close("t75", ims.t75_s, 0.75 * td, 1e-12, 0.0);
    assert_close("t95", ims.t95_s, 0.95 * td, 1e-12, 0.0);
    assert_close("D5-75", ims.d5_75_s, 0.70 * td, 1e-12, 0.0);
    assert_close("D5-95", ims.d5_95_s, 0.90 * td, 1e-12, 0.0);
    assert_close("a_rms", ims.a_rms_mps2, c, 1e-12, 0.0);
    assert_close("Ic", ims.ic, c.powf(1.5) * (0.9 * td).sqrt(), 1e-12, 0.0);
}

#[test]
fn durations_match_direct_loops_on_every_record() {
    // Same definition evaluated independently; the two only differ in rounding of the
    // normalisation, and the interpolated time is continuous, so 1e-9 s is ample.
    for (name, record) in all_records() {
        let a = &record.horizontal_mps2;
        let ims = compute_ims(a, record.dt_s, &ImOptions::default()).unwrap();
        let [t5, t75, t95] = naive_husid_times(a, record.dt_s);
        assert_close(&format!("{name} t5"), ims.t5_s, t5, 0.0, 1e-9);
        assert_close(&format!("{name} t75"), ims.t75_s, t75, 0.0, 1e-9);
        assert_close(&format!("{name} t95"), ims.t95_s, t95, 0.0, 1e-9);
        assert_close(&format!("{name} D5-75"), ims.d5_75_s, t75 - t5, 0.0, 1e-9);
        let energy: f64 = a
            .windows(2)
            .map(|w| record.dt_s * (w[0] * w[0] + w[1] * w[1]) / 2.0)
            .sum();
        let a_rms = (0.9 * energy / (t95 - t5)).sqrt();
        assert_close(&format!("{name} a_rms"), ims.a_rms_mps2, a_rms, 1e-9, 0.0);
        assert_close(
            &format!("{name} Ic"),
            ims.ic,
            a_rms.powf(1.5) * (t95 - t5).sqrt(),
            1e-9,
            0.0,
        );
    }
}

#[test]
fn sma_matches_explicit_half_cycles_on_every_record() {
    for (name, record) in all_records() {
        let ims = compute_ims(&record.horizontal_mps2, record.dt_s, &ImOptions::default()).unwrap();
        assert_eq!(ims.sma_mps2, naive_sma(&record.horizontal_mps2), "{name}");
        assert!(ims.sma_mps2 > 0.0 && ims.sma_mps2 <= ims.pga_mps2, "{name}");
    }
}

#[test]
fn sa_matches_naive_rk4_on_linear_interpolant() {
    // RK4 with ω·h ≤ 0.02 has a local error ~ (ωh)⁵/120 ≈ 3e-11 per step; 5 % damping
    // forgets errors after ~1/(ξωh) = 1000 steps, so the peaks agree to ~1e-7: tol 1e-6.
    // PTH090 has dt = 0.02 s (the coarse case) and 0.137 s is off the grid.
    for name in ["RSN1059_NORTHR_PTH090.AT2", "Rinaldi228.AT2"] {
        let record = read_record(name);
        for period in [0.1, 0.137, 0.3, 1.0, 3.0] {
            let got = response(&record.horizontal_mps2, record.dt_s, period, 0.05).unwrap();
            let (sd, sv) = naive_sdof_peaks(&record.horizontal_mps2, record.dt_s, period, 0.05);
            let w = 2.0 * PI / period;
            let what = format!("{name} T={period}");
            assert_close(&format!("{what} Sd"), got.sd_m, sd, 1e-6, 0.0);
            assert_close(&format!("{what} SV"), got.sv_mps, sv, 1e-6, 0.0);
            assert_close(&format!("{what} SA"), got.sa_mps2, w * w * sd, 1e-6, 0.0);
            assert_close(&format!("{what} PSV"), got.psv_mps, w * sd, 1e-6, 0.0);
        }
    }
}

#[test]
fn sa_of_resonant_harmonic_matches_steady_state_amplitude() {
    // a = A sin ωt at the oscillator's own ω: the steady-state amplitude is
    // u0 = A/(2ξω²), so SA = ω²u0 = A/(2ξ) and SV = ωu0. From rest the envelope grows as
    // 1 − e^(−ξωt) and never overshoots; after 200 cycles e^(−ξωt) ≈ e^(−63). Sampling the
    // crest (1000 samples per cycle) and the linear interpolation of the input each cost
    // ≈ (ωdt)²/8 ≈ 5e-6: tol 1e-4.
    let (amplitude, per_cycle, cycles) = (1.2, 1000, 200);
    let period = 0.5;
    let dt = period / per_cycle as f64;
    let accel = sine(amplitude, per_cycle, per_cycle * cycles + 1);
    let got = response(&accel, dt, period, 0.05).unwrap();
    let w = 2.0 * PI / period;
    assert_close("SA", got.sa_mps2, amplitude / (2.0 * 0.05), 1e-4, 0.0);
    assert_close("SV", got.sv_mps, amplitude / (2.0 * 0.05 * w), 1e-4, 0.0);
    // And the predominant period of that motion is its period (the 5 % SA peak of a
    // harmonic is at 0.9975·T = 0.49875 s, nearest grid point 0.50 s).
    let ims = compute_ims(&accel, dt, &ImOptions::default()).unwrap();
    assert_eq!(ims.tp_s, 0.5);
}

#[test]
fn eda_of_tapered_sine_matches_butterworth_squared_gain() {
    // Zero-phase 4th-order Butterworth (forward–backward): a steady sine of frequency f
    // comes out scaled by G(f) = 1/(1 + (tan(πf dt)/tan(π·9·dt))⁸), G(9 Hz) = 1/2.
    // The sine has a Hann envelope over 30 s (slow, so edge transients vanish and the
    // envelope's curvature changes the peak by ~1e-4: tol 5e-4) and a crest on the centre sample.
    let dt = 1.0 / 180.0;
    for (f, per_cycle) in [(1.0, 180), (9.0, 20), (15.0, 12)] {
        let centre = (2700 / per_cycle) * per_cycle + per_cycle / 4;
        let n = 2 * centre + 1;
        let accel: Vec<f64> = (0..n)
            .map(|i| {
                let envelope = (PI * i as f64 / (n - 1) as f64).sin().powi(2);
                envelope * (2.0 * PI * i as f64 / per_cycle as f64).sin()
            })
            .collect();
        let ims = compute_ims(&accel, dt, &ImOptions::default()).unwrap();
        let r = (PI * f * dt).tan() / (PI * 9.0 * dt).tan();
        let gain = 1.0 / (1.0 + r.powi(8));
        assert_close(&format!("EDA at {f} Hz"), ims.eda_mps2, gain, 5e-4, 0.0);
    }
}

#[test]
fn epv_and_spectral_intensities_match_naive_integration() {
    // Naive RK4 spectra on the grid points (tolerance as for SA), then the definitions:
    // EPV = mean PSV over 0.80..=1.20 s / 2.5; ASI/SI/VSI = trapezoid over 0.10..=0.50 s.
    let record = read_record("Rinaldi228.AT2");
    let (a, dt) = (&record.horizontal_mps2, record.dt_s);
    let ims = compute_ims(a, dt, &ImOptions::default()).unwrap();
    let naive = |k: u32| {
        let period = f64::from(k) / 100.0;
        let (sd, sv) = naive_sdof_peaks(a, dt, period, 0.05);
        let w = 2.0 * PI / period;
        (w * w * sd, w * sd, sv)
    };
    let psv_band: Vec<f64> = (80..=120).map(|k| naive(k).1).collect();
    let epv = psv_band.iter().sum::<f64>() / 41.0 / 2.5;
    assert_close("EPV", ims.epv_mps, epv, 1e-6, 0.0);
    let points: Vec<(f64, f64, f64)> = (10..=50).map(naive).collect();
    let trapezoid = |pick: fn(&(f64, f64, f64)) -> f64| {
        points
            .windows(2)
            .map(|w| 0.01 * (pick(&w[0]) + pick(&w[1])) / 2.0)
            .sum::<f64>()
    };
    let si = ims.study_intensities[0];
    assert_eq!(si.range, PeriodRange::new(10, 50));
    assert_close("ASI 0.1-0.5", si.asi_mps, trapezoid(|p| p.0), 1e-6, 0.0);
    assert_close("SI 0.1-0.5", si.si_m, trapezoid(|p| p.1), 1e-6, 0.0);
    assert_close("VSI 0.1-0.5", si.vsi_m, trapezoid(|p| p.2), 1e-6, 0.0);
}

#[test]
fn study_ims_are_the_37_named_values() {
    let record = read_record("Rinaldi228.AT2");
    let ims = compute_ims(&record.horizontal_mps2, record.dt_s, &ImOptions::default()).unwrap();
    let study = study_ims(&ims);
    let get = |name: &str| {
        study
            .iter()
            .find(|(n, _)| n.study_name() == name)
            .unwrap()
            .1
    };
    assert_eq!(study.len(), 37);
    assert_eq!(get("pha"), ims.pga_mps2);
    assert_eq!(get("phv"), ims.pgv_mps);
    assert_eq!(get("phd"), ims.pgd_m);
    assert_eq!(get("cav"), ims.cav_mps);
    assert_eq!(get("epv"), ims.epv_mps);
    assert_eq!(get("d5_95"), ims.d5_95_s);
    for si in &ims.study_intensities {
        let label = si.range.label();
        assert_eq!(get(&format!("asi_{label}")), si.asi_mps);
        assert_eq!(get(&format!("si_{label}")), si.si_m);
        assert_eq!(get(&format!("vsi_{label}")), si.vsi_m);
    }
    let labels: Vec<String> = STUDY_RANGES.iter().map(PeriodRange::label).collect();
    assert_eq!(
        labels,
        ["0.1-0.5", "0.1-2.5", "0.5-1.0", "1.0-1.5", "1.5-2.0", "2.0-2.5", "2.5-3.0", "1.0-2.5"]
    );
}

// ---------------------------------------------------------------------------------------
// Running == offline.

fn assert_running_equals_offline(what: &str, running: &RunningIms, offline: &ImSet) {
    // The running values form the same sums in the same order; 1e-12 relative (plus 1e-15
    // absolute for values near 0) leaves room for rounding only.
    let close = |name: &str, got: f64, want: f64| {
        assert_close(&format!("{what}: {name}"), got, want, 1e-12, 1e-15);
    };
    close("PGA", running.pga_mps2(), offline.pga_mps2);
    close("PGV", running.pgv_mps(), offline.pgv_mps);
    close("PGD", running.pgd_m(), offline.pgd_m);
    close("CAV", running.cav_mps(), offline.cav_mps);
    close("Arias", running.arias_mps(), offline.arias_mps);
    close("t5", running.t5_s(), offline.t5_s);
    close("t75", running.t75_s(), offline.t75_s);
    close("t95", running.t95_s(), offline.t95_s);
    close("D5-75", running.d5_75_s(), offline.d5_75_s);
    close("D5-95", running.d5_95_s(), offline.d5_95_s);
    close("a_rms", running.a_rms_mps2(), offline.a_rms_mps2);
    close("Ic", running.ic(), offline.ic);
    close("SMA", running.sma_mps2(), offline.sma_mps2);
    let spectral: Vec<_> = running.spectral().collect();
    assert_eq!(spectral.len(), offline.spectral.len());
    for (r, o) in spectral.iter().zip(&offline.spectral) {
        assert_eq!(r.period_s, o.period_s);
        close(&format!("SA({})", o.period_s), r.sa_mps2, o.sa_mps2);
        close(&format!("SV({})", o.period_s), r.sv_mps, o.sv_mps);
    }
    let intensities: Vec<_> = running.intensities().collect();
    assert_eq!(intensities.len(), 8);
    for (r, o) in intensities.iter().zip(&offline.study_intensities) {
        assert_eq!(r.range, o.range);
        let label = o.range.label();
        close(&format!("ASI {label}"), r.asi_mps, o.asi_mps);
        close(&format!("SI {label}"), r.si_m, o.si_m);
        close(&format!("VSI {label}"), r.vsi_m, o.vsi_m);
    }
}

#[test]
fn running_ims_equal_offline_at_cut_points_on_every_record() {
    for (name, record) in all_records() {
        let a = &record.horizontal_mps2;
        let n = a.len();
        let mut cuts = vec![1, 2, 3, 17, n / 10, n / 3, n / 2, (2 * n) / 3, n - 1, n];
        cuts.sort_unstable();
        cuts.dedup();
        let mut running = RunningIms::new(record.dt_s, &RunningConfig::study()).unwrap();
        let mut pushed = 0;
        for &cut in &cuts {
            while pushed < cut {
                running.push(a[pushed]);
                pushed += 1;
            }
            let offline = compute_ims(&a[..cut], record.dt_s, &ImOptions::default()).unwrap();
            assert_eq!(running.npts(), cut);
            assert_running_equals_offline(&format!("{name} [..{cut}]"), &running, &offline);
        }
    }
}

#[test]
fn running_live_set_equals_offline_spectrum_on_coarse_grid() {
    // The live default integrates ASI over 0.10, 0.12, …, 0.50 s (the 0.02 s grid).
    let record = read_record("RSN181_IMPVALL.H_H-E06230.AT2");
    let a = &record.horizontal_mps2;
    let mut running = RunningIms::new(record.dt_s, &RunningConfig::live_default()).unwrap();
    for &x in a {
        running.push(x);
    }
    let coarse: Vec<f64> = period_grid_s(2).into_iter().filter(|&t| t <= 0.5).collect();
    assert_eq!(coarse.len(), 21);
    let spectrum = response_spectrum(a, record.dt_s, &coarse, 0.05).unwrap();
    let want = spectral_intensities(&spectrum, PeriodRange::new(10, 50));
    let got = running.intensities().next().unwrap();
    assert_close("ASI", got.asi_mps, want.asi_mps, 1e-12, 0.0);
    assert_close("SI", got.si_m, want.si_m, 1e-12, 0.0);
    assert_close("VSI", got.vsi_m, want.vsi_m, 1e-12, 0.0);
    for period in [0.3, 1.0, 3.0] {
        let want = response(a, record.dt_s, period, 0.05).unwrap().sa_mps2;
        assert_close("SA", running.sa_mps2(period).unwrap(), want, 1e-12, 0.0);
    }
    // reset() starts a new window.
    running.reset();
    assert_eq!(running.npts(), 0);
    assert_eq!(running.pga_mps2(), 0.0);
    assert_eq!(running.sa_mps2(1.0), Some(0.0));
}

// ---------------------------------------------------------------------------------------
// CLI.

const JSON_KEYS: [&str; 24] = [
    "pga", "pgv", "pgd", "cav", "arias", "t5", "t75", "t95", "d5_75", "d5_95", "a_rms", "ic",
    "sma", "eda", "tp", "pgv_pga", "epv", "sa", "asi", "si", "vsi", "dt", "npts", "vertical",
];

#[test]
fn ims_json_has_every_documented_key() {
    let dir = records_dir();
    let horizontal = dir.join("Rinaldi228.AT2");
    let vertical = dir.join("RinaldiUP.AT2");
    let out = rockwatch_bin!().output(&[
        "ims",
        "--record",
        horizontal.to_str().unwrap(),
        "--vertical",
        vertical.to_str().unwrap(),
        "--format",
        "json",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let object = json.as_object().unwrap();
    let mut keys: Vec<&str> = object.keys().map(String::as_str).collect();
    keys.sort_unstable();
    let mut want = JSON_KEYS.to_vec();
    want.sort_unstable();
    assert_eq!(keys, want);
    let periods: Vec<&str> = json["sa"]
        .as_object()
        .unwrap()
        .keys()
        .map(String::as_str)
        .collect();
    assert_eq!(periods.len(), 9);
    for p in [
        "0.1", "0.2", "0.3", "0.5", "1.0", "1.5", "2.0", "2.5", "3.0",
    ] {
        assert!(periods.contains(&p), "sa lacks {p}: {periods:?}");
    }
    for key in ["asi", "si", "vsi"] {
        let ranges = json[key].as_object().unwrap();
        assert_eq!(ranges.len(), 8, "{key}");
        for r in [
            "0.1-0.5", "0.1-2.5", "0.5-1.0", "1.0-1.5", "1.5-2.0", "2.0-2.5", "2.5-3.0", "1.0-2.5",
        ] {
            assert!(ranges[r].as_f64().unwrap() > 0.0, "{key} {r}");
        }
    }
    assert_eq!(json["npts"].as_u64(), Some(1991));
    assert_eq!(json["dt"].as_f64(), Some(0.01));
    // Published PGAs (im_expected.json) of the two components.
    assert_close(
        "pga",
        json["pga"].as_f64().unwrap(),
        8.57159657634,
        1e-14,
        0.0,
    );
    let v = json["vertical"].as_object().unwrap();
    assert_eq!(v.len(), JSON_KEYS.len() - 1);
    assert_close(
        "vertical pga",
        v["pga"].as_f64().unwrap(),
        9.396427043185,
        1e-14,
        0.0,
    );
}

#[test]
fn ims_custom_periods_become_sa_keys() {
    let record = records_dir().join("RSN1059_NORTHR_PTH090.AT2");
    let out = rockwatch_bin!().output(&[
        "ims",
        "--record",
        record.to_str().unwrap(),
        "--periods",
        "0.25,1,2.0",
        "--format",
        "json",
    ]);
    assert!(out.status.success());
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let mut keys: Vec<&str> = json["sa"]
        .as_object()
        .unwrap()
        .keys()
        .map(String::as_str)
        .collect();
    keys.sort_unstable();
    assert_eq!(keys, ["0.25", "1.0", "2.0"]);
    assert!(json.get("vertical").is_none());
}

#[test]
fn ims_text_table_names_units() {
    let record = records_dir().join("RSN15_KERN_TAF021.AT2");
    let out = rockwatch_bin!().output(&["ims", "--record", record.to_str().unwrap()]);
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    for needle in [
        "PGA",
        "m/s2",
        "Arias",
        "D5-95",
        "SA(1.0 s)",
        "ASI 1.0-2.5",
        "VSI 2.5-3.0",
    ] {
        assert!(text.contains(needle), "missing {needle:?} in\n{text}");
    }
}

#[test]
fn ims_bad_input_fails_with_one_line_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("broken.AT2");
    std::fs::write(&bad, "a\nb\nc\nNPTS= 3, DT= 0.01 SEC\n 0.1 oops 0.3\n").unwrap();
    let missing = dir.path().join("missing.AT2");
    for path in [&bad, &missing] {
        let out = rockwatch_bin!().output(&["ims", "--record", path.to_str().unwrap()]);
        assert!(!out.status.success());
        let stderr = String::from_utf8(out.stderr).unwrap();
        assert_eq!(stderr.trim_end().lines().count(), 1, "{stderr}");
        assert!(stderr.contains(path.to_str().unwrap()), "{stderr}");
    }
    let good = records_dir().join("Rinaldi228.AT2");
    let out = rockwatch_bin!().output(&[
        "ims",
        "--record",
        good.to_str().unwrap(),
        "--vertical",
        records_dir()
            .join("RSN15_KERN_TAF021.AT2")
            .to_str()
            .unwrap(),
    ]);
    assert!(!out.status.success());
    let stderr = String::from_utf8(out.stderr).unwrap();
    assert!(stderr.contains("RSN15_KERN_TAF021.AT2"), "{stderr}");
}

/// `rockwatch ims` on the K-NET record whose raw acceleration carries a DC offset: a warning
/// naming it and --demean; with --demean the pre-event mean (first 5 %, computed here from
/// the samples) is subtracted, so PGA is max |a − mean| and the offset's PGD of ~75 m is gone.
#[test]
fn ims_warns_of_a_dc_offset_and_demean_removes_the_pre_event_mean() {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../tests/data/mseed/knet_AKT013_HNE_ms2.mseed"
    );
    let ims = |extra: &[&str]| {
        let out = Command::new(env!("CARGO_BIN_EXE_rockwatch"))
            .args(["ims", "--format", "json", "--record", path])
            .args(extra)
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        (json, String::from_utf8_lossy(&out.stderr).into_owned())
    };
    let (raw, warning) = ims(&[]);
    assert_eq!(warning.lines().count(), 1, "{warning}");
    assert!(
        warning.contains("DC offset") && warning.contains("--demean") && warning.contains(path),
        "{warning}"
    );
    assert!(raw["pgd"].as_f64().unwrap() > 70.0, "{raw}");

    let record = Record::read(Path::new(path)).unwrap();
    let a = &record.horizontal_mps2;
    let n = a.len() / 20; // the first 5 %
    let mean = a[..n].iter().sum::<f64>() / n as f64;
    let pga = a.iter().fold(0.0f64, |m, x| m.max((x - mean).abs()));
    let (demeaned, quiet) = ims(&["--demean"]);
    assert!(quiet.is_empty(), "{quiet}");
    assert_close("PGA", demeaned["pga"].as_f64().unwrap(), pga, 1e-12, 0.0);
    assert!(demeaned["pgd"].as_f64().unwrap() < 0.1, "{demeaned}");

    // A processed record starts near zero: no warning.
    let out = Command::new(env!("CARGO_BIN_EXE_rockwatch"))
        .args(["ims", "--format", "json", "--record"])
        .arg(records_dir().join("Rinaldi228.AT2"))
        .output()
        .unwrap();
    assert!(out.status.success() && out.stderr.is_empty());
}

/// The vertical table is labelled with the vertical's own file.
#[test]
fn ims_labels_the_vertical_with_its_own_file() {
    let out = Command::new(env!("CARGO_BIN_EXE_rockwatch"))
        .args(["ims", "--record"])
        .arg(records_dir().join("Rinaldi228.AT2"))
        .arg("--vertical")
        .arg(records_dir().join("RinaldiUP.AT2"))
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success());
    let headers: Vec<&str> = text
        .lines()
        .filter(|l| l.contains(" samples, dt"))
        .collect();
    assert_eq!(headers.len(), 2, "{text}");
    assert!(headers[0].contains("Rinaldi228.AT2 (horizontal)"), "{text}");
    assert!(headers[1].contains("RinaldiUP.AT2 (vertical)"), "{text}");
}
