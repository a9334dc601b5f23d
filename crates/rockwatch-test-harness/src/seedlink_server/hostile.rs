//! A hostile SeedLink 3 (or 4, [`Hostile::start_v4`]) server for the fault tests: plain
//! threads on loopback, no crate. It
//! streams a ring of `(sequence number, 512-byte record)` entries that the test builds —
//! sequence numbers and records are whatever the test says, so a fault is a record or a
//! number put in the ring ([`Hostile::push`], [`Hostile::push_with_seq`]) — and behaves per
//! connection as told ([`Conn`]: serve, hang or close after some packets, send garbage, a
//! v4 header claiming 2^31 bytes, or part of a packet). An entry may carry the six
//! characters of its v3 header's number ([`Hostile::push_with_number_text`]: an unreadable
//! number, sent on every connection).
//!
//! Requests are read the way a numbering server reads them: `DATA n` (v3 6 hex digits, v4
//! decimal) sends the entries whose number is greater than n, in ring order; `TIME
//! y,m,d,h,m,s` (v4 `DATA ALL y-m-dTh:m:sZ`) the entries whose record starts at or after
//! that time; plain `DATA` the whole ring. It refuses `INFO` (so acquire never sees a
//! restart). v4 is `SLPROTO 4.0` after HELLO, packets `SE2D` + length + number + `XX_STN`.
//! Every command received is kept ([`Hostile::commands`]).
//!
//! [`Hostile::start_like_ringserver`] answers and positions as ringserver 4 does (its
//! `slclient.c`, SeedLink 3; no ringserver can be installed here, so this is the model the
//! tests can run): plain `DATA` starts at the **next** record pushed, not the ring's oldest;
//! `DATA n` sends from n on; `TIME t` positions at the first record (in ring order) starting at
//! or after t and sends everything after it; `INFO ID`, `INFO STATIONS` and `INFO STREAMS`
//! are answered with ringserver's XML (per stream `begin_time` and `end_time` of its data)
//! inside 512-byte MiniSEED records (`SLINFO *` … `SLINFO  `, the text from byte 56, at most
//! 456 bytes each), without a trailing `END`.

use std::collections::{BTreeMap, VecDeque};
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
    /// Sends this many packets, then 520 bytes of text in place of the next packet (then
    /// serves on: the client has dropped the connection).
    GarbageAfter(usize),
    /// v4: sends this many packets, then a packet header claiming a 2^31-byte payload and a
    /// few bytes of it (then serves on).
    HugeLengthAfter(usize),
    /// Sends this many packets, then the first 100 bytes of the next, then nothing more (the
    /// socket stays open).
    HangMidPacketAfter(usize),
    /// Sends this many packets, then the first 100 bytes of the next, then closes.
    CloseMidPacketAfter(usize),
}

#[derive(Debug, Clone)]
struct Entry {
    seq: u64,
    bytes: Vec<u8>,
    start_ns: i64,
    /// Time of the record's last sample (ns): ringserver's `end_time` of a stream.
    end_ns: i64,
    /// v3: the six characters sent in place of the number (`None`: the number in hex).
    number_text: Option<[u8; 6]>,
}

#[derive(Default)]
struct Shared {
    ring: Vec<Entry>,
    next_seq: u64,
    plan: VecDeque<Conn>,
    commands: Vec<String>,
    /// Offers and speaks SeedLink 4.
    v4: bool,
    /// Answers and positions as ringserver does (see the module doc).
    ringserver: bool,
    /// Data packets written, all connections.
    sent: usize,
    /// ringserver model: `INFO STREAMS` answered with text that is not its XML.
    unreadable_streams: bool,
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
    /// ringserver's plain `DATA`: the records pushed after the request.
    Next,
    /// ringserver's `TIME t`: from the first record in ring order starting at or after t.
    FirstAfter(i64),
}

impl Hostile {
    /// Listens on 127.0.0.1 (any port); SeedLink 3; sequence numbers start at 1.
    pub fn start() -> Hostile {
        Hostile::listen(false)
    }

    /// The same, offering SeedLink 4 (`SLPROTO:4.0`) and speaking it when asked.
    pub fn start_v4() -> Hostile {
        Hostile::listen(true)
    }

    /// SeedLink 3 answering and positioning as ringserver 4 does (see the module doc).
    pub fn start_like_ringserver() -> Hostile {
        let server = Hostile::listen(false);
        server.shared.lock().unwrap().ringserver = true;
        server
    }

