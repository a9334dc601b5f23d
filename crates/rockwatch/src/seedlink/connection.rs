//! One SeedLink connection (blocking TCP): HELLO and protocol negotiation, the
//! STATION/SELECT/DATA requests, END, then packets. Commands end with CR LF (some servers
//! hang on CR alone). Every read has a deadline, so nothing here blocks forever.

use std::io::{Read, Write};
use std::net::{TcpStream, ToSocketAddrs};
use std::time::{Duration, Instant};

use rockwatch_core::seedlink::frame::{parse_frame, Frame, MAX_V4_PAYLOAD};
use rockwatch_core::seedlink::info::{
    info_packet_text, parse_stations, parse_streams, InfoError, StreamSpan,
};
use rockwatch_core::seedlink::select::StreamPattern;
use rockwatch_core::seedlink::sequence::V3_MODULUS;
use rockwatch_core::seedlink::Protocol;
use rockwatch_core::utc::format_utc_ns;

use super::{LinkError, ProtocolChoice};

/// Longest response line accepted (bytes).
const MAX_LINE: usize = 4096;

/// Longest INFO answer accepted (bytes): 64 MiB (a station list of 100 000 stations).
const MAX_INFO_BYTES: usize = 64 << 20;

/// An open, negotiated connection.
pub struct Connection {
    stream: TcpStream,
    /// Received bytes not yet consumed: `buf[start..end]`.
    buf: Vec<u8>,
    start: usize,
    end: usize,
    pub protocol: Protocol,
    /// The server's HELLO line (software and capabilities).
    pub server_id: String,
    /// When the server started (`started` of its INFO ID answer), if it says: a change
    /// between connections means a restart, whose sequence numbers may have started again.
    pub server_started: Option<String>,
}

/// Where a station's data should start.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Resume {
    /// What arrives from now on (`DATA`).
    Next,
    /// After this sequence number (`DATA seq`: the last one received).
    After(u64),
    /// Records starting at or after this time (ns since the epoch; whole seconds below):
    /// after a server restart, when sequence numbers mean nothing any more.
    Since(i64),
}

impl Connection {
    /// Connects to `addr`, says HELLO and negotiates the protocol: v4 when the server lists
    /// `SLPROTO:4.0` and `choice` allows it, else v3 (`choice` V4 with a v3-only server is an
    /// error). `timeout` bounds the connection and every response.
    pub fn open(
        addr: &str,
        choice: ProtocolChoice,
        timeout: Duration,
    ) -> Result<Connection, LinkError> {
        let addrs: Vec<_> = addr
            .to_socket_addrs()
            .map_err(|e| LinkError::Io(format!("cannot resolve {addr}: {e}")))?
            .collect();
        let mut last = None;
        let mut stream = None;
        for a in addrs {
            match TcpStream::connect_timeout(&a, timeout) {
                Ok(s) => {
                    stream = Some(s);
                    break;
                }
                Err(e) => last = Some(e),
            }
        }
        let stream = stream.ok_or_else(|| {
            LinkError::Io(format!(
                "cannot connect to {addr}: {}",
                last.map_or_else(|| "no address".into(), |e| e.to_string())
            ))
        })?;
        stream.set_nodelay(true).ok();
        let mut conn = Connection {
            stream,
            buf: vec![0; 2 * (MAX_V4_PAYLOAD + 512)],
            start: 0,
            end: 0,
            protocol: Protocol::V3,
            server_id: String::new(),
            server_started: None,
        };
        conn.send("HELLO\r\n")?;
        let deadline = Instant::now() + timeout;
        conn.server_id = conn.read_line(deadline)?;
        let _organization = conn.read_line(deadline)?;
        let offers_v4 = conn.server_id.contains("SLPROTO:4.0");
        let v4 = match choice {
            ProtocolChoice::Auto => offers_v4,
            ProtocolChoice::V3 => false,
            ProtocolChoice::V4 if offers_v4 => true,
            ProtocolChoice::V4 => {
                return Err(LinkError::Refused(format!(
                    "protocol = 4, but the server does not offer SLPROTO:4.0 ({:?})",
                    conn.server_id
                )))
            }
        };
        if v4 {
            conn.command("SLPROTO 4.0\r\n", deadline)?;
            conn.protocol = Protocol::V4;
        }
        conn.server_started = conn.query_started(deadline)?;
        Ok(conn)
    }

