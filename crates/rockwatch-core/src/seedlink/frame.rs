//! SeedLink packets as they arrive on a streaming connection.
//!
//! - v3: `SL` + sequence as 6 ASCII hex digits + 512-byte payload (520 bytes); `SLINFO` + 2
//!   bytes + 512 bytes is an INFO packet (answers to INFO, no sequence). The length is fixed,
//!   so a packet whose number cannot be read still ends where it should: it is returned
//!   without a number ([`Frame::unreadable_sequence`]) and the stream stays framed.
//! - v4: `SE`, format (1 byte, `2` = MiniSEED 2, `3` = MiniSEED 3, `J` = JSON, `X` = XML),
//!   subformat (1 byte, `D` = data, `I` = info, `E` = error, …), payload length (u32 LE),
//!   sequence (u64 LE), station id length (u8), station id (`NET_STA`), payload.

use super::Protocol;

/// v3 packet: header and payload lengths (bytes).
pub const V3_HEADER_LEN: usize = 8;
pub const V3_PAYLOAD_LEN: usize = 512;
/// v4 fixed header length (bytes), before the station id.
pub const V4_HEADER_LEN: usize = 17;
/// Largest v4 payload accepted (bytes): MiniSEED 3 records are at most a few hundred KiB; a
/// larger length is a corrupt header, and buffering stays bounded.
pub const MAX_V4_PAYLOAD: usize = 1 << 20;

/// One packet, borrowing the receive buffer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Frame<'a> {
    /// The server's sequence number (v3: 0 to 0xFFFFFF); `None` for INFO packets and for v3
    /// data packets whose number cannot be read.
    pub sequence: Option<u64>,
    /// v3: the six characters where the number should be, when they are not hex digits (a
    /// corrupt header); the payload is still the packet's 512 bytes.
    pub unreadable_sequence: Option<&'a [u8]>,
    /// v4 format byte (`b'2'` for v3 data packets).
    pub format: u8,
    /// v4 subformat byte (`b'D'` for v3 data packets, `b'I'` for v3 INFO packets).
    pub subformat: u8,
    /// v4 station id (`NET_STA`); empty for v3.
    pub station: &'a str,
    pub payload: &'a [u8],
}

impl Frame<'_> {
    /// Whether the payload is a MiniSEED data record (format 2 or 3, subformat D), numbered
    /// or with an unreadable number.
    #[must_use]
    pub fn is_miniseed_data(&self) -> bool {
        matches!(self.format, b'2' | b'3')
            && self.subformat == b'D'
            && (self.sequence.is_some() || self.unreadable_sequence.is_some())
    }
}

/// Bytes that are not a SeedLink packet of the connection's protocol.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum FrameError {
    #[error("not a SeedLink {protocol:?} packet: starts with {start:?}")]
    Signature { protocol: Protocol, start: String },
    #[error("v4 payload of {0} bytes is more than the {MAX_V4_PAYLOAD} accepted")]
    TooLarge(usize),
    #[error("v4 station id is not ASCII")]
    StationId,
}

