//! The optional Prometheus endpoint (`[metrics] listen = "127.0.0.1:9464"`): `GET /metrics`
//! as the text exposition format, on the codebase's one HTTP server ([`crate::web::server`]:
//! axum on tokio, one thread). The node serves its status ([`crate::status::NodeStatus::prometheus`])
//! there and on the dashboard's `/metrics` (`[web] listen`) from the same thread
//! ([`crate::web::WebServer`]); `[metrics] listen` is a `/metrics`-only listener, for a scraper
//! that should not reach the dashboard. As every listener ([`crate::web::config::listener_token`]):
//! loopback by default, and an address off loopback needs `[metrics] token_file`, a bearer
//! token every scrape must carry (Prometheus: `authorization: { credentials_file: … }`).
//! `rockwatch acquire` uses [`MetricsServer`], a text the caller replaces once per period.

use std::net::SocketAddr;
use std::sync::{Arc, Mutex};

use crate::web::server::HttpThread;

/// The `[metrics]` section (node and acquire): kept with `[web]`, the other listener.
pub use crate::web::config::MetricsConfig;

/// The endpoint's server and the text it serves.
pub struct MetricsServer {
    text: Arc<Mutex<String>>,
    address: SocketAddr,
    /// Stops the server when dropped.
    _thread: HttpThread,
}

impl MetricsServer {
    /// Binds `listen` and starts the server (it serves `# no status yet` until the first
    /// [`MetricsServer::update`]); with `token`, every request must carry it.
    pub fn start(listen: &str, token: Option<String>) -> anyhow::Result<MetricsServer> {
        let (thread, text) = crate::web::text_metrics_server(listen, token)?;
        let address = thread.addresses()[0];
        tracing::info!("metrics: Prometheus text on http://{address}/metrics");
        Ok(MetricsServer {
            text,
            address,
            _thread: thread,
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

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::{Read, Write};
    use std::net::TcpStream;
    use std::time::Duration;

    fn get(address: SocketAddr, request: &str) -> String {
        let mut s = TcpStream::connect(address).unwrap();
        s.write_all(request.as_bytes()).unwrap();
        let mut reply = String::new();
        s.read_to_string(&mut reply).unwrap();
        reply
    }

    #[test]
    fn serves_the_last_text_on_get_metrics_only() {
        let server = MetricsServer::start("127.0.0.1:0", None).unwrap();
        let address = server.address();
        let first = get(
            address,
            "GET /metrics HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n",
        );
        assert!(first.starts_with("HTTP/1.1 200 OK\r\n"), "{first}");
        assert!(first.ends_with("\r\n\r\n# no status yet\n"), "{first}");
        server.update("# TYPE rockwatch_up gauge\nrockwatch_up 1\n".into());
        let reply = get(address, "GET /metrics?x=1 HTTP/1.0\r\n\r\n");
        let (head, body) = reply.split_once("\r\n\r\n").unwrap();
        // Header names are case-insensitive (hyper writes them in lower case).
        let head = head.to_ascii_lowercase();
        assert!(
            head.contains("content-type: text/plain; version=0.0.4"),
            "{head}"
        );
        assert!(
            head.contains(&format!("content-length: {}", body.len())),
            "{head}"
        );
        assert_eq!(body, "# TYPE rockwatch_up gauge\nrockwatch_up 1\n");
        assert!(
            get(address, "GET / HTTP/1.1\r\nConnection: close\r\n\r\n").starts_with("HTTP/1.1 404")
        );
        assert!(get(
            address,
            "POST /metrics HTTP/1.1\r\nConnection: close\r\n\r\n"
        )
        .starts_with("HTTP/1.1 405"));
        // A client that sends nothing does not hold the others up.
        let idle = TcpStream::connect(address).unwrap();
        assert!(get(
            address,
            "GET /metrics HTTP/1.1\r\nConnection: close\r\n\r\n"
        )
        .contains("rockwatch_up 1"));
        drop(idle);
        drop(server); // the thread ends (joined)
        assert!(TcpStream::connect_timeout(&address, Duration::from_millis(200)).is_err());
    }

    #[test]
    fn an_address_off_loopback_needs_a_token_and_every_scrape_must_carry_it() {
        let open = MetricsConfig {
            listen: Some("0.0.0.0:9464".into()),
            token_file: None,
        };
        let e = open.token().unwrap_err().to_string();
        assert!(
            e.contains("[metrics] listen") && e.contains("[metrics] token_file"),
            "{e}"
        );
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("metrics.token"), "0123456789abcdef0123\n").unwrap();
        let mut config = MetricsConfig {
            listen: Some("127.0.0.1:0".into()),
            token_file: Some("metrics.token".into()),
        };
        config.resolve(dir.path());
        let token = config.token().unwrap();
        assert_eq!(token.as_deref(), Some("0123456789abcdef0123"));
        let server = MetricsServer::start("127.0.0.1:0", token).unwrap();
        server.update("rockwatch_up 1\n".into());
        let bare = "GET /metrics HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n";
        assert!(get(server.address(), bare).starts_with("HTTP/1.1 401"));
        let wrong = "GET /metrics HTTP/1.1\r\nAuthorization: Bearer 0123456789abcdef0124\r\n\
                     Connection: close\r\n\r\n";
        assert!(get(server.address(), wrong).starts_with("HTTP/1.1 401"));
        let good = "GET /metrics HTTP/1.1\r\nAuthorization: Bearer 0123456789abcdef0123\r\n\
                    Connection: close\r\n\r\n";
        let reply = get(server.address(), good);
        assert!(
            reply.starts_with("HTTP/1.1 200") && reply.ends_with("rockwatch_up 1\n"),
            "{reply}"
        );
    }
}
