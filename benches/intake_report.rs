//! The node's per-packet cost of the intake report bookkeeping (`rockwatch::intake`):
//! `WriterCounts::taken` (one hash lookup per message, redeliveries recognised by sequence
//! number), the engine's verdict counted in the `SourceTally`, and `WriterCounts::due` (which
//! reports are due, called after every turn of the event loop), for 4 writers sending in turn
//! and for 1000. Criterion reports messages per second; the reports themselves are not
//! published here (a counter stands for the publisher).

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use rockwatch::intake::{Taken, WriterCounts};
use rockwatch_core::engine::{SourceTally, Verdict};
use std::hint::black_box;
use std::sync::Arc;
use std::time::Duration;

/// Messages per iteration, and per turn of the event loop between two `due` calls.
const MESSAGES: u64 = 10_000;
const PER_TURN: u64 = 256;

fn bench_intake(c: &mut Criterion) {
    let mut group = c.benchmark_group("intake_report");
    group.throughput(Throughput::Elements(MESSAGES));
    group.measurement_time(Duration::from_secs(5));
    for writers in [4u64, 1000] {
        let gids: Vec<[u8; 16]> = (0..writers)
            .map(|w| {
                let mut bytes = [1u8; 16];
                bytes[..8].copy_from_slice(&w.to_le_bytes());
                bytes
            })
            .collect();
        let tally = Arc::new(SourceTally::default());
        let mut counts = WriterCounts::new([9; 16], "/bench".into(), Arc::clone(&tally), 1000);
        let mut sn = 0i64;
        group.bench_function(format!("{writers}_writers"), |b| {
            b.iter(|| {
                let mut reports = 0u64;
                for i in 0..MESSAGES {
                    sn += 1;
                    let gid = gids[(i % writers) as usize];
                    if let Taken::New(slot) = counts.taken(gid, sn, black_box(true)) {
                        tally.count(slot, Verdict::Accepted);
                    }
                    if i % PER_TURN == PER_TURN - 1 {
                        counts.due(false, [7; 16], &mut |r| reports += black_box(r.taken) & 1);
                    }
                }
                black_box(reports)
            });
        });
    }
    group.finish();
}

criterion_group!(benches, bench_intake);
criterion_main!(benches);
