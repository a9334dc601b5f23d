//! Catalogue loading at network scale: a generated catalogue of N blocks written as TOML and as
//! CSV (the same entries), read and validated by `Catalogue::from_toml_str` /
//! `Catalogue::from_csv_str` (parsing, locating every entry's line, validation, unique ids).
//! Run: `cargo bench --bench catalogue_load`.
//!
//! It first prints one load of each format at 20 000, 50 000 and 100 000 blocks (wall time of
//! one call; `CATALOGUE_LOAD_SIZES=20000,50000` changes the sizes), then criterion measures
//! the 100 000-block loads. Target (docs/capacity.md): 100 000 TOML blocks in ≤ 2 s in release,
//! well inside the 60 s start timeout of the shipped systemd unit.
//!
//! Then the region's startup (issue 21, docs/capacity.md): a catalogue of 1000 rocks from one
//! mesh (an 0.8 × 0.6 × 4 m box, planar model, every 15°: 24 directions) with an uncertain
//! heading, contact tolerance and μs and an ensemble of 100, loaded from its file, each entry
//! turned into its engine spec (the Latin hypercube and each member's 24 planar bodies from
//! the mesh) and the engine built: 2 400 000 member blocks. Target ≤ 10 s.
//! `REGION_STARTUP_ROCKS=100` runs it at a tenth of the scale; `cargo bench --bench
//! catalogue_load -- region` runs only it.
//!
//! The entries: 5000 stations with 20 blocks each (azimuths 18° apart); every 7th a general
//! body, every 10th an uncertain height with an ensemble of 20, the others a fixed rectangle.

use std::fmt::Write as _;
use std::time::{Duration, Instant};

use criterion::{Criterion, Throughput};
use rockwatch_core::catalogue::Catalogue;
use rockwatch_core::engine::{Engine, EngineConfig, PbrSpec};

const BLOCKS: usize = 100_000;
const BLOCKS_PER_STATION: usize = 20;

/// The same `n` entries as TOML and as CSV.
fn catalogue_texts(n: usize) -> (String, String) {
    let mut toml = String::with_capacity(n * 260);
    let mut csv = String::with_capacity(n * 160);
    csv.push_str(
        "id,name,lat,lon,station,azimuth_deg,width_m,height_m,height_m_min,height_m_max,\
         b_plus_m,b_minus_m,h_m,rho_m,mu_s,mu_k,source,ensemble\n",
    );
    for i in 0..n {
        let station = format!("XB.S{:04}.00", i / BLOCKS_PER_STATION);
        let azimuth = (i % BLOCKS_PER_STATION) as f64 * 18.0;
        let lat = 34.0 + (i % 1000) as f64 * 1e-3;
        let lon = -118.0 - (i / 1000) as f64 * 1e-3;
        let _ = write!(
            toml,
            "[[pbr]]\nid = \"pbr-{i:06}\"\nname = \"rock {i}\"\nlat = {lat}\nlon = {lon}\n\
             station = \"{station}\"\nazimuth_deg = {azimuth}\n"
        );
        let _ = write!(csv, "pbr-{i:06},rock {i},{lat},{lon},{station},{azimuth},");
        if i % 7 == 0 {
            toml.push_str("b_plus_m = 0.2\nb_minus_m = 0.25\nh_m = 0.7\nrho_m = 0.42\n");
            csv.push_str(",,,,0.2,0.25,0.7,0.42,");
        } else if i % 10 == 0 {
            toml.push_str("width_m = 0.4\nheight_m = { min = 1.4, max = 1.6 }\nensemble = 20\n");
            csv.push_str("0.4,,1.4,1.6,,,,,");
        } else {
            toml.push_str("width_m = 0.4\nheight_m = 1.5\n");
            csv.push_str("0.4,1.5,,,,,,,");
        }
        toml.push_str("mu_s = 0.7\nmu_k = 0.55\nsource = \"bench\"\n\n");
        csv.push_str("0.7,0.55,bench,");
        csv.push_str(if i % 10 == 0 && i % 7 != 0 {
            "20\n"
        } else {
            "\n"
        });
    }
    (toml, csv)
}

fn load_toml(text: &str) -> Catalogue {
    Catalogue::from_toml_str(text, "bench.toml").expect("the generated TOML catalogue loads")
}

fn load_csv(text: &str) -> Catalogue {
    Catalogue::from_csv_str(text, "bench.csv").expect("the generated CSV catalogue loads")
}

