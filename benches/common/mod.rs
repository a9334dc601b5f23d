//! Fixtures shared by the transport latency benchmarks (iox_latency, dds_latency).

use std::path::Path;
use std::sync::atomic::{AtomicI64, Ordering};
use std::time::{Duration, Instant};

use rockwatch::ports::PacketSink;
use rockwatch::replay::Traces;
use rockwatch_core::azimuth::Azimuth;
use rockwatch_core::engine::AccelPacket;
use rockwatch_core::record::Record;

/// Station id of benchmark station `i`.
pub fn station(i: usize) -> String {
    format!("XB.S{i:04}.00")
}

/// Writes a catalogue of `stations` copies of the example's slender pillar, one per station.
pub fn write_catalogue(path: &Path, stations: usize) {
    let mut text = String::new();
    for i in 0..stations {
        text += &format!(
            "[[pbr]]\nid = \"b{i:04}\"\nname = \"bench block {i}\"\nlat = 34.28\nlon = -118.48\n\
             station = \"{}\"\nazimuth_deg = 228.0\nwidth_m = 0.30\nheight_m = 1.50\n\
             mu_s = 0.70\nmu_k = 0.55\nsource = \"benchmark: copy of rrs-slender-pillar\"\n\n",
            station(i)
        );
    }
    std::fs::write(path, text).expect("benchmark catalogue is writable");
}

/// The bundled Rinaldi record (228° + vertical) as traces along azimuth 228°.
pub fn rinaldi() -> Traces {
    let mut record = Record::read(Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../tests/data/records/Rinaldi228.AT2"
    )))
    .expect("bundled record");
    record
        .attach_vertical(Path::new(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../tests/data/records/RinaldiUP.AT2"
        )))
        .expect("bundled record");
    Traces::from_record(
        &record,
        Azimuth::from_degrees(228.0).expect("finite azimuth"),
    )
}

/// The `p`-th percentile (0–100) of sorted values.
pub fn percentile(sorted: &[f64], p: f64) -> f64 {
    sorted[((p / 100.0) * (sorted.len() - 1) as f64).round() as usize]
}

/// The packets of the latency runs: `stations` copies of `template`, one per bench station.
pub fn station_packets(template: &[AccelPacket], stations: usize) -> Vec<Vec<AccelPacket>> {
    (0..stations)
        .map(|s| {
            template
                .iter()
                .map(|p| AccelPacket {
                    station: rockwatch_core::engine::StationId::parse(&station(s))
                        .expect("valid id"),
                    ..p.clone()
                })
                .collect()
        })
        .collect()
}

/// When each (packet, station) of a latency run was sent (ns since `epoch`; −1: not yet).
pub struct SendLog {
    pub epoch: Instant,
    stations: usize,
    per_station: usize,
    sent_ns: Vec<AtomicI64>,
}

impl SendLog {
    pub fn new(stations: usize, per_station: usize) -> SendLog {
        SendLog {
            epoch: Instant::now(),
            stations,
            per_station,
            sent_ns: (0..stations * per_station)
                .map(|_| AtomicI64::new(-1))
                .collect(),
        }
    }

    /// Now, in ns since the epoch.
    pub fn now_ns(&self) -> i64 {
        self.epoch.elapsed().as_nanos() as i64
    }

    /// Sends packet j of every station in turn through `sink`, one every `pace` (sleeping,
    /// not spinning: the machine may have 2 cores for 5 busy threads), logging send times.
    pub fn paced_send(
        &self,
        sink: &mut dyn PacketSink,
        packets: &[Vec<AccelPacket>],
        pace: Duration,
    ) {
        let mut next = Instant::now();
        for j in 0..self.per_station {
            for (s, station_packets) in packets.iter().enumerate() {
                std::thread::sleep(next.saturating_duration_since(Instant::now()));
                next += pace;
                self.sent_ns[j * self.stations + s].store(self.now_ns(), Ordering::Relaxed);
                sink.send(&station_packets[j]).expect("benchmark send");
            }
        }
    }

    /// Sorted latencies (µs) of alerts `(station id, received ns)`. The triggering packet is
    /// the station's latest packet sent before the alert came back (a station's packets are
    /// stations × pace apart, far more than the latency; the alert's data time may lie in the
    /// packet before, when the engine detects the event at a packet boundary).
    pub fn latencies_us<S: AsRef<str>>(&self, alerts: impl Iterator<Item = (S, i64)>) -> Vec<f64> {
        let mut out: Vec<f64> = alerts
            .filter_map(|(station, received_ns)| {
                let s: usize = station.as_ref().get(4..8)?.parse().ok()?;
                let sent = (0..self.per_station)
                    .map(|j| self.sent_ns[j * self.stations + s].load(Ordering::Relaxed))
                    .filter(|&t| t >= 0 && t <= received_ns)
                    .max()?;
                Some((received_ns - sent) as f64 / 1e3)
            })
            .collect();
        out.sort_by(f64::total_cmp);
        out
    }
}
