//! Partitions of the stations among the nodes of one service (scale-out, docs/capacity.md).
//!
//! A service of N nodes splits its stations into N partitions `0..N`; node `i` owns partition
//! `i` (`partition = "i/N"` in its configuration) and runs the blocks of its stations only. A
//! station's partition is, unless assigned explicitly ([`PartitionMap::assign`]),
//!
//! ```text
//! FNV-1a-64(SEED id "NET.STA.LOC" as UTF-8 bytes) mod N
//! ```
//!
//! FNV-1a 64 (offset basis 0xcbf29ce484222325, prime 0x100000001b3, one xor-then-multiply per
//! byte, wrapping) is fixed by its definition, uses no seed, no platform word size and no
//! library's hasher (whose output may change between versions), so every process, version and
//! platform, and any other program, computes the same partition. The reference values of the
//! FNV authors are checked in the tests.
//!
//! Pure: no transport. The shell maps a partition to its input topic.

use std::collections::BTreeMap;
use std::fmt;

use crate::station_id::StationId;

/// Most partitions of a service.
pub const MAX_PARTITIONS: u32 = 1024;

/// FNV-1a, 64 bit, of `bytes`.
#[must_use]
pub fn fnv1a64(bytes: &[u8]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for &b in bytes {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}

/// Partition `index` of `count` (0 ≤ index < count ≤ [`MAX_PARTITIONS`]), written `"i/N"`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Partition {
    index: u32,
    count: u32,
}

/// Why a text is not a partition or an assignment is invalid.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum PartitionError {
    /// Not `i/N` with 0 ≤ i < N ≤ [`MAX_PARTITIONS`].
    #[error("partition {text:?} must be \"i/N\" with 0 ≤ i < N ≤ {MAX_PARTITIONS} (e.g. \"1/3\": the second of three)")]
    Syntax { text: String },
    /// An explicitly assigned station names a partition that does not exist.
    #[error("station {station} is assigned to partition {index}, but there are only {count} (0–{})", count - 1)]
    AssignedBeyond {
        station: String,
        index: u32,
        count: u32,
    },
}

impl Partition {
    /// Partition `index` of `count`.
    pub fn new(index: u32, count: u32) -> Result<Partition, PartitionError> {
        if count == 0 || count > MAX_PARTITIONS || index >= count {
            return Err(PartitionError::Syntax {
                text: format!("{index}/{count}"),
            });
        }
        Ok(Partition { index, count })
    }

    /// Parses `"i/N"` (decimal, no spaces).
    pub fn parse(text: &str) -> Result<Partition, PartitionError> {
        let bad = || PartitionError::Syntax {
            text: text.to_owned(),
        };
        let (i, n) = text.split_once('/').ok_or_else(bad)?;
        let digits =
            |s: &str| !s.is_empty() && s.len() <= 5 && s.bytes().all(|b| b.is_ascii_digit());
        if !digits(i) || !digits(n) {
            return Err(bad());
        }
        let (index, count) = (i.parse().map_err(|_| bad())?, n.parse().map_err(|_| bad())?);
        Partition::new(index, count).map_err(|_| bad())
    }

    /// The partition owned (0-based).
    #[must_use]
    pub fn index(self) -> u32 {
        self.index
    }

    /// Partitions in the service.
    #[must_use]
    pub fn count(self) -> u32 {
        self.count
    }
}

impl fmt::Display for Partition {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

/// Which partition each station belongs to: explicit assignments, else the hash.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PartitionMap {
    count: u32,
    assigned: BTreeMap<String, u32>,
}

impl PartitionMap {
    /// `count` partitions by hash alone.
    pub fn hashed(count: u32) -> Result<PartitionMap, PartitionError> {
        Partition::new(0, count)?;
        Ok(PartitionMap {
            count,
            assigned: BTreeMap::new(),
        })
    }

