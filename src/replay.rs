//! Turning records into the packets a live station would send: aligned east/north/up traces
//! with their timing, cut into packets of a given length and followed by a quiet tail. Used by
//! `rockwatch monitor` and the replay tool, so offline and live runs see the same packets.

use std::path::Path;

use crate::engine::{AccelPacket, StationId};
use crate::mseed::{read_mseed, Channel, GapFill};
use crate::record::{Record, RecordError};

/// Three aligned components (m/s², or counts for integer MiniSEED) with their timing.
#[derive(Debug, Clone, PartialEq)]
pub struct Traces {
    /// UTC time of the first sample (ns).
    pub start_ns: i64,
    pub rate_hz: f64,
    pub east: Vec<f64>,
    pub north: Vec<f64>,
    pub up: Option<Vec<f64>>,
}

impl Traces {
    /// A record's horizontal component pointing to `azimuth_deg` (clockwise from north) split
    /// into east and north (a_E = a sin az, a_N = a cos az), its vertical as up. Time 0 is
    /// the Unix epoch (AT2 and CSV records carry no absolute time).
    pub fn from_record(record: &Record, azimuth_deg: f64) -> Result<Traces, String> {
        if !azimuth_deg.is_finite() {
            return Err(format!(
                "azimuth must be a finite number of degrees, got {azimuth_deg}"
            ));
        }
        let (s, c) = azimuth_deg.to_radians().sin_cos();
        Ok(Traces {
            start_ns: 0,
            rate_hz: 1.0 / record.dt_s,
            east: record.horizontal_mps2.iter().map(|a| a * s).collect(),
            north: record.horizontal_mps2.iter().map(|a| a * c).collect(),
            up: record.vertical_mps2.clone(),
        })
    }

    /// The channels of `station` in a MiniSEED file: …E or …1 as east, …N or …2 as north, …Z
    /// or …3 as up (a missing horizontal is zero). Gaps inside the file are filled linearly;
    /// the channels must share rate and start time (to half a sample). Values are as stored
    /// (counts for integer encodings: the station's gain converts them).
    pub fn from_mseed(path: &Path, station: &StationId) -> Result<Traces, RecordError> {
        let err = |problem: String| RecordError::new(path, None, problem);
        let file = read_mseed(path)?;
        let mine: Vec<&Channel> = file
            .channels
            .iter()
            .filter(|c| format!("{}.{}.{}", c.net, c.sta, c.loc) == station.as_str())
            .collect();
        if mine.is_empty() {
            let ids: Vec<String> = file.channels.iter().map(Channel::id).collect();
            return Err(err(format!(
                "no channel of station {station} (channels: {})",
                ids.join(", ")
            )));
        }
        let pick = |codes: [char; 2]| mine.iter().find(|c| c.cha.ends_with(codes)).copied();
        let (east, north, up) = (pick(['E', '1']), pick(['N', '2']), pick(['Z', '3']));
        let Some(first) = east.or(north) else {
            return Err(err(format!(
                "station {station} has no horizontal channel (…E/…N or …1/…2)"
            )));
        };
        let (start_ns, rate_hz) = (first.start_time_ns, first.sample_rate_hz);
        let samples = |c: Option<&Channel>| -> Result<Option<Vec<f64>>, RecordError> {
            let Some(c) = c else { return Ok(None) };
            if (c.sample_rate_hz - rate_hz).abs() > 1e-9 * rate_hz
                || (c.start_time_ns - start_ns).abs() as f64 > 0.5e9 / rate_hz
            {
                return Err(err(format!(
                    "channel {} is not aligned with {} (rate or start time)",
                    c.id(),
                    first.id()
                )));
            }
            c.contiguous_samples(GapFill::Linear).map(Some)
        };
        let (e, n, u) = (samples(east)?, samples(north)?, samples(up)?);
        let len = [&e, &n, &u]
            .iter()
            .filter_map(|c| c.as_ref().map(Vec::len))
            .min()
            .unwrap_or(0);
        let cut = |v: Option<Vec<f64>>| {
            v.map(|mut v| {
                v.truncate(len);
                v
            })
        };
        Ok(Traces {
            start_ns,
            rate_hz,
            east: cut(e).unwrap_or_else(|| vec![0.0; len]),
            north: cut(n).unwrap_or_else(|| vec![0.0; len]),
            up: cut(u),
        })
    }

    /// Number of samples.
    #[must_use]
    pub fn len(&self) -> usize {
        self.east.len()
    }

    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.east.is_empty()
    }

    /// Cuts the traces, followed by `tail_s` seconds of zeros, into packets of `packet_ms`
    /// (at least one sample), sequence numbers from 0.
    #[must_use]
    pub fn packets(&self, station: &StationId, packet_ms: u32, tail_s: f64) -> Vec<AccelPacket> {
        let per_packet = ((f64::from(packet_ms) * 1e-3 * self.rate_hz).round() as usize).max(1);
        let total = self.len() + (tail_s.max(0.0) * self.rate_hz).round() as usize;
        let at = |v: &[f64], i: usize| v.get(i).copied().unwrap_or(0.0) as f32;
        (0..total)
            .step_by(per_packet)
            .enumerate()
            .map(|(sequence, first)| {
                let range = first..(first + per_packet).min(total);
                AccelPacket {
                    station: station.to_string(),
                    start_time_ns: self.start_ns
                        + (first as f64 * 1e9 / self.rate_hz).round() as i64,
                    sample_rate_hz: self.rate_hz,
                    sequence: sequence as u64,
                    east: range.clone().map(|i| at(&self.east, i)).collect(),
                    north: range.clone().map(|i| at(&self.north, i)).collect(),
                    up: self
                        .up
                        .as_ref()
                        .map_or_else(Vec::new, |u| range.map(|i| at(u, i)).collect()),
                }
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn packets_cover_record_and_tail_contiguously() {
        let record = Record {
            source: "test".into(),
            dt_s: 0.01,
            horizontal_mps2: (0..25).map(f64::from).collect(),
            vertical_mps2: None,
        };
        let t = Traces::from_record(&record, 90.0).unwrap();
        let id = StationId::parse("CI.RRS.00").unwrap();
        let p = t.packets(&id, 100, 0.1);
        let lens: Vec<usize> = p.iter().map(AccelPacket::len).collect();
        assert_eq!(lens, vec![10, 10, 10, 5]);
        assert_eq!(p[2].start_time_ns, 200_000_000);
        assert_eq!(p[2].east[4], 24.0);
        assert_eq!(p[3].east, vec![0.0; 5]);
        assert!(p
            .iter()
            .all(|q| q.up.is_empty() && q.north.iter().all(|v| v.abs() < 1e-5)));
        assert_eq!(
            p.iter().map(|q| q.sequence).collect::<Vec<_>>(),
            vec![0, 1, 2, 3]
        );
    }
}
