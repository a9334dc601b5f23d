//! A hostile SeedLink 3 server for the fault tests: plain threads on loopback, no crate. It
//! streams a ring of `(sequence number, 512-byte record)` entries that the test builds —
//! sequence numbers and records are whatever the test says, so a fault is a record or a
//! number put in the ring ([`Hostile::push`], [`Hostile::push_with_seq`]) — and behaves per
//! connection as told ([`Conn`]: serve, hang or close after some packets).
//!
//! Requests are read the way a numbering server reads them: `DATA n` (6 hex digits) sends the
//! entries whose number is greater than n, in ring order; `TIME y,m,d,h,m,s` the entries whose
//! record starts at or after that time; plain `DATA` the whole ring. It refuses `INFO` (so
//! acquire never sees a restart). Every command received is kept ([`Hostile::commands`]).

use std::collections::VecDeque;
use std::io::{BufRead, BufReader, Write};
use std::net::{Shutdown, SocketAddr, TcpListener, TcpStream};
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use rockwatch_core::record::mseed::{
    encode_mseed, parse_mseed, ChannelData, FloatEncoding, RecordLength, Samples, WriteOptions,
};

/// What one connection does, in the order connections arrive (then [`Conn::Serve`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Conn {
    /// Sends what is asked for, and new entries as they come.
    Serve,
    /// Sends this many packets, then nothing more (the socket stays open).
    HangAfter(usize),
    /// Sends this many packets, then closes the connection.
    CloseAfter(usize),
}

#[derive(Debug, Clone)]
struct Entry {
    seq: u64,
    bytes: Vec<u8>,
    start_ns: i64,
}

#[derive(Default)]
struct Shared {
    ring: Vec<Entry>,
    next_seq: u64,
    plan: VecDeque<Conn>,
    commands: Vec<String>,
}

pub struct Hostile {
    pub addr: SocketAddr,
    shared: Arc<Mutex<Shared>>,
    stop: Arc<AtomicBool>,
}

/// Where a connection starts in the ring.
#[derive(Debug, Clone, Copy)]
enum From {
    All,
    After(u64),
    Since(i64),
}

impl Hostile {
    /// Listens on 127.0.0.1 (any port); sequence numbers start at 1.
    pub fn start() -> Hostile {
        let listener = TcpListener::bind("127.0.0.1:0").unwrap();
        let addr = listener.local_addr().unwrap();
        let shared = Arc::new(Mutex::new(Shared {
            next_seq: 1,
            ..Shared::default()
        }));
        let stop = Arc::new(AtomicBool::new(false));
        let (s, st) = (Arc::clone(&shared), Arc::clone(&stop));
        listener.set_nonblocking(true).unwrap();
        std::thread::spawn(move || {
            while !st.load(Ordering::Relaxed) {
                match listener.accept() {
                    Ok((stream, _)) => {
                        let conn = s.lock().unwrap().plan.pop_front().unwrap_or(Conn::Serve);
                        let (s, st) = (Arc::clone(&s), Arc::clone(&st));
                        std::thread::spawn(move || {
                            let _ = serve(stream, conn, &s, &st);
                        });
                    }
                    Err(_) => std::thread::sleep(Duration::from_millis(20)),
                }
            }
        });
        Hostile { addr, shared, stop }
    }

    /// What the next connections do (in order).
    pub fn plan(&self, conns: &[Conn]) {
        self.shared.lock().unwrap().plan.extend(conns);
    }

    /// Appends records numbered from the server's next number on.
    pub fn push(&self, records: &[Vec<u8>]) {
        let mut s = self.shared.lock().unwrap();
        for r in records {
            let seq = s.next_seq;
            s.next_seq += 1;
            s.ring.push(entry(seq, r));
        }
    }

    /// Appends one record with number `seq` (the server's own numbering goes on unchanged).
    pub fn push_with_seq(&self, record: &[u8], seq: u64) {
        self.shared.lock().unwrap().ring.push(entry(seq, record));
    }

    /// The next number [`Hostile::push`] assigns.
    pub fn next_seq(&self) -> u64 {
        self.shared.lock().unwrap().next_seq
    }

    /// The commands received so far (all connections).
    pub fn commands(&self) -> Vec<String> {
        self.shared.lock().unwrap().commands.clone()
    }

    pub fn stop(&self) {
        self.stop.store(true, Ordering::Relaxed);
    }
}

impl Drop for Hostile {
    fn drop(&mut self) {
        self.stop();
    }
}

fn entry(seq: u64, bytes: &[u8]) -> Entry {
    assert_eq!(bytes.len(), 512, "SeedLink 3 carries 512-byte records");
    // A record the reader cannot decode starts "never" (sent only to plain DATA or DATA n).
    let start_ns = parse_mseed(bytes, Path::new("ring"))
        .ok()
        .and_then(|f| f.channels.first().map(|c| c.start_time_ns))
        .unwrap_or(i64::MIN);
    Entry {
        seq,
        bytes: bytes.to_vec(),
        start_ns,
    }
}

