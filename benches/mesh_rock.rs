//! A rock from a mesh in the engine: the offline cost of reading and analysing its mesh at
//! catalogue load (readers, validation, mass properties, hull, contact, 24 directions × an
//! ensemble of 20), and the online cost of integrating it in 24 directions × 21 blocks under
//! a two-component record. Run: `cargo bench --bench mesh_rock` (prints the figures).
//!
//! The mesh is generated here: a faceted ellipsoid (semi-axes 0.35 × 0.25 × 0.9 m, 96 × 48
//! facets) with its bottom cut flat, so it rests on a patch of many vertices.

use std::path::Path;
use std::time::Instant;

use rockwatch_core::catalogue::Catalogue;
use rockwatch_core::engine::{AccelPacket, Engine, EngineConfig, PbrSpec};
use rockwatch_core::record::Record;

/// Scale of the record.
const SCALE: f64 = 0.45;

fn boulder_obj(nu: usize, nv: usize) -> String {
    let (a, b, c) = (0.35, 0.25, 0.9);
    let cut = -0.8 * c;
    let mut text = String::new();
    let mut vertex = |x: f64, y: f64, z: f64| text.push_str(&format!("v {x} {y} {}\n", z.max(cut)));
    vertex(0.0, 0.0, -c);
    for j in 1..nv {
        let th = -std::f64::consts::FRAC_PI_2 + std::f64::consts::PI * j as f64 / nv as f64;
        for i in 0..nu {
            let ph = 2.0 * std::f64::consts::PI * i as f64 / nu as f64;
            vertex(
                a * th.cos() * ph.cos(),
                b * th.cos() * ph.sin(),
                c * th.sin(),
            );
        }
    }
    vertex(0.0, 0.0, c);
    let idx = |j: usize, i: usize| 2 + (j - 1) * nu + i % nu; // 1-based
    let top = 2 + (nv - 1) * nu;
    for i in 0..nu {
        text.push_str(&format!("f 1 {} {}\n", idx(1, i + 1), idx(1, i)));
        text.push_str(&format!(
            "f {} {} {top}\n",
            idx(nv - 1, i),
            idx(nv - 1, i + 1)
        ));
    }
    for j in 1..nv - 1 {
        for i in 0..nu {
            let (p, q, r, s) = (idx(j, i), idx(j, i + 1), idx(j + 1, i + 1), idx(j + 1, i));
            text.push_str(&format!("f {p} {q} {r}\nf {p} {r} {s}\n"));
        }
    }
    text
}

fn main() {
    let dir = std::env::temp_dir().join(format!("rockwatch-mesh-bench-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    std::fs::write(dir.join("boulder.obj"), boulder_obj(96, 48)).expect("write mesh");
    let catalogue = dir.join("cat.toml");
    std::fs::write(
        &catalogue,
        "[[pbr]]\nid = \"boulder\"\nname = \"boulder\"\nlat = 34.28\nlon = -118.48\n\
         station = \"CI.RRS.00\"\nmesh = \"boulder.obj\"\n\
         azimuths = { from = 0, to = 360, step = 15 }\nheading_deg = { min = -10, max = 10 }\n\
         contact_tolerance_m = { min = 0.002, max = 0.01 }\nmu_s = 0.8\nmu_k = 0.6\n\
         source = \"bench\"\nensemble = 20\n",
    )
    .expect("write catalogue");

    let t = Instant::now();
    let cat = Catalogue::load(&catalogue).expect("catalogue");
    let spec = PbrSpec::from_catalogue(&cat.pbrs()[0]).expect("spec");
    let load_s = t.elapsed().as_secs_f64();
    let directions = 1 + spec.more_directions.len();
    let blocks = directions * (1 + spec.members.len());
    let faces = 2 * 96 + 2 * 96 * 46;
    println!(
        "mesh_rock: catalogue load of a {faces}-triangle mesh, {directions} directions × {} \
         blocks: {:.1} ms",
        1 + spec.members.len(),
        load_s * 1e3
    );

    let record = Record::read(Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../tests/data/records/Rinaldi228.AT2"
    )))
    .expect("record");
    // Scaled so that the rock rocks in most directions without falling (a fallen block costs
    // nothing more).
    let east: Vec<f32> = record
        .horizontal_mps2
        .iter()
        .map(|&a| (SCALE * a) as f32)
        .collect();
    let north: Vec<f32> = east.iter().rev().map(|&a| 0.6 * a).collect();
    let per_packet = (0.1 / record.dt_s).round() as usize;
    let packets: Vec<AccelPacket> = east
        .chunks(per_packet)
        .zip(north.chunks(per_packet))
        .enumerate()
        .map(|(i, (e, n))| AccelPacket {
            station: rockwatch_core::engine::StationId::parse("CI.RRS.00").unwrap(),
            start_time_ns: (i * per_packet) as i64 * (record.dt_s * 1e9).round() as i64,
            sample_rate_hz: 1.0 / record.dt_s,
            sequence: i as u64,
            east: e.to_vec(),
            north: n.to_vec(),
            up: vec![],
            unit: Default::default(),
        })
        .collect();
    let mut engine =
        Engine::new(EngineConfig::default(), vec![], std::slice::from_ref(&spec)).expect("engine");
    let mut out = Vec::new();
    let t = Instant::now();
    for p in packets {
        engine.process(p, 0, &mut out);
    }
    let run_s = t.elapsed().as_secs_f64();
    let data_s = record.len() as f64 * record.dt_s;
    let summary = &engine.summaries()[0];
    println!(
        "mesh_rock: {data_s:.1} s of Rinaldi × {SCALE} (east) + reversed × 0.6 (north) through \
         the engine: {:.3} s → real-time factor {:.1}× for one rock of {blocks} blocks; {:.2} µs \
         per block and sample; max θ/α {:.2}, {} of {directions} directions moved, overturn \
         probability {:.2}, {} outputs",
        run_s,
        data_s / run_s,
        run_s / (record.len() as f64 * blocks as f64) * 1e6,
        summary.max_theta_over_alpha,
        summary
            .directions
            .iter()
            .filter(|d| d.max_theta_over_alpha > 0.0 || d.max_slide_m > 0.0)
            .count(),
        summary.overturn_probability,
        out.len()
    );
    let _ = std::fs::remove_dir_all(&dir);
}
