//! Fixtures shared by the transport latency benchmarks (iox_latency, dds_latency).

use std::path::Path;

use rockwatch::record::Record;
use rockwatch::replay::Traces;

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
    let mut record =
        Record::read(Path::new("tests/data/records/Rinaldi228.AT2")).expect("bundled record");
    record
        .attach_vertical(Path::new("tests/data/records/RinaldiUP.AT2"))
        .expect("bundled record");
    Traces::from_record(&record, 228.0).expect("finite azimuth")
}

/// The `p`-th percentile (0–100) of sorted values.
pub fn percentile(sorted: &[f64], p: f64) -> f64 {
    sorted[((p / 100.0) * (sorted.len() - 1) as f64).round() as usize]
}
