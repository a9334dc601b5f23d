//! Running-IM throughput: samples per second on one core for the live node's default set
//! (PGA, PGV, PGD, CAV, Arias, t5/t75/t95, SMA, SA at 0.3/1.0/3.0 s, ASI/SI/VSI 0.1–0.5 s on
//! the 0.02 s grid: 23 oscillators), and for the full study set (291 grid oscillators) for
//! comparison. Criterion reports the throughput as elements (= samples) per second.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use rockwatch_core::ims::{RunningConfig, RunningIms};
use rockwatch_core::record::Record;
use std::hint::black_box;
use std::path::Path;
use std::time::Duration;

fn chichi_record() -> Record {
    let path = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."))
        .join("tests/data/records/RSN1476_CHICHI_TCU029-N.AT2");
    Record::read(&path).unwrap_or_else(|e| panic!("{e}"))
}

fn bench_running(c: &mut Criterion) {
    let record = chichi_record();
    let samples = &record.horizontal_mps2;
    let mut group = c.benchmark_group("running_ims");
    group.throughput(Throughput::Elements(samples.len() as u64));
    group.measurement_time(Duration::from_secs(10));
    for (name, config) in [
        ("live_default", RunningConfig::live_default()),
        ("study_291_oscillators", RunningConfig::study()),
    ] {
        let mut running = RunningIms::new(record.dt_s, &config).unwrap_or_else(|e| panic!("{e}"));
        group.bench_function(name, |b| {
            b.iter(|| {
                running.reset();
                for &a in samples {
                    running.push(black_box(a));
                }
                black_box((running.t95_s(), running.sma_mps2(), running.sa_mps2(1.0)))
            });
        });
    }
    group.finish();
}

criterion_group!(benches, bench_running);
criterion_main!(benches);