    /// `INFO ID`: the server's start time (the `started` attribute), or `None` when the
    /// server refuses INFO or does not say.
    fn query_started(&mut self, deadline: Instant) -> Result<Option<String>, LinkError> {
        let Some(text) = self.info("ID", deadline)? else {
            return Ok(None);
        };
        Ok(text
            .split("started=\"")
            .nth(1)
            .and_then(|rest| rest.split('"').next())
            .map(|s| s.chars().filter(|c| !c.is_control()).take(64).collect()))
    }

    /// `INFO STATIONS`: the server's stations (network, station), or `None` when the server
    /// refuses INFO STATIONS. An answer that cannot be read is an error.
    pub fn query_stations(
        &mut self,
        timeout: Duration,
    ) -> Result<Option<Vec<(String, String)>>, LinkError> {
        let deadline = Instant::now() + timeout;
        match self.info("STATIONS", deadline)? {
            None => Ok(None),
            Some(text) => parse_stations(&text)
                .map(Some)
                .map_err(|e| LinkError::Protocol(e.to_string())),
        }
    }

    /// `INFO STREAMS`: the streams of the server's ring with the time span of their data;
    /// `Ok(None)` when the server refuses INFO STREAMS; `Ok(Some(Err(_)))` when the answer
    /// cannot be read (the caller logs and counts it and goes on without it: the connection
    /// is fine).
    pub fn query_streams(
        &mut self,
        timeout: Duration,
    ) -> Result<Option<Result<Vec<StreamSpan>, InfoError>>, LinkError> {
        let deadline = Instant::now() + timeout;
        Ok(self
            .info("STREAMS", deadline)?
            .map(|text| parse_streams(&text)))
    }

