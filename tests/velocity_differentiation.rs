//! Velocity channels differentiated to acceleration (`rockwatch_core::differentiate`, used by
//! the assembly of `rockwatch acquire` and by `--differentiate-velocity` of monitor/replay/
//! ims), against closed forms:
//! - a sampled sine `v = A sin(ωt + φ)`: the central difference is exactly
//!   `A ω cos(ωt + φ) · sin(ωh)/(ωh)` (checked to round-off, so the scheme is the one
//!   documented), hence within `A ω (ωh)²/6` of the true acceleration; the one-sided ends
//!   within `A ω² h / 2`;
//! - a linear chirp: within `h²/6 · max|v'''|` inside, `h/2 · max|v''|` at the ends;
//! - through the assembler: three velocity channels (StationXML input units M/S, counts per
//!   m/s) cut into records of uneven lengths arriving interleaved give packets equal to the
//!   analytic east/north/up acceleration within the same bound; without
//!   `differentiate_velocity` they are refused naming the setting.

use std::f64::consts::PI;

use rockwatch_core::assembly::{Assembler, AssemblyConfig};
use rockwatch_core::differentiate::{differentiate, Differentiator};
use rockwatch_core::engine::AccelPacket;
use rockwatch_core::inventory::{ChannelEpoch, Inventory, Sensitivity};
use rockwatch_core::record::mseed::{Channel, SampleKind, Segment};

const RATE: f64 = 100.0;
const H: f64 = 1.0 / RATE;

fn sinc(x: f64) -> f64 {
    if x == 0.0 {
        1.0
    } else {
        x.sin() / x
    }
}

#[test]
fn a_sampled_sine_is_differentiated_by_exactly_the_central_scheme() {
    let a = 0.37;
    for f in [0.5, 2.0, 10.0, 30.0] {
        let w = 2.0 * PI * f;
        let phase = 0.3;
        let n = 1000;
        let t = |k: usize| k as f64 * H;
        let v: Vec<f64> = (0..n).map(|k| a * (w * t(k) + phase).sin()).collect();
        let d = differentiate(&v, RATE);
        assert_eq!(d.len(), n);
        let interior_bound = a * w * (w * H).powi(2) / 6.0;
        let edge_bound = a * w * w * H / 2.0;
        let mut worst: f64 = 0.0;
        for (k, &dk) in d.iter().enumerate().take(n - 1).skip(1) {
            let exact = a * w * (w * t(k) + phase).cos();
            // The scheme's own closed form: to round-off (v's rounding / 2h).
            let scheme = exact * sinc(w * H);
            assert!(
                (dk - scheme).abs() <= 1e-12 * a * RATE,
                "f {f}: k {k}: {dk} vs {scheme}"
            );
            let err = (dk - exact).abs();
            assert!(
                err <= interior_bound * (1.0 + 1e-6) + 1e-12 * a * RATE,
                "f {f} k {k}"
            );
            worst = worst.max(err);
        }
        // The exact error A ω (1 − sinc ωh) (≤ the Taylor bound) is attained where cos ≈ ±1.
        let exact_error = a * w * (1.0 - sinc(w * H));
        assert!(exact_error <= interior_bound);
        assert!(
            worst >= 0.9 * exact_error,
            "f {f}: {worst} vs {exact_error}"
        );
        for k in [0, n - 1] {
            let exact = a * w * (w * t(k) + phase).cos();
            assert!((d[k] - exact).abs() <= edge_bound, "f {f}: end {k}");
        }
    }
}

#[test]
fn a_chirp_is_within_the_schemes_error_bound_and_records_cut_anywhere_agree() {
    // v = A sin(2π(f0 t + c t²/2)), 0.5 → 10.5 Hz over 10 s.
    let (amp, f0, c) = (0.05, 0.5, 1.0);
    let n = 1001;
    let phase = |t: f64| 2.0 * PI * (f0 * t + 0.5 * c * t * t);
    let dphase = |t: f64| 2.0 * PI * (f0 + c * t);
    let v: Vec<f64> = (0..n).map(|k| amp * phase(k as f64 * H).sin()).collect();
    let d = differentiate(&v, RATE);
    // |v'''| ≤ A(φ'³ + 3φ'φ''), |v''| ≤ A(φ'² + φ''), φ'' = 2πc, at the largest φ'.
    let (p1, p2) = (dphase((n - 1) as f64 * H), 2.0 * PI * c);
    let third = amp * (p1.powi(3) + 3.0 * p1 * p2);
    let second = amp * (p1 * p1 + p2);
    for (k, &dk) in d.iter().enumerate() {
        let t = k as f64 * H;
        let exact = amp * dphase(t) * phase(t).cos();
        let bound = if k == 0 || k == n - 1 {
            H / 2.0 * second
        } else {
            H * H / 6.0 * third
        };
        assert!(
            (dk - exact).abs() <= bound,
            "k {k}: {dk} vs {exact} (bound {bound})"
        );
    }
    // Streaming, in records of uneven lengths: the same numbers.
    let mut streamed = vec![f64::NAN; n];
    let mut diff = Differentiator::new();
    let mut start = 0;
    for len in [1, 2, 3, 97, 250, 13, 400].iter().cycle() {
        if start >= n {
            break;
        }
        let end = (start + len).min(n);
        for (k, &x) in v.iter().enumerate().take(end).skip(start) {
            diff.push(k as i64, x, &mut |j, d| streamed[j as usize] = d * RATE);
        }
        start = end;
    }
    diff.flush(&mut |j, x| streamed[j as usize] = x * RATE);
    assert_eq!(streamed, d);
}

