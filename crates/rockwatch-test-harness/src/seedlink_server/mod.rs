//! The independent SeedLink server of the acquisition tests: `seedlink-rs-server` 0.4.0 in
//! this process (its own tokio runtime), on loopback; and the bundled K2 records in the order
//! a live server receives them.

pub mod hostile;

use std::net::SocketAddr;
use std::path::Path;
use std::time::Duration;

use rockwatch_core::record::mseed::parse_mseed;
use seedlink_rs_server::{DataStore, SeedLinkServer, ShutdownHandle};

/// The K2 accelerograph counts (512-byte Steim-2 records written by ObsPy).
pub const K2: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../tests/data/mseed/k2_STNA_HN123_counts.mseed"
);

pub struct Server {
    runtime: tokio::runtime::Runtime,
    shutdown: ShutdownHandle,
    pub store: DataStore,
    pub addr: SocketAddr,
}

impl Server {
    /// A server with an empty ring on `addr` (`127.0.0.1:0` for any port).
    pub fn start(addr: &str) -> Server {
        let runtime = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(1)
            .enable_all()
            .build()
            .unwrap();
        let server = runtime.block_on(SeedLinkServer::bind(addr)).unwrap();
        let (addr, store) = (server.local_addr().unwrap(), server.store().clone());
        let shutdown = server.shutdown_handle();
        runtime.spawn(server.run());
        Server {
            runtime,
            shutdown,
            store,
            addr,
        }
    }

    /// Adds records of station XX.STN to the ring.
    pub fn push(&self, records: &[Vec<u8>]) {
        for r in records {
            self.store.push("XX", "STN", r).unwrap();
        }
    }

    /// Adds records as station XX.`sta` (their MiniSEED 2 header's station code rewritten,
    /// bytes 8..13, so they decode as that station).
    pub fn push_as(&self, sta: &str, records: &[Vec<u8>]) {
        for r in records {
            let mut r = r.clone();
            let code = format!("{sta:<5}");
            r[8..13].copy_from_slice(&code.as_bytes()[..5]);
            self.store.push("XX", sta, &r).unwrap();
        }
    }

    pub fn stop(self) {
        self.shutdown.shutdown();
        self.runtime.shutdown_timeout(Duration::from_secs(2));
    }
}

/// The K2 file's 512-byte records sorted by start time (stable: channel order at equal times).
pub fn records_in_time_order() -> Vec<Vec<u8>> {
    let bytes = std::fs::read(K2).unwrap();
    assert_eq!(bytes.len() % 512, 0);
    let mut records: Vec<(i64, Vec<u8>)> = bytes
        .chunks(512)
        .map(|r| {
            let file = parse_mseed(r, Path::new("record")).unwrap();
            (file.channels[0].segments[0].start_time_ns, r.to_vec())
        })
        .collect();
    records.sort_by_key(|(t, _)| *t);
    records.into_iter().map(|(_, r)| r).collect()
}