fn one_shot(sizes: &[usize]) {
    println!("catalogue_load: one load each (wall time)");
    for &n in sizes {
        let (toml, csv) = catalogue_texts(n);
        let t = Instant::now();
        let cat = load_toml(&toml);
        let toml_s = t.elapsed().as_secs_f64();
        assert_eq!(cat.len(), n);
        let t = Instant::now();
        let from_csv = load_csv(&csv);
        let csv_s = t.elapsed().as_secs_f64();
        assert_eq!(
            from_csv.pbrs(),
            cat.pbrs(),
            "TOML and CSV describe the same blocks"
        );
        println!(
            "  {n:>7} blocks: TOML {toml_s:.3} s ({:.1} MB), CSV {csv_s:.3} s ({:.1} MB)",
            toml.len() as f64 / 1e6,
            csv.len() as f64 / 1e6
        );
    }
}

/// An `x` × `y` × `z` m box as an OBJ (up z).
fn box_obj(x: f64, y: f64, z: f64) -> String {
    let mut text = String::new();
    for k in [0.0, z] {
        for (i, j) in [(0.0, 0.0), (x, 0.0), (x, y), (0.0, y)] {
            let _ = writeln!(text, "v {i} {j} {k}");
        }
    }
    text + "f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n"
}

/// Loads the region's catalogue and builds the engine (see the module doc).
fn region_startup() {
    let rocks: usize = std::env::var("REGION_STARTUP_ROCKS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(1000);
    let dir = tempfile::tempdir().expect("temporary directory");
    std::fs::write(dir.path().join("rock.obj"), box_obj(0.8, 0.6, 4.0)).expect("mesh written");
    let mut toml = String::new();
    for r in 0..rocks {
        let _ = write!(
            toml,
            "[[pbr]]\nid = \"rock-{r:04}\"\nname = \"rock {r}\"\nlat = 34.0\nlon = -118.0\n\
             station = \"XX.S{:04}.00\"\nmesh = \"rock.obj\"\n\
             heading_deg = {{ min = -10.0, max = 10.0 }}\n\
             contact_tolerance_m = {{ min = 0.0, max = 0.01 }}\n\
             mu_s = {{ min = 0.6, max = 0.9 }}\nmu_k = 0.5\nsource = \"bench\"\nensemble = 100\n\n",
            2 * r
        );
    }
    let path = dir.path().join("region.toml");
    std::fs::write(&path, toml).expect("catalogue written");
    let t = Instant::now();
    let cat = Catalogue::load(&path).expect("the region catalogue loads");
    let load_s = t.elapsed().as_secs_f64();
    let specs: Vec<PbrSpec> = cat
        .pbrs()
        .iter()
        .map(|p| PbrSpec::from_catalogue(p).expect("spec"))
        .collect();
    let specs_s = t.elapsed().as_secs_f64() - load_s;
    let members: usize = specs
        .iter()
        .map(|s| {
            s.members.len()
                + s.more_directions
                    .iter()
                    .map(|d| d.members.len())
                    .sum::<usize>()
        })
        .sum();
    let engine = Engine::new(EngineConfig::default(), vec![], &specs).expect("engine");
    let total_s = t.elapsed().as_secs_f64();
    println!(
        "region startup: {rocks} rocks × 100 members × {} directions = {members} member blocks: catalogue {load_s:.2} s, ensembles and planar bodies {specs_s:.2} s, engine {:.2} s: {total_s:.2} s in all (target ≤ 10 s); block state {:.0} B per member block",
        1 + specs[0].more_directions.len(),
        total_s - load_s - specs_s,
        engine.block_bytes() as f64 / members as f64
    );
}

fn main() {
    if std::env::args().skip(1).any(|a| a == "region") {
        region_startup();
        return;
    }
    let sizes: Vec<usize> = match std::env::var("CATALOGUE_LOAD_SIZES") {
        Ok(list) => list
            .split(',')
            .map(|s| {
                s.trim()
                    .parse()
                    .expect("CATALOGUE_LOAD_SIZES: numbers, comma-separated")
            })
            .collect(),
        Err(_) => vec![20_000, 50_000, BLOCKS],
    };
    one_shot(&sizes);
    region_startup();

    let (toml, csv) = catalogue_texts(BLOCKS);
    let mut c = Criterion::default()
        .sample_size(10)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(10))
        .configure_from_args();
    let mut group = c.benchmark_group("catalogue_load_100k");
    group.throughput(Throughput::Elements(BLOCKS as u64));
    group.bench_function("toml", |b| b.iter(|| load_toml(&toml)));
    group.bench_function("csv", |b| b.iter(|| load_csv(&csv)));
    group.finish();
    c.final_summary();
}