/// The first packet in `buf`, with the number of bytes it takes; `Ok(None)` when `buf` holds
/// only part of one (read more and call again).
pub fn parse_frame(
    buf: &[u8],
    protocol: Protocol,
) -> Result<Option<(Frame<'_>, usize)>, FrameError> {
    let signature = |want: &[u8]| -> Result<(), FrameError> {
        let n = buf.len().min(want.len());
        if buf[..n] == want[..n] {
            Ok(())
        } else {
            Err(FrameError::Signature {
                protocol,
                start: String::from_utf8_lossy(&buf[..buf.len().min(16)]).into_owned(),
            })
        }
    };
    match protocol {
        Protocol::V3 => {
            signature(b"SL")?;
            if buf.len() < V3_HEADER_LEN + V3_PAYLOAD_LEN {
                return Ok(None);
            }
            let payload = &buf[V3_HEADER_LEN..V3_HEADER_LEN + V3_PAYLOAD_LEN];
            let digits = &buf[2..8];
            let (sequence, unreadable_sequence, subformat) = if &buf[2..6] == b"INFO" {
                (None, None, b'I')
            } else {
                let seq = std::str::from_utf8(digits)
                    .ok()
                    .filter(|h| h.bytes().all(|b| b.is_ascii_hexdigit()))
                    .and_then(|h| u64::from_str_radix(h, 16).ok());
                match seq {
                    Some(seq) => (Some(seq), None, b'D'),
                    None => (None, Some(digits), b'D'),
                }
            };
            let frame = Frame {
                sequence,
                unreadable_sequence,
                format: b'2',
                subformat,
                station: "",
                payload,
            };
            Ok(Some((frame, V3_HEADER_LEN + V3_PAYLOAD_LEN)))
        }
        Protocol::V4 => {
            signature(b"SE")?;
            if buf.len() < V4_HEADER_LEN {
                return Ok(None);
            }
            let len = u32::from_le_bytes([buf[4], buf[5], buf[6], buf[7]]) as usize;
            if len > MAX_V4_PAYLOAD {
                return Err(FrameError::TooLarge(len));
            }
            let mut seq = [0u8; 8];
            seq.copy_from_slice(&buf[8..16]);
            let id_len = usize::from(buf[16]);
            let total = V4_HEADER_LEN + id_len + len;
            if buf.len() < total {
                return Ok(None);
            }
            let station = std::str::from_utf8(&buf[V4_HEADER_LEN..V4_HEADER_LEN + id_len])
                .ok()
                .filter(|s| s.is_ascii())
                .ok_or(FrameError::StationId)?;
            let frame = Frame {
                sequence: Some(u64::from_le_bytes(seq)),
                unreadable_sequence: None,
                format: buf[2],
                subformat: buf[3],
                station,
                payload: &buf[V4_HEADER_LEN + id_len..total],
            };
            Ok(Some((frame, total)))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn v3_packets_parse_when_complete_and_wait_when_not() {
        let mut bytes = b"SL00002A".to_vec();
        bytes.extend(std::iter::repeat_n(7u8, 512));
        bytes.extend_from_slice(b"SL0000");
        assert_eq!(parse_frame(&bytes[..300], Protocol::V3), Ok(None));
        let (frame, used) = parse_frame(&bytes, Protocol::V3).unwrap().unwrap();
        assert_eq!(
            (frame.sequence, used, frame.payload.len()),
            (Some(42), 520, 512)
        );
        assert!(frame.is_miniseed_data());
        assert_eq!(parse_frame(&bytes[520..], Protocol::V3), Ok(None));
        let mut info = b"SLINFO *".to_vec();
        info.extend(std::iter::repeat_n(b' ', 512));
        let (frame, _) = parse_frame(&info, Protocol::V3).unwrap().unwrap();
        assert!(frame.sequence.is_none() && !frame.is_miniseed_data());
        let e = parse_frame(b"ERROR\r\n", Protocol::V3).unwrap_err();
        assert!(matches!(e, FrameError::Signature { .. }), "{e}");
        // An unreadable number: still one 520-byte data packet, without a number.
        let bad = [b"SLzz!?00".as_slice(), &[0; 512], b"SL00002B"].concat();
        let (frame, used) = parse_frame(&bad, Protocol::V3).unwrap().unwrap();
        assert_eq!(
            (frame.sequence, frame.unreadable_sequence, used),
            (None, Some(&b"zz!?00"[..]), 520)
        );
        assert!(frame.is_miniseed_data());
    }

    #[test]
    fn v4_packets_carry_64_bit_sequences_and_the_station() {
        let payload = [1u8, 2, 3, 4, 5];
        let mut bytes = b"SE2D".to_vec();
        bytes.extend_from_slice(&(payload.len() as u32).to_le_bytes());
        bytes.extend_from_slice(&(u64::MAX - 2).to_le_bytes());
        bytes.push(6);
        bytes.extend_from_slice(b"XX_STN");
        bytes.extend_from_slice(&payload);
        assert_eq!(parse_frame(&bytes[..20], Protocol::V4), Ok(None));
        let (frame, used) = parse_frame(&bytes, Protocol::V4).unwrap().unwrap();
        assert_eq!(used, bytes.len());
        assert_eq!(
            (frame.sequence, frame.station, frame.payload),
            (Some(u64::MAX - 2), "XX_STN", &payload[..])
        );
        let mut huge = bytes.clone();
        huge[4..8].copy_from_slice(&u32::MAX.to_le_bytes());
        assert!(matches!(
            parse_frame(&huge, Protocol::V4),
            Err(FrameError::TooLarge(_))
        ));
    }
}