    /// `count` partitions, the stations of `assigned` in the partition given, the others by
    /// hash.
    pub fn assign(
        count: u32,
        assigned: impl IntoIterator<Item = (StationId, u32)>,
    ) -> Result<PartitionMap, PartitionError> {
        let mut map = PartitionMap::hashed(count)?;
        for (station, index) in assigned {
            if index >= count {
                return Err(PartitionError::AssignedBeyond {
                    station: station.as_str().to_owned(),
                    index,
                    count,
                });
            }
            map.assigned.insert(station.as_str().to_owned(), index);
        }
        Ok(map)
    }

    /// Partitions in the service.
    #[must_use]
    pub fn count(&self) -> u32 {
        self.count
    }

    /// The partition of the station `NET.STA.LOC` (any text: a malformed id is hashed too, so
    /// that it reaches exactly one node, which rejects and counts it).
    #[must_use]
    pub fn partition_of(&self, station: &str) -> u32 {
        match self.assigned.get(station) {
            Some(&i) => i,
            None => (fnv1a64(station.as_bytes()) % u64::from(self.count)) as u32,
        }
    }

    /// Whether `partition` owns `station`.
    #[must_use]
    pub fn owns(&self, partition: Partition, station: &str) -> bool {
        partition.count == self.count && self.partition_of(station) == partition.index
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fnv1a64_matches_the_reference_values_of_its_authors() {
        // From the FNV test suite (http://www.isthe.com/chongo/src/fnv/test_fnv.c, FNV1a_64).
        assert_eq!(fnv1a64(b""), 0xcbf2_9ce4_8422_2325);
        assert_eq!(fnv1a64(b"a"), 0xaf63_dc4c_8601_ec8c);
        assert_eq!(fnv1a64(b"foobar"), 0x8594_4171_f739_67e8);
    }

    #[test]
    fn partitions_parse_and_refuse_what_is_not_i_of_n() {
        let p = Partition::parse("1/3").unwrap();
        assert_eq!((p.index(), p.count()), (1, 3));
        assert_eq!(p.to_string(), "1/3");
        for bad in [
            "3/3", "0/0", "1", "-1/3", "1/ 3", "a/3", "0/1025", "1/3/4", "",
        ] {
            assert!(Partition::parse(bad).is_err(), "{bad:?}");
        }
    }

    #[test]
    fn each_station_belongs_to_exactly_one_partition_and_assignments_override_the_hash() {
        let ids: Vec<String> = (0..300).map(|i| format!("XX.S{i:03}.00")).collect();
        let map = PartitionMap::hashed(3).unwrap();
        let mut sizes = [0usize; 3];
        for id in &ids {
            let owners: Vec<u32> = (0..3)
                .filter(|&i| map.owns(Partition::new(i, 3).unwrap(), id))
                .collect();
            assert_eq!(owners.len(), 1, "{id}");
            sizes[owners[0] as usize] += 1;
        }
        // A hash spreads them: each partition gets a fair share (binomial, 300 × 1/3 ± 5σ).
        assert!(sizes.iter().all(|&n| (60..=140).contains(&n)), "{sizes:?}");
        let id = StationId::parse("CI.RRS.00").unwrap();
        let hashed = map.partition_of("CI.RRS.00");
        let moved = (hashed + 1) % 3;
        let assigned = PartitionMap::assign(3, [(id.clone(), moved)]).unwrap();
        assert_eq!(assigned.partition_of("CI.RRS.00"), moved);
        assert!(PartitionMap::assign(3, [(id, 3)]).is_err());
        // A station's partition depends on its id and N only (no seed): the values of an
        // independent implementation (Python, docs/capacity.md).
        assert_eq!(fnv1a64(b"CI.RRS.00"), 0xb254_4828_7eb9_f30c);
        assert_eq!(map.partition_of("CI.RRS.00"), 1);
        assert_eq!(fnv1a64(b"CI.PASC."), 0x0bc0_0a37_d9be_c24a);
        assert_eq!(map.partition_of("CI.PASC."), 1);
    }
}
