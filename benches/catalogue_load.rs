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
//! The entries: 5000 stations with 20 blocks each (azimuths 18° apart); every 7th a general
//! body, every 10th an uncertain height with an ensemble of 20, the others a fixed rectangle.

use std::fmt::Write as _;
use std::time::{Duration, Instant};

use criterion::{Criterion, Throughput};
use rockwatch_core::catalogue::Catalogue;

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

fn main() {
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