    /// `INFO level`: the text of the answer, or `None` when the server answers ERROR. The
    /// answer is INFO packets (v3 `SLINFO`, the last one without `*`, each a MiniSEED record
    /// holding part of the text on ringserver and SeisComP; v4 one packet; some servers send
    /// numbered packets), which some servers follow with `END`.
    fn info(&mut self, level: &str, deadline: Instant) -> Result<Option<String>, LinkError> {
        self.send(&format!("INFO {level}\r\n"))?;
        let mut text = Vec::new();
        loop {
            let pending = &self.buf[self.start..self.end];
            if pending.first() == Some(&b'E') {
                // END (end of the INFO answer) or ERROR (INFO not supported).
                let line = self.read_line(deadline)?;
                if line.starts_with("ERROR") {
                    return Ok(None);
                }
                break;
            }
            if pending.len() >= 2 {
                let header_flag = pending.get(7).copied();
                match parse_frame(pending, self.protocol) {
                    Ok(Some((frame, used))) => {
                        // v3: the text inside the MiniSEED record that carries it.
                        text.extend_from_slice(match self.protocol {
                            Protocol::V3 => info_packet_text(frame.payload),
                            Protocol::V4 => frame.payload,
                        });
                        let last = match self.protocol {
                            Protocol::V3 => frame.subformat == b'I' && header_flag != Some(b'*'),
                            Protocol::V4 => true,
                        };
                        self.start += used;
                        if last {
                            // Some servers end with END: take it if it comes promptly.
                            let pending = &self.buf[self.start..self.end];
                            if pending.is_empty() {
                                self.fill(Duration::from_millis(300))?;
                            }
                            if self.buf[self.start..self.end].first() == Some(&b'E') {
                                self.read_line(deadline)?;
                            }
                            break;
                        }
                        continue;
                    }
                    Ok(None) => {}
                    Err(e) => return Err(LinkError::Protocol(format!("INFO {level} answer: {e}"))),
                }
            }
            if text.len() > MAX_INFO_BYTES {
                return Err(LinkError::Protocol(format!(
                    "INFO {level} answer longer than {MAX_INFO_BYTES} bytes"
                )));
            }
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                return Err(LinkError::Timeout(format!("no answer to INFO {level}")));
            }
            self.fill(left)?;
        }
        Ok(Some(String::from_utf8_lossy(&text).into_owned()))
    }

    /// Requests the streams: per station, STATION, the SELECTs its patterns can express, and
    /// where to start ([`Resume`]: v3 `DATA`, `DATA seq` in 6 hex digits, `TIME y,m,d,h,m,s`;
    /// v4 `DATA`, `DATA seq` in decimal, `DATA ALL start`), then END. A station the server
    /// refuses is skipped (returned); none accepted is an error.
    pub fn request(
        &mut self,
        patterns: &[StreamPattern],
        resume: &dyn Fn(&StreamPattern) -> Resume,
        timeout: Duration,
    ) -> Result<Vec<String>, LinkError> {
        let deadline = Instant::now() + timeout;
        let mut stations: Vec<Vec<&StreamPattern>> = Vec::new();
        for p in patterns {
            match stations
                .iter_mut()
                .find(|g| g[0].network == p.network && g[0].station == p.station)
            {
                Some(group) => group.push(p),
                None => stations.push(vec![p]),
            }
        }
        let mut refused = Vec::new();
        for group in &stations {
            let name = format!("{}.{}", group[0].network, group[0].station);
            if let Err(e) = self.command(&group[0].station_command(self.protocol), deadline) {
                match e {
                    LinkError::Refused(reason) => {
                        refused.push(format!("{name}: {reason}"));
                        continue;
                    }
                    other => return Err(other),
                }
            }
            // A pattern the protocol cannot express selects the whole station.
            let selects: Option<Vec<String>> = group
                .iter()
                .map(|p| p.select_command(self.protocol))
                .collect();
            for select in selects.unwrap_or_default() {
                self.command(&select, deadline)
                    .map_err(|e| LinkError::Refused(format!("{name}: {}: {e}", select.trim())))?;
            }
            let data = match (resume(group[0]), self.protocol) {
                (Resume::After(seq), Protocol::V3) => format!("DATA {:06X}\r\n", seq % V3_MODULUS),
                (Resume::After(seq), Protocol::V4) => format!("DATA {seq}\r\n"),
                (Resume::Since(t_ns), Protocol::V3) => {
                    // "YYYY-MM-DDThh:mm:ss…" → "YYYY,MM,DD,hh,mm,ss".
                    let t = format_utc_ns(i128::from(t_ns));
                    format!("TIME {}\r\n", t[..19].replace(['-', 'T', ':'], ","))
                }
                (Resume::Since(t_ns), Protocol::V4) => {
                    format!("DATA ALL {}Z\r\n", &format_utc_ns(i128::from(t_ns))[..19])
                }
                (Resume::Next, _) => "DATA\r\n".to_string(),
            };
            match self.command(&data, deadline) {
                // A v4 server without time selection: everything it holds (duplicates are
                // dropped by the caller) rather than nothing.
                Err(LinkError::Refused(_)) if data.starts_with("DATA ALL") => {
                    self.command("DATA\r\n", deadline)
                        .map_err(|e| LinkError::Refused(format!("{name}: DATA: {e}")))?;
                }
                result => result
                    .map_err(|e| LinkError::Refused(format!("{name}: {}: {e}", data.trim())))?,
            }
        }
        if refused.len() == stations.len() {
            return Err(LinkError::Refused(format!(
                "no station accepted ({})",
                refused.join("; ")
            )));
        }
        self.send("END\r\n")?;
        Ok(refused)
    }

    /// Reads what arrives within `wait` and calls `on_frame` for every complete packet.
    /// `Ok(false)` when nothing arrived (the caller decides about idle timeouts); EOF and I/O
    /// errors are errors.
    pub fn poll_frames(
        &mut self,
        wait: Duration,
        on_frame: &mut dyn FnMut(Frame<'_>),
    ) -> Result<bool, LinkError> {
        if !self.fill(wait)? {
            return Ok(false);
        }
        loop {
            match parse_frame(&self.buf[self.start..self.end], self.protocol) {
                Ok(Some((frame, used))) => {
                    on_frame(frame);
                    self.start += used;
                }
                Ok(None) => break,
                Err(e) => return Err(LinkError::Protocol(e.to_string())),
            }
        }
        Ok(true)
    }

    /// Bytes received and not yet consumed: a partial packet, between complete ones.
    #[must_use]
    pub fn pending_bytes(&self) -> usize {
        self.end - self.start
    }

    /// Says BYE (best effort) and closes.
    pub fn close(mut self) {
        let _ = self.send("BYE\r\n");
    }

    fn send(&mut self, command: &str) -> Result<(), LinkError> {
        self.stream
            .write_all(command.as_bytes())
            .map_err(|e| LinkError::Io(format!("cannot send {}: {e}", command.trim())))
    }

    /// Sends a command and expects `OK`; `ERROR …` is [`LinkError::Refused`].
    fn command(&mut self, command: &str, deadline: Instant) -> Result<(), LinkError> {
        self.send(command)?;
        let reply = self.read_line(deadline)?;
        if reply.starts_with("OK") {
            Ok(())
        } else if reply.starts_with("ERROR") {
            Err(LinkError::Refused(format!("{} → {reply}", command.trim())))
        } else {
            Err(LinkError::Protocol(format!(
                "unexpected reply to {}: {reply:?}",
                command.trim()
            )))
        }
    }

    /// One response line (CR LF, or LF, or CR-terminated), before `deadline`.
    fn read_line(&mut self, deadline: Instant) -> Result<String, LinkError> {
        loop {
            let pending = &self.buf[self.start..self.end];
            if let Some(i) = pending.iter().position(|&b| b == b'\n' || b == b'\r') {
                let line = String::from_utf8_lossy(&pending[..i]).into_owned();
                let mut used = i + 1;
                if pending[i] == b'\r' && pending.get(i + 1) == Some(&b'\n') {
                    used += 1;
                }
                self.start += used;
                return Ok(line);
            }
            if pending.len() > MAX_LINE {
                return Err(LinkError::Protocol("response line too long".into()));
            }
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                return Err(LinkError::Timeout("no response from the server".into()));
            }
            self.fill(left)?;
        }
    }

    /// Reads once (waiting at most `wait`); `Ok(false)` on timeout.
    fn fill(&mut self, wait: Duration) -> Result<bool, LinkError> {
        if self.start == self.end {
            self.start = 0;
            self.end = 0;
        } else if self.end == self.buf.len() {
            self.buf.copy_within(self.start..self.end, 0);
            self.end -= self.start;
            self.start = 0;
        }
        self.stream
            .set_read_timeout(Some(wait.max(Duration::from_millis(1))))
            .map_err(|e| LinkError::Io(e.to_string()))?;
        match self.stream.read(&mut self.buf[self.end..]) {
            Ok(0) => Err(LinkError::Eof),
            Ok(n) => {
                self.end += n;
                Ok(true)
            }
            Err(e)
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::WouldBlock
                        | std::io::ErrorKind::TimedOut
                        | std::io::ErrorKind::Interrupted
                ) =>
            {
                Ok(false)
            }
            Err(e) => Err(LinkError::Io(e.to_string())),
        }
    }
}