/// A velocity channel of station XX.VEL. (HH?): `sensitivity` counts per m/s.
fn epoch(cha: &str, az: f64, dip: f64, sensitivity: f64, units: &str) -> ChannelEpoch {
    ChannelEpoch {
        source: "test".into(),
        network: "XX".into(),
        station: "VEL".into(),
        location: String::new(),
        channel: cha.into(),
        start_ns: Some(0),
        end_ns: None,
        sample_rate_hz: Some(RATE),
        azimuth_deg: Some(az),
        dip_deg: Some(dip),
        sensitivity: Some(Sensitivity {
            value: sensitivity,
            frequency_hz: Some(1.0),
            input_units: units.into(),
            output_units: Some("COUNTS".into()),
        }),
    }
}

fn record(cha: &str, first: usize, counts: &[f64]) -> Channel {
    let start = (first as f64 * 1e9 / RATE).round() as i64 + 1_600_000_000_000_000_000;
    Channel {
        source: "test".into(),
        net: "XX".into(),
        sta: "VEL".into(),
        loc: String::new(),
        cha: cha.into(),
        sample_rate_hz: RATE,
        start_time_ns: start,
        sample_kind: SampleKind::Float,
        segments: vec![Segment {
            start_time_ns: start,
            samples: counts.to_vec(),
        }],
        gaps: vec![],
        overlaps: vec![],
    }
}

#[test]
fn the_assembler_differentiates_velocity_channels_across_records_to_the_analytic_acceleration() {
    // HH1 at azimuth 30°, HH2 at 120°, HHZ up; 1.5e6 counts per m/s (a 1500 V/(m/s) sensor).
    let s = 1.5e6;
    let inventory = Inventory {
        channels: vec![
            epoch("HH1", 30.0, 0.0, s, "M/S"),
            epoch("HH2", 120.0, 0.0, s, "M/S"),
            epoch("HHZ", 0.0, -90.0, s, "M/S"),
        ],
    };
    // Ground velocity east, north, up (m/s): sines of 1, 2.5 and 4 Hz.
    let comps = [(0.02, 1.0, 0.1), (0.01, 2.5, 0.7), (0.005, 4.0, 1.9)];
    let vel = |c: usize, t: f64| {
        let (a, f, p) = comps[c];
        a * (2.0 * PI * f * t + p).sin()
    };
    let acc = |c: usize, t: f64| {
        let (a, f, p) = comps[c];
        a * 2.0 * PI * f * (2.0 * PI * f * t + p).cos()
    };
    let axis = |az: f64| (az.to_radians().sin(), az.to_radians().cos());
    let n = 2000;
    let counts = |cha: &str| -> Vec<f64> {
        (0..n)
            .map(|k| {
                let t = k as f64 * H;
                let (e, nn, u) = (vel(0, t), vel(1, t), vel(2, t));
                s * match cha {
                    "HH1" => axis(30.0).0 * e + axis(30.0).1 * nn,
                    "HH2" => axis(120.0).0 * e + axis(120.0).1 * nn,
                    _ => u,
                }
            })
            .collect()
    };
    let config = AssemblyConfig {
        differentiate_velocity: true,
        ..AssemblyConfig::default()
    };
    let mut asm = Assembler::new(inventory.clone(), config);
    let mut packets: Vec<AccelPacket> = Vec::new();
    // Records of different lengths per component, interleaved in time order.
    let mut records = Vec::new();
    for (cha, len) in [("HH1", 173), ("HH2", 311), ("HHZ", 97)] {
        let c = counts(cha);
        let mut k = 0;
        while k < n {
            let end = (k + len).min(n);
            records.push((k, record(cha, k, &c[k..end])));
            k = end;
        }
    }
    records.sort_by_key(|(k, r)| (*k, r.cha.clone()));
    for (_, r) in &records {
        asm.push(r, 0, &mut |p| packets.push(p)).unwrap();
    }
    asm.flush(&mut |p| packets.push(p));
    let total: usize = packets.iter().map(AccelPacket::len).sum();
    assert_eq!(total, n);
    assert_eq!(asm.counters().missing_component_samples, 0);
    let t0 = packets[0].start_time_ns;
    let w_max = 2.0 * PI * 4.0;
    for p in &packets {
        for i in 0..p.len() {
            let k = ((p.start_time_ns - t0) as f64 * 1e-9 * RATE).round() as usize + i;
            let t = k as f64 * H;
            let edge = k == 0 || k == n - 1;
            for (c, got) in [(0, p.east[i]), (1, p.north[i]), (2, p.up[i])] {
                let (a, f, _) = comps[c];
                let w = 2.0 * PI * f;
                let bound = if edge {
                    a * w * w * H / 2.0
                } else {
                    a * w * (w * H).powi(2) / 6.0
                };
                // f32 packets: plus their rounding of values up to a·ω_max.
                let f32_ulp = 0.02 * w_max * 2.0f64.powi(-23);
                let err = (f64::from(got) - acc(c, t)).abs();
                assert!(
                    err <= bound + 2.0 * f32_ulp,
                    "component {c} sample {k}: {err} > {bound}"
                );
            }
        }
    }

    // Refused without the setting, the reason naming it.
    let mut refuse = Assembler::new(inventory, AssemblyConfig::default());
    let e = refuse
        .push(&records[0].1, 0, &mut |_| {})
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("velocity channel (M/S)") && e.contains("differentiate_velocity = true"),
        "{e}"
    );
}