fn serve(
    stream: TcpStream,
    conn: Conn,
    shared: &Mutex<Shared>,
    stop: &AtomicBool,
) -> std::io::Result<()> {
    stream.set_read_timeout(Some(Duration::from_secs(5)))?;
    let mut reader = BufReader::new(stream.try_clone()?);
    let mut out = stream.try_clone()?;
    let mut from = From::All;
    loop {
        let mut line = String::new();
        if reader.read_line(&mut line)? == 0 {
            return Ok(());
        }
        let line = line.trim().to_string();
        shared.lock().unwrap().commands.push(line.clone());
        let words: Vec<&str> = line.split_whitespace().collect();
        match words.first().copied() {
            Some("HELLO") => out.write_all(
                b"SeedLink v3.1 (rockwatch hostile test server) :: SLPROTO:3.1\r\nrockwatch tests\r\n",
            )?,
            Some("INFO") => out.write_all(b"ERROR\r\n")?,
            Some("STATION" | "SELECT") => out.write_all(b"OK\r\n")?,
            Some("DATA") => {
                from = match words.get(1) {
                    Some(n) => From::After(u64::from_str_radix(n, 16).unwrap_or(0)),
                    None => From::All,
                };
                out.write_all(b"OK\r\n")?;
            }
            Some("TIME") => {
                let t = words.get(1).copied().unwrap_or("1970,1,1,0,0,0");
                from = From::Since(time_ns(t));
                out.write_all(b"OK\r\n")?;
            }
            Some("END") => break,
            Some("BYE") => return Ok(()),
            _ => out.write_all(b"ERROR\r\n")?,
        }
    }
    // Streaming: every ring entry the request selects, in ring order, then new ones.
    let mut position = 0;
    let mut sent = 0;
    while !stop.load(Ordering::Relaxed) {
        let next = {
            let s = shared.lock().unwrap();
            s.ring.get(position).cloned()
        };
        let Some(e) = next else {
            std::thread::sleep(Duration::from_millis(20));
            continue;
        };
        position += 1;
        let wanted = match from {
            From::All => true,
            From::After(n) => e.seq > n,
            From::Since(t) => e.start_ns >= t,
        };
        if !wanted {
            continue;
        }
        match conn {
            Conn::HangAfter(n) if sent >= n => {
                // Silent, the socket open, until the client goes away or the test ends.
                while !stop.load(Ordering::Relaxed) {
                    std::thread::sleep(Duration::from_millis(50));
                }
                return Ok(());
            }
            Conn::CloseAfter(n) if sent >= n => {
                let _ = stream.shutdown(Shutdown::Both);
                return Ok(());
            }
            _ => {}
        }
        let mut packet = format!("SL{:06X}", e.seq % (1 << 24)).into_bytes();
        packet.extend_from_slice(&e.bytes);
        out.write_all(&packet)?;
        sent += 1;
    }
    Ok(())
}

/// `y,m,d,h,m,s` → ns since the epoch (UTC).
fn time_ns(text: &str) -> i64 {
    let v: Vec<i64> = text.split(',').map(|x| x.parse().unwrap_or(0)).collect();
    let (y, m, d) = (v[0], v[1], v[2]);
    // Days from civil (Howard Hinnant's algorithm).
    let y = if m <= 2 { y - 1 } else { y };
    let era = y.div_euclid(400);
    let yoe = y - era * 400;
    let mp = (m + 9) % 12;
    let doy = (153 * mp + 2) / 5 + d - 1;
    let doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    let days = era * 146_097 + doe - 719_468;
    ((days * 86_400) + v[3] * 3600 + v[4] * 60 + v[5]) * 1_000_000_000
}

// ---- Faulty records, made from good ones ----

/// The record claiming `factor` × its sampling rate (the rate multiplier of the fixed header;
/// the K2 records have no blockette 100).
pub fn at_other_rate(record: &[u8], factor: i16) -> Vec<u8> {
    let mut r = record.to_vec();
    let multiplier = i16::from_be_bytes([r[34], r[35]]);
    r[34..36].copy_from_slice(&(multiplier * factor).to_be_bytes());
    r
}

/// The record with its start year set to `year` (a GPS glitch at the digitizer).
pub fn in_year(record: &[u8], year: u16) -> Vec<u8> {
    let mut r = record.to_vec();
    r[20..22].copy_from_slice(&year.to_be_bytes());
    r
}

/// A FLOAT32 record of the same stream and start as `record`, every sample `value`.
pub fn with_values(record: &[u8], value: f64) -> Vec<u8> {
    let file = parse_mseed(record, Path::new("record")).unwrap();
    let c = &file.channels[0];
    let samples = vec![value; 100];
    let bytes = encode_mseed(
        &[ChannelData {
            id: c.id(),
            start_time_ns: c.start_time_ns,
            sample_rate_hz: c.sample_rate_hz,
            samples: Samples::Float(&samples),
        }],
        WriteOptions {
            record_length: RecordLength::B512,
            float_encoding: FloatEncoding::Float32,
            ..WriteOptions::default()
        },
        Path::new("hostile"),
    )
    .unwrap();
    assert_eq!(bytes.len(), 512);
    bytes
}
