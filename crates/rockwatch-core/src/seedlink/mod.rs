//! SeedLink, the pure part: stream selections and the commands that request them
//! ([`select`]), the packets on the wire ([`frame`]), and what a packet's sequence number and
//! record start time say about it — next, gap, repeat, server restart, already delivered
//! ([`sequence`]); the server's station list and wildcard patterns expanded over it
//! ([`info`]). No I/O: the shell (`rockwatch::seedlink`) owns the socket, the reconnecting
//! supervisor and the state file.
//!
//! Protocols: SeedLink 3 (`SL` + 6 hex digits + a 512-byte MiniSEED record; 24-bit sequence
//! numbers that wrap) and SeedLink 4 (`SE` header with a 64-bit little-endian sequence number,
//! the station id and a payload of any length), negotiated with `SLPROTO 4.0` when the server's
//! `HELLO` lists `SLPROTO:4.0`. See docs/seedlink.md.

pub mod frame;
pub mod info;
pub mod select;
pub mod sequence;

/// The protocol of a connection.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum Protocol {
    /// SeedLink 3.x: 24-bit sequence numbers, 512-byte MiniSEED 2 records.
    V3,
    /// SeedLink 4.0: 64-bit sequence numbers, any payload length.
    V4,
}
