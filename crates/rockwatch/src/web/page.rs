//! The dashboard's one page (`page.html`, embedded in the binary: no CDN, no external asset),
//! with the map's tile settings written into it at start ([`Page::new`]).

use std::sync::Arc;

use axum::extract::State;
use axum::http::{header, StatusCode, Uri};
use axum::response::{IntoResponse, Response};

use super::tiles::MapTiles;

/// The page: HTML, CSS and JavaScript in one file.
pub const PAGE: &str = include_str!("page.html");

/// The element of [`PAGE`] that carries the map's tile settings (JSON; `null`: no tiles).
const TILES_ELEMENT: &str = r#"<script id="map-tiles" type="application/json">null</script>"#;

/// The page as served, and its Content-Security-Policy.
#[derive(Debug, Clone)]
pub struct Page {
    html: String,
    csp: String,
}

impl Page {
    /// The page for `tiles` (`[web] tiles`): without, no image source but the node's; with,
    /// the template and attribution in the page (`{"template", "origin", "attribution"}`) and
    /// `img-src` allowing the tiles' origin only.
    #[must_use]
    pub fn new(tiles: Option<&MapTiles>) -> Page {
        let base = "default-src 'self'; style-src 'self' 'unsafe-inline'; script-src 'self' 'unsafe-inline'";
        let Some(tiles) = tiles else {
            return Page {
                html: PAGE.to_string(),
                csp: base.to_string(),
            };
        };
        let json = serde_json::json!({
            "template": tiles.template.as_str(),
            "origin": tiles.template.origin(),
            "attribution": tiles.attribution,
        })
        .to_string()
        // Inside a <script> element: no "</script>" or "<!--" can be formed.
        .replace('<', "\\u003c")
        .replace('>', "\\u003e")
        .replace('&', "\\u0026");
        Page {
            html: PAGE.replace(
                TILES_ELEMENT,
                &TILES_ELEMENT.replace(">null<", &format!(">{json}<")),
            ),
            csp: format!("{base}; img-src {}", tiles.img_src()),
        }
    }
}

/// `GET /`.
pub async fn index(State(page): State<Arc<Page>>) -> Response {
    (
        [
            (header::CONTENT_TYPE, "text/html; charset=utf-8"),
            (header::CONTENT_SECURITY_POLICY, page.csp.as_str()),
        ],
        page.html.clone(),
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_tile_settings_go_into_the_page_and_its_csp_allows_their_origin_only() {
        let plain = Page::new(None);
        assert_eq!(plain.html, PAGE);
        assert!(PAGE.contains(TILES_ELEMENT));
        assert!(!plain.csp.contains("img-src"), "{}", plain.csp);
        let tiles = MapTiles::from_config(
            true,
            Some("https://tile.example.org:8443/{z}/{x}/{y}.png?k=1&v=2"),
            Some("© <b>Example</b> & co"),
        )
        .unwrap()
        .unwrap();
        let page = Page::new(Some(&tiles));
        assert!(
            page.csp
                .ends_with("; img-src 'self' https://tile.example.org:8443"),
            "{}",
            page.csp
        );
        let start = page
            .html
            .find(r#"<script id="map-tiles" type="application/json">"#)
            .unwrap();
        let rest = &page.html[start..];
        let element = &rest[..rest.find("</script>").unwrap()];
        let json: serde_json::Value =
            serde_json::from_str(element.split_once('>').unwrap().1).unwrap();
        assert_eq!(
            json["template"],
            "https://tile.example.org:8443/{z}/{x}/{y}.png?k=1&v=2"
        );
        assert_eq!(json["attribution"], "© <b>Example</b> & co");
        assert!(!element.contains("<b>"), "{element}");
    }
}
