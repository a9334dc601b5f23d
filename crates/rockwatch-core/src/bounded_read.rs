//! Reading an input file into memory with a bound on its size: a device given as a file
//! (`/dev/urandom`, `/dev/zero`: their size reads as 0, and they never end) or a file of absurd
//! size is refused with a message instead of exhausting memory (issue 24 item 8). Pipes and
//! process substitutions still work: only what they send beyond the bound is refused.

use std::fs::File;
use std::io::{self, Read};
use std::path::Path;

/// Most bytes read of a data file (records, MiniSEED, meshes, StationXML, catalogues): 1 GiB,
/// far beyond a day of 200 Hz three-component MiniSEED (≈ 100 MB) or a scanned boulder.
pub const MAX_DATA_FILE_BYTES: u64 = 1 << 30;

/// Most bytes read of a configuration file (node, acquire, iceoryx2, ROS arguments): 16 MiB.
pub const MAX_CONFIG_FILE_BYTES: u64 = 16 << 20;

/// Reads `path` wholly, refusing one of more than `max_bytes` (an `InvalidData` error saying
/// so; nothing beyond `max_bytes + 1` is read).
pub fn read_bounded(path: &Path, max_bytes: u64) -> io::Result<Vec<u8>> {
    let file = File::open(path)?;
    let mut bytes = Vec::new();
    file.take(max_bytes.saturating_add(1))
        .read_to_end(&mut bytes)?;
    if bytes.len() as u64 > max_bytes {
        return Err(io::Error::new(
            io::ErrorKind::InvalidData,
            format!(
                "more than {max_bytes} bytes, the most read of such a file (a device such as \
                 /dev/urandom, or not the file meant?)"
            ),
        ));
    }
    Ok(bytes)
}

/// [`read_bounded`] as UTF-8 text (an `InvalidData` error if it is not).
pub fn read_to_string_bounded(path: &Path, max_bytes: u64) -> io::Result<String> {
    String::from_utf8(read_bounded(path, max_bytes)?).map_err(|e| {
        io::Error::new(
            io::ErrorKind::InvalidData,
            format!(
                "not UTF-8 text (invalid at byte {})",
                e.utf8_error().valid_up_to()
            ),
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_device_that_never_ends_is_refused_after_the_bound() {
        let e = read_bounded(Path::new("/dev/zero"), 4096).unwrap_err();
        assert_eq!(e.kind(), io::ErrorKind::InvalidData);
        assert!(e.to_string().contains("more than 4096 bytes"), "{e}");
    }

    #[test]
    fn a_file_within_the_bound_is_read_whole() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("f");
        std::fs::write(&path, b"12345").unwrap();
        assert_eq!(read_bounded(&path, 5).unwrap(), b"12345");
        assert!(read_bounded(&path, 4).is_err());
        assert_eq!(read_to_string_bounded(&path, 5).unwrap(), "12345");
    }
}
