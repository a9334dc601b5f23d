//! The optional Prometheus endpoint (`[metrics] listen = "127.0.0.1:9464"`): a small blocking
//! HTTP responder on its own thread (`rockwatch-metrics`) serving the node's last status
//! ([`crate::status::NodeStatus::prometheus`]) as the text exposition format on `GET /metrics`.
//!
//! The event loop hands it a new text once per status period ([`MetricsServer::update`]: one
//! swap under a mutex); the thread never touches the engine. One connection at a time, each
//! bounded (a request head of at most [`MAX_REQUEST`] bytes, [`IO_TIMEOUT`] per read and
//! write), so a slow or hostile client delays only other scrapers, never the node.

use std::io::{Read, Write};
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use anyhow::Context;

/// Longest request head read (bytes).
pub const MAX_REQUEST: usize = 8192;

/// Read and write timeout of one connection.
pub const IO_TIMEOUT: Duration = Duration::from_secs(2);

/// The `[metrics]` section of the node configuration.
#[derive(Debug, Clone, Default, PartialEq, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MetricsConfig {
    /// Address of the endpoint (`host:port`); none by default.
    #[serde(default)]
    pub listen: Option<String>,
}

/// The endpoint's thread and the text it serves.
pub struct MetricsServer {
    text: Arc<Mutex<String>>,
    stop: Arc<AtomicBool>,
    address: SocketAddr,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl MetricsServer {
    /// Binds `listen` and starts the thread (it serves `# no status yet` until the first
    /// [`MetricsServer::update`]).
    pub fn start(listen: &str) -> anyhow::Result<MetricsServer> {
        let listener = TcpListener::bind(listen)
            .with_context(|| format!("[metrics] listen = {listen:?}: cannot listen there"))?;
        let address = listener.local_addr()?;
        let text = Arc::new(Mutex::new("# no status yet\n".to_string()));
        let stop = Arc::new(AtomicBool::new(false));
        let (served, stopping) = (Arc::clone(&text), Arc::clone(&stop));
        let thread = std::thread::Builder::new()
            .name("rockwatch-metrics".into())
            .spawn(move || {
                for stream in listener.incoming() {
                    if stopping.load(Ordering::Relaxed) {
                        return;
                    }
                    if let Ok(stream) = stream {
                        if let Err(e) = serve(stream, &served) {
                            tracing::debug!("metrics: a request failed: {e}");
                        }
                    }
                }
            })
            .context("cannot start the metrics thread")?;
        tracing::info!("metrics: Prometheus text on http://{address}/metrics");
        Ok(MetricsServer {
            text,
            stop,
            address,
            thread: Some(thread),
        })
    }

    /// The address bound (the port, when `listen` asked for port 0).
    #[must_use]
    pub fn address(&self) -> SocketAddr {
        self.address
    }

    /// Serves `text` from now on.
    pub fn update(&self, text: String) {
        if let Ok(mut t) = self.text.lock() {
            *t = text;
        }
    }
}

impl Drop for MetricsServer {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        // Wakes the blocking accept; the thread sees the flag and ends.
        let _ = TcpStream::connect_timeout(&self.address, IO_TIMEOUT);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// Answers one connection: `GET /metrics` → 200 with the text, another path → 404, another
/// method → 405.
fn serve(mut stream: TcpStream, text: &Mutex<String>) -> std::io::Result<()> {
    stream.set_read_timeout(Some(IO_TIMEOUT))?;
    stream.set_write_timeout(Some(IO_TIMEOUT))?;
    let mut head = Vec::with_capacity(1024);
    let mut buf = [0u8; 1024];
    while !head.windows(4).any(|w| w == b"\r\n\r\n") && head.len() < MAX_REQUEST {
        let n = stream.read(&mut buf)?;
        if n == 0 {
            break;
        }
        head.extend_from_slice(&buf[..n]);
    }
    let line = head.split(|&b| b == b'\r').next().unwrap_or(&[]);
    let line = String::from_utf8_lossy(line);
    let mut parts = line.split(' ');
    let (method, path) = (parts.next().unwrap_or(""), parts.next().unwrap_or(""));
    let (status, body) = match (method, path.split('?').next().unwrap_or("")) {
        ("GET", "/metrics") => ("200 OK", text.lock().map(|t| t.clone()).unwrap_or_default()),
        ("GET", _) => ("404 Not Found", "not found: try /metrics\n".to_string()),
        _ => ("405 Method Not Allowed", "only GET\n".to_string()),
    };
    write!(
        stream,
        "HTTP/1.1 {status}\r\nContent-Type: text/plain; version=0.0.4; charset=utf-8\r\nContent-Length: {}\r\nConnection: close\r\n\r\n{body}",
        body.len()
    )?;
    stream.flush()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn get(address: SocketAddr, request: &str) -> String {
        let mut s = TcpStream::connect(address).unwrap();
        s.write_all(request.as_bytes()).unwrap();
        let mut reply = String::new();
        s.read_to_string(&mut reply).unwrap();
        reply
    }

    #[test]
    fn serves_the_last_text_on_get_metrics_only() {
        let server = MetricsServer::start("127.0.0.1:0").unwrap();
        let address = server.address();
        let first = get(address, "GET /metrics HTTP/1.1\r\nHost: x\r\n\r\n");
        assert!(first.starts_with("HTTP/1.1 200 OK\r\n"), "{first}");
        assert!(first.ends_with("\r\n\r\n# no status yet\n"), "{first}");
        server.update("# TYPE rockwatch_up gauge\nrockwatch_up 1\n".into());
        let reply = get(address, "GET /metrics?x=1 HTTP/1.0\r\n\r\n");
        let (head, body) = reply.split_once("\r\n\r\n").unwrap();
        assert!(
            head.contains("Content-Type: text/plain; version=0.0.4"),
            "{head}"
        );
        assert!(
            head.contains(&format!("Content-Length: {}", body.len())),
            "{head}"
        );
        assert_eq!(body, "# TYPE rockwatch_up gauge\nrockwatch_up 1\n");
        assert!(get(address, "GET / HTTP/1.1\r\n\r\n").starts_with("HTTP/1.1 404"));
        assert!(get(address, "POST /metrics HTTP/1.1\r\n\r\n").starts_with("HTTP/1.1 405"));
        // A client that sends nothing is dropped after IO_TIMEOUT; the next is served.
        let idle = TcpStream::connect(address).unwrap();
        assert!(get(address, "GET /metrics HTTP/1.1\r\n\r\n").contains("rockwatch_up 1"));
        drop(idle);
        drop(server); // the thread ends (joined)
        assert!(TcpStream::connect_timeout(&address, Duration::from_millis(200)).is_err());
    }
}
