//! Fragility throughput: block-record simulations per second per core on the bundled records
//! (rockwatch_core::fragility::run_simulations: the real-time stepper with early exit), the
//! cost of the fit and bootstrap, and the extrapolated time of issue 14's job
//! (100 records × 20 stripes × 24 directions × 20 ensemble members on 2 cores, target
//! ≤ 10 min). Run: `cargo bench --bench fragility` (prints its figures; no criterion).

use std::path::Path;
use std::time::Instant;

use rockwatch_core::dynamics::{BlockOptions, BlockParams};
use rockwatch_core::fragility::{
    analyse, log_spaced, prepare, run_simulations, FragilityConfig, FragilityRecord, Im, Intensity,
    Prepared, RockDirection, RockMember, RunResult, RunStatus,
};
use rockwatch_core::record::Record;

const G: f64 = rockwatch_core::STANDARD_GRAVITY_MPS2;

fn records() -> Vec<FragilityRecord> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/records");
    let mut names: Vec<String> = std::fs::read_dir(&dir)
        .expect("bundled records")
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".AT2") && n != "RinaldiUP.AT2")
        .collect();
    names.sort();
    names
        .into_iter()
        .map(|n| FragilityRecord {
            record: Record::read(&dir.join(&n)).expect("bundled record reads"),
            name: n,
            second_horizontal_mps2: None,
        })
        .collect()
}

fn config(members: Vec<RockMember>, bootstrap: usize) -> FragilityConfig {
    FragilityConfig {
        ims: vec![Im::Pga, Im::Pgv, Im::PgvPga, Im::Sa(1.0)],
        // Stripes from well below uplift to well above overturning: the realistic mix of
        // runs at rest, rocking and falling.
        intensity: Intensity::Stripes {
            im: 0,
            levels: log_spaced(0.05 * G, 1.5 * G, 20),
        },
        members,
        incidences_deg: vec![0.0, 180.0],
        t_extra_s: 10.0,
        block: BlockOptions::default(),
        bootstrap,
        seed: 1,
        surface: Some((0, 2)),
        surface_grid: 41,
        horizontal: Default::default(),
    }
}

fn main() {
    let records = records();
    let samples: usize = records.iter().map(|r| r.record.len()).sum();
    let seconds: f64 = records.iter().map(|r| r.record.duration_s()).sum();
    println!(
        "records: {} bundled horizontals, mean {:.1} s, {} samples in all",
        records.len(),
        seconds / records.len() as f64,
        samples
    );
    // A slender rock (B = 0.4 m, H = 1.6 m, α = 14°, μ = 0.7) and a stocky one (α = 34°).
    let rock = |b: f64, h: f64| RockMember::Planar {
        directions: vec![RockDirection {
            azimuth_deg: 0.0,
            params: BlockParams::from_width_height(b, h, 0.7, 0.6, None).expect("valid block"),
        }],
    };
    let members = vec![rock(0.4, 1.6), rock(1.0, 1.5)];
    let cfg = config(members, 0);
    let prepared = prepare(&cfg, &records).expect("prepare");
    let n_sims = cfg.n_simulations(records.len());
    let mut per_core = Vec::new();
    for threads in [1, 2] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("pool");
        // The fastest of 5 repetitions: the machine may be shared.
        let mut dt = f64::INFINITY;
        let mut runs = Vec::new();
        for _ in 0..5 {
            let t0 = Instant::now();
            runs = pool.install(|| run_simulations(&cfg, &records, &prepared, &|| {}));
            dt = dt.min(t0.elapsed().as_secs_f64());
        }
        let fell = runs
            .iter()
            .filter(|r| r.status == RunStatus::Overturned)
            .count();
        let rate = n_sims as f64 / dt;
        println!(
            "{threads} thread(s): {n_sims} block-record simulations in {dt:.3} s (fastest of 5) \
             = {rate:.0}/s ({:.0}/s per core), {fell} overturned",
            rate / threads as f64
        );
        per_core.push(rate / threads as f64);
    }
    // The 1-thread rate times 2 assumes linear scaling; the measured 2-thread rate includes
    // whatever else the machine runs. Both are printed.
    let best_per_core = per_core[0];
    let measured_two = per_core[1] * 2.0;
    // Issue 14's job.
    let job = 100.0 * 20.0 * 24.0 * 20.0;
    let job_s = job / (best_per_core * 2.0);
    println!(
        "extrapolated: 100 records × 20 stripes × 24 directions × 20 members = {job:.0} \
         simulations on 2 cores at {best_per_core:.0}/s per core: {:.1} min (target ≤ 10 min; \
         records as long as the bundled ones, mean {:.1} s)",
        job_s / 60.0,
        seconds / records.len() as f64
    );
    println!(
        "extrapolated from the measured 2-thread rate ({measured_two:.0}/s): {:.1} min",
        job / measured_two / 60.0
    );

    // The analysis at the job's size: 100 records × 20 stripes, 4 IMs (3 fitted) + the
    // surface, 500 bootstrap replicates. Its cost is per (record, stripe) cell, not per run.
    let n_rec = 100;
    let big = config(vec![rock(0.4, 1.6)], 500);
    let levels = match &big.intensity {
        Intensity::Stripes { levels, .. } => levels.clone(),
        Intensity::Scales(_) => unreachable!(),
    };
    let prepared = Prepared {
        ims: (0..n_rec)
            .map(|r| {
                let f = 1.0 + 0.5 * ((r as f64) * 0.37).sin();
                vec![3.0, 0.3 * f, 0.1 * f, 4.0 * f]
            })
            .collect(),
        scales: (0..n_rec)
            .map(|_| levels.iter().map(|l| l / 3.0).collect())
            .collect(),
    };
    let mut runs = Vec::new();
    for r in 0..n_rec {
        let capacity = 4.0 * (0.4 * ((r as f64) * 1.7).sin()).exp();
        for (j, &l) in levels.iter().enumerate() {
            runs.push(RunResult {
                record: r,
                level: j,
                member: 0,
                incidence: 0,
                scale: l / 3.0,
                status: if l > capacity {
                    RunStatus::Overturned
                } else {
                    RunStatus::Standing
                },
                direction: None,
                max_abs_theta_over_alpha: 0.0,
                max_abs_slide_m: 0.0,
                error: None,
            });
        }
    }
    for threads in [1, 2] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("pool");
        let t0 = Instant::now();
        let result = pool.install(|| analyse(&big, &prepared, &runs));
        println!(
            "analysis, 100 records × 20 stripes, 3 IMs + surface, 500 bootstrap replicates, \
             {threads} thread(s): {:.2} s ({} IMs fitted)",
            t0.elapsed().as_secs_f64(),
            result.ranking.len()
        );
    }
}
