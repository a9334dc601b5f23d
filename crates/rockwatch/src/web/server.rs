//! The one HTTP server implementation of the codebase: axum on a tokio current-thread runtime
//! in ONE dedicated thread (`rockwatch-web`), beside the node's mio event loop. It serves one
//! or more listeners, each with its own router (the dashboard's `[web] listen`, the
//! Prometheus-only `[metrics] listen`). The listeners are bound by the caller's thread, so a
//! bad address is an error at start, not a log line later.

use std::net::SocketAddr;
use std::time::Duration;

use anyhow::Context;
use axum::extract::{Request, State};
use axum::http::{header, StatusCode};
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};
use axum::Router;

use super::config::token_matches;

/// Longest the server's thread is given to end its connections when stopped.
pub const SHUTDOWN_GRACE: Duration = Duration::from_secs(2);

/// One listener and what it serves.
pub struct Listener {
    /// The configuration key, for errors and logs (`[web] listen`).
    pub key: &'static str,
    pub listener: std::net::TcpListener,
    pub router: Router,
}

impl Listener {
    /// Binds `listen` (`host:port`) for `router`; the error names `key`.
    pub fn bind(key: &'static str, listen: &str, router: Router) -> anyhow::Result<Listener> {
        let listener = std::net::TcpListener::bind(listen)
            .with_context(|| format!("{key} = {listen:?}: cannot listen there"))?;
        listener
            .set_nonblocking(true)
            .with_context(|| format!("{key} = {listen:?}: cannot make the socket non-blocking"))?;
        Ok(Listener {
            key,
            listener,
            router,
        })
    }
}

/// The server's thread; dropping it stops the server (connections ended, thread joined).
pub struct HttpThread {
    addresses: Vec<SocketAddr>,
    stop: Option<tokio::sync::oneshot::Sender<()>>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl HttpThread {
    /// Starts the thread serving `listeners`; `background` is spawned on its runtime too
    /// (e.g. the dashboard's fan-out of alerts), and ends with it.
    pub fn start<F>(listeners: Vec<Listener>, background: F) -> anyhow::Result<HttpThread>
    where
        F: std::future::Future<Output = ()> + Send + 'static,
    {
        let addresses = listeners
            .iter()
            .map(|l| l.listener.local_addr())
            .collect::<Result<Vec<_>, _>>()
            .context("cannot read a listener's address")?;
        let runtime = tokio::runtime::Builder::new_current_thread()
            .enable_io()
            .enable_time()
            .build()
            .context("cannot build the web server's runtime (tokio)")?;
        let (stop, stopped) = tokio::sync::oneshot::channel::<()>();
        // Converted on the runtime (a tokio listener needs its reactor).
        let thread = std::thread::Builder::new()
            .name("rockwatch-web".into())
            .spawn(move || {
                runtime.block_on(async move {
                    let (all_stop, _) = tokio::sync::broadcast::channel::<()>(1);
                    let mut servers = tokio::task::JoinSet::new();
                    for l in listeners {
                        let key = l.key;
                        let listener = match tokio::net::TcpListener::from_std(l.listener) {
                            Ok(listener) => listener,
                            Err(e) => {
                                tracing::error!("{key}: cannot serve: {e}");
                                continue;
                            }
                        };
                        let mut stop_rx = all_stop.subscribe();
                        servers.spawn(async move {
                            let served = axum::serve(listener, l.router)
                                .with_graceful_shutdown(async move {
                                    let _ = stop_rx.recv().await;
                                })
                                .await;
                            if let Err(e) = served {
                                tracing::error!("{key}: the server failed: {e}");
                            }
                        });
                    }
                    let background = tokio::spawn(background);
                    let _ = stopped.await;
                    let _ = all_stop.send(());
                    background.abort();
                    // Streams (SSE) never end by themselves: bounded grace, then dropped.
                    let _ = tokio::time::timeout(SHUTDOWN_GRACE, async {
                        while servers.join_next().await.is_some() {}
                    })
                    .await;
                });
            })
            .context("cannot start the web server's thread")?;
        Ok(HttpThread {
            addresses,
            stop: Some(stop),
            thread: Some(thread),
        })
    }

    /// The addresses bound, in the order of the listeners (the port, when one asked for 0).
    #[must_use]
    pub fn addresses(&self) -> &[SocketAddr] {
        &self.addresses
    }
}

impl Drop for HttpThread {
    fn drop(&mut self) {
        if let Some(stop) = self.stop.take() {
            let _ = stop.send(());
        }
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// Middleware: every request must carry `Authorization: Bearer <token>` (compared in
/// constant time), else 401 with a `WWW-Authenticate` header.
pub async fn require_token(
    State(token): State<std::sync::Arc<str>>,
    request: Request,
    next: Next,
) -> Response {
    let given = request
        .headers()
        .get(header::AUTHORIZATION)
        .and_then(|v| v.as_bytes().strip_prefix(b"Bearer "));
    match given {
        Some(given) if token_matches(given, token.as_bytes()) => next.run(request).await,
        _ => (
            StatusCode::UNAUTHORIZED,
            [(header::WWW_AUTHENTICATE, "Bearer")],
            "401 unauthorized: this endpoint needs `Authorization: Bearer <token>` (the listener's token_file)\n",
        )
            .into_response(),
    }
}
