//! The dashboard's one page (`page.html`, embedded in the binary: no CDN, no external asset).

use axum::http::{header, StatusCode, Uri};
use axum::response::{IntoResponse, Response};

/// The page: HTML, CSS and JavaScript in one file.
pub const PAGE: &str = include_str!("page.html");

/// `GET /`.
pub async fn index() -> Response {
    (
        [
            (header::CONTENT_TYPE, "text/html; charset=utf-8"),
            (
                header::CONTENT_SECURITY_POLICY,
                "default-src 'self'; style-src 'self' 'unsafe-inline'; script-src 'self' 'unsafe-inline'",
            ),
        ],
        PAGE,
    )
        .into_response()
}

/// Any other path: 404 naming what exists.
pub async fn not_found(uri: Uri) -> Response {
    (
        StatusCode::NOT_FOUND,
        format!(
            "not found: {}: try / (dashboard), /api/status, /api/alerts?since=<ns>, /api/rocks/<id>, /api/stations/<id>/trace?seconds=<s>, /api/events, /metrics\n",
            uri.path()
        ),
    )
        .into_response()
}