    fn listen(v4: bool) -> Hostile {
        let listener = TcpListener::bind("127.0.0.1:0").unwrap();
        let addr = listener.local_addr().unwrap();
        let shared = Arc::new(Mutex::new(Shared {
            next_seq: 1,
            v4,
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

    /// Appends one record numbered on (as [`Hostile::push`]) whose v3 header carries `text`
    /// in place of the number, on every connection.
    pub fn push_with_number_text(&self, record: &[u8], text: &[u8; 6]) {
        let mut s = self.shared.lock().unwrap();
        let seq = s.next_seq;
        s.next_seq += 1;
        s.ring.push(Entry {
            number_text: Some(*text),
            ..entry(seq, record)
        });
    }

    /// The next number [`Hostile::push`] assigns.
    pub fn next_seq(&self) -> u64 {
        self.shared.lock().unwrap().next_seq
    }

    /// ringserver model: from now on `INFO STREAMS` is answered with text that is neither
    /// XML nor JSON (a broken or foreign server).
    pub fn garble_info_streams(&self) {
        self.shared.lock().unwrap().unreadable_streams = true;
    }

    /// Data packets written so far (all connections).
    pub fn sent(&self) -> usize {
        self.shared.lock().unwrap().sent
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
    let (start_ns, end_ns) = parse_mseed(bytes, Path::new("ring"))
        .ok()
        .and_then(|f| {
            f.channels.first().map(|c| {
                let n: usize = c.segments.iter().map(|s| s.samples.len()).sum();
                let span = (n.saturating_sub(1) as f64 * 1e9 / c.sample_rate_hz).round() as i64;
                (c.start_time_ns, c.start_time_ns + span)
            })
        })
        .unwrap_or((i64::MIN, i64::MIN));
    Entry {
        seq,
        bytes: bytes.to_vec(),
        start_ns,
        end_ns,
        number_text: None,
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
    let offers_v4 = shared.lock().unwrap().v4;
    let ringserver = shared.lock().unwrap().ringserver;
    let mut v4 = false;
    loop {
        let mut line = String::new();
        if reader.read_line(&mut line)? == 0 {
            return Ok(());
        }
        let line = line.trim().to_string();
        shared.lock().unwrap().commands.push(line.clone());
        let words: Vec<&str> = line.split_whitespace().collect();
        match words.first().copied() {
            Some("HELLO") if offers_v4 => out.write_all(
                b"SeedLink v4.0 (rockwatch hostile test server) :: SLPROTO:3.1 SLPROTO:4.0\r\nrockwatch tests\r\n",
            )?,
            Some("HELLO") => out.write_all(
                b"SeedLink v3.1 (rockwatch hostile test server) :: SLPROTO:3.1\r\nrockwatch tests\r\n",
            )?,
            Some("SLPROTO") if offers_v4 => {
                v4 = true;
                out.write_all(b"OK\r\n")?;
            }
            Some("INFO") if ringserver => {
                let s = shared.lock().unwrap();
                let level = words.get(1).copied();
                let xml = if s.unreadable_streams && level == Some("STREAMS") {
                    "streams: XX_STN HN1 HN2 HN3".to_string()
                } else {
                    ringserver_info(&s.ring, level)
                };
                drop(s);
                out.write_all(&info_records(&xml))?;
            }
            Some("INFO") => out.write_all(b"ERROR\r\n")?,
            // ringserver: plain DATA is the next record; `DATA n` sends n on; TIME positions.
            Some("DATA") if ringserver => {
                from = match words.get(1) {
                    None => From::Next,
                    Some(n) => From::After(u64::from_str_radix(n, 16).unwrap_or(1).saturating_sub(1)),
                };
                out.write_all(b"OK\r\n")?;
            }
            Some("TIME") if ringserver => {
                let t = words.get(1).copied().unwrap_or("1970,1,1,0,0,0");
                from = From::FirstAfter(time_ns(t));
                out.write_all(b"OK\r\n")?;
            }
            Some("STATION" | "SELECT") => out.write_all(b"OK\r\n")?,
            Some("DATA") => {
                from = match (words.get(1), words.get(2)) {
                    // v4 `DATA ALL start`: `y-m-dTh:m:sZ`.
                    (Some(&"ALL"), Some(t)) => From::Since(time_ns(
                        &t.trim_end_matches('Z').replace(['-', 'T', ':'], ","),
                    )),
                    (Some(&"ALL"), None) => From::All,
                    (Some(n), _) if v4 => From::After(n.parse().unwrap_or(0)),
                    (Some(n), _) => From::After(u64::from_str_radix(n, 16).unwrap_or(0)),
                    (None, _) => From::All,
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
    {
        let s = shared.lock().unwrap();
        match from {
            From::Next => position = s.ring.len(),
            From::FirstAfter(t) => {
                position = s
                    .ring
                    .iter()
                    .position(|e| e.start_ns >= t)
                    .unwrap_or(s.ring.len());
            }
            _ => {}
        }
    }
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
            From::All | From::Next | From::FirstAfter(_) => true,
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
        let packet = if v4 {
            let mut p = b"SE2D".to_vec();
            p.extend_from_slice(&(e.bytes.len() as u32).to_le_bytes());
            p.extend_from_slice(&e.seq.to_le_bytes());
            p.push(6);
            p.extend_from_slice(b"XX_STN");
            p.extend_from_slice(&e.bytes);
            p
        } else {
            let mut p = match e.number_text {
                Some(text) => [b"SL".as_slice(), &text].concat(),
                None => format!("SL{:06X}", e.seq % (1 << 24)).into_bytes(),
            };
            p.extend_from_slice(&e.bytes);
            p
        };
        // The faults in place of the packet `sent` (then the connection ends or goes on).
        match conn {
            Conn::GarbageAfter(n) if sent == n => {
                let garbage = b"<html><body>502 Bad Gateway</body></html> ".repeat(13);
                out.write_all(&garbage[..520])?;
            }
            Conn::HugeLengthAfter(n) if sent == n => {
                let mut header = packet[..16].to_vec();
                header[4..8].copy_from_slice(&(1u32 << 31).to_le_bytes());
                header.extend_from_slice(&packet[16..100]);
                out.write_all(&header)?;
            }
            Conn::HangMidPacketAfter(n) | Conn::CloseMidPacketAfter(n) if sent == n => {
                out.write_all(&packet[..100])?;
                out.flush()?;
                if let Conn::CloseMidPacketAfter(_) = conn {
                    std::thread::sleep(Duration::from_millis(50));
                    let _ = stream.shutdown(Shutdown::Both);
                    return Ok(());
                }
                while !stop.load(Ordering::Relaxed) {
                    std::thread::sleep(Duration::from_millis(50));
                }
                return Ok(());
            }
            _ => {}
        }
        if matches!(conn, Conn::GarbageAfter(n) | Conn::HugeLengthAfter(n) if sent == n) {
            // The fault took the packet's place: it is not sent on this connection.
            sent += 1;
            continue;
        }
        out.write_all(&packet)?;
        sent += 1;
        shared.lock().unwrap().sent += 1;
    }
    Ok(())
}

/// A station's first and last sequence numbers, and per (location, channel) the start of its
/// first record and the last sample of its newest (ns).
type StationSpans = ((u64, u64), BTreeMap<(String, String), (i64, i64)>);

/// ringserver's v3 XML answer to `INFO level` (ID, STATIONS, STREAMS) for the ring.
fn ringserver_info(ring: &[Entry], level: Option<&str>) -> String {
    let mut xml = String::from(
        "<?xml version=\"1.0\"?>\n<seedlink software=\"SeedLink v3.1 (rockwatch model of ringserver/4.5.3)\" organization=\"rockwatch tests\" started=\"2026-01-01T00:00:00Z\">",
    );
    let level = level.unwrap_or("").to_ascii_uppercase();
    if level == "STATIONS" || level == "STREAMS" {
        let code = |e: &Entry, r: std::ops::Range<usize>| {
            String::from_utf8_lossy(&e.bytes[r]).trim().to_string()
        };
        // (net, sta) → (loc, cha) → (begin, end), and the station's sequence span.
        let mut stations: BTreeMap<(String, String), StationSpans> = BTreeMap::new();
        for e in ring.iter().filter(|e| e.start_ns != i64::MIN) {
            let station = stations
                .entry((code(e, 18..20), code(e, 8..13)))
                .or_insert(((e.seq, e.seq), Default::default()));
            station.0 = (station.0 .0.min(e.seq), station.0 .1.max(e.seq));
            let span = station
                .1
                .entry((code(e, 13..15), code(e, 15..18)))
                .or_insert((e.start_ns, e.end_ns));
            *span = (span.0.min(e.start_ns), span.1.max(e.end_ns));
        }
        let time = |t: i64| {
            let text = rockwatch_core::utc::format_utc_ns(i128::from(t));
            // ringserver writes microseconds.
            format!("{}Z", &text[..26])
        };
        for ((net, sta), ((first, last), streams)) in stations {
            xml += &format!(
                "<station name=\"{sta}\" network=\"{net}\" description=\"\" begin_seq=\"{first}\" end_seq=\"{last}\" stream_check=\"enabled\">"
            );
            if level == "STREAMS" {
                for ((loc, cha), (begin, end)) in streams {
                    xml += &format!(
                        "<stream location=\"{loc}\" seedname=\"{cha}\" type=\"D\" begin_time=\"{}\" end_time=\"{}\"/>",
                        time(begin),
                        time(end)
                    );
                }
            }
            xml += "</station>";
        }
    }
    xml + "</seedlink>"
}

/// `text` as ringserver sends an INFO answer in SeedLink 3: 512-byte MiniSEED records (a
/// fixed header, blockette 1000, the text from byte 56, at most 456 bytes each, its length
/// as the sample count), each after `SLINFO *`, the last after `SLINFO  `.
fn info_records(text: &str) -> Vec<u8> {
    let chunks: Vec<&[u8]> = text.as_bytes().chunks(456).collect();
    let mut out = Vec::new();
    for (i, chunk) in chunks.iter().enumerate() {
        out.extend_from_slice(if i + 1 == chunks.len() {
            b"SLINFO  "
        } else {
            b"SLINFO *"
        });
        let mut record = vec![0u8; 512];
        record[..6].copy_from_slice(format!("{:06}", i + 1).as_bytes());
        record[6] = b'D';
        record[7] = b' ';
        record[8..13].copy_from_slice(b"INFO ");
        record[13..15].copy_from_slice(b"  ");
        record[15..18].copy_from_slice(b"INF");
        record[18..20].copy_from_slice(b"XX");
        record[30..32].copy_from_slice(&(chunk.len() as u16).to_be_bytes());
        record[39] = 1; // one blockette
        record[44..46].copy_from_slice(&56u16.to_be_bytes());
        record[46..48].copy_from_slice(&48u16.to_be_bytes());
        record[48..50].copy_from_slice(&1000u16.to_be_bytes());
        record[52] = 0; // text
        record[53] = 1; // big endian
        record[54] = 9; // 2^9 bytes
        record[56..56 + chunk.len()].copy_from_slice(chunk);
        out.extend_from_slice(&record);
    }
    out
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

/// The record with its header's sample count set to `n` (more than its Steim frames hold).
pub fn with_sample_count(record: &[u8], n: u16) -> Vec<u8> {
    let mut r = record.to_vec();
    r[30..32].copy_from_slice(&n.to_be_bytes());
    r
}

/// The record with its location code set to `loc` (two characters): another stream of the
/// station, which no pattern selects and the inventory does not hold.
pub fn with_location(record: &[u8], loc: &str) -> Vec<u8> {
    let mut r = record.to_vec();
    r[13..15].copy_from_slice(&loc.as_bytes()[..2]);
    r
}

/// The record with its first Steim frame's forward integration constant (X0, the first
/// sample) moved by 1000 counts: every sample decodes off by 1000, and the last one no longer
/// equals the reverse integration constant (Xn).
pub fn with_corrupt_steim(record: &[u8]) -> Vec<u8> {
    let mut r = record.to_vec();
    let data = usize::from(u16::from_be_bytes([r[44], r[45]]));
    let x0 = i32::from_be_bytes([r[data + 4], r[data + 5], r[data + 6], r[data + 7]]);
    r[data + 4..data + 8].copy_from_slice(&(x0 + 1000).to_be_bytes());
    r
}

/// A FLOAT32 record of the same stream and start as `record` whose samples are all NaN (the
/// writer refuses to encode them, so they are put in its data section afterwards).
pub fn with_nan(record: &[u8]) -> Vec<u8> {
    let mut r = with_values(record, 1.0);
    let data = usize::from(u16::from_be_bytes([r[44], r[45]]));
    for i in 0..100 {
        r[data + 4 * i..data + 4 * i + 4].copy_from_slice(&f32::NAN.to_be_bytes());
    }
    r
}
