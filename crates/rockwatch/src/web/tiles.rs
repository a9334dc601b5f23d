//! The dashboard map's optional background tiles (`[web] tiles`, `[web] tiles_attribution`):
//! a slippy-map tile URL template, checked at load ([`TileTemplate::parse`]).
//!
//! The tiles are fetched by the operator's browser, never by the node; without a template the
//! page uses no network resource but the node's. The page's Content-Security-Policy allows
//! images from the template's origin only ([`TileTemplate::origin`]).

/// Placeholders a template must hold, each once: zoom, column, row of the tile (the slippy-map
/// scheme: Web Mercator, EPSG:3857, 256-pixel tiles, row 0 at the north edge).
pub const PLACEHOLDERS: [&str; 3] = ["{z}", "{x}", "{y}"];

/// Longest template accepted (bytes).
pub const MAX_TEMPLATE_BYTES: usize = 512;

/// Why a tile URL template is refused.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum TileTemplateError {
    #[error("not an http:// or https:// URL")]
    Scheme,
    #[error("longer than {MAX_TEMPLATE_BYTES} bytes")]
    TooLong,
    #[error("no host after the scheme")]
    NoHost,
    #[error(
        "the host part {host:?} may hold letters, digits, '.', '-', ':', '[' and ']' only (no \
         placeholder, no user name)"
    )]
    Host { host: String },
    #[error("the character {character:?} is not allowed in a tile URL template")]
    Character { character: char },
    #[error("{placeholder} is missing (a template holds {{z}}, {{x}} and {{y}}, each once)")]
    Missing { placeholder: &'static str },
    #[error("{placeholder} appears more than once")]
    Repeated { placeholder: &'static str },
    #[error("unknown placeholder or stray brace at {at:?} (only {{z}}, {{x}} and {{y}})")]
    Unknown { at: String },
}

/// A checked tile URL template (`https://tile.openstreetmap.org/{z}/{x}/{y}.png`).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TileTemplate {
    template: String,
    /// `scheme://host[:port]`, the CSP source of the tiles.
    origin: String,
}

impl TileTemplate {
    /// Checks `template`: an `http` or `https` URL (case-insensitive scheme) with a fixed host,
    /// holding `{z}`, `{x}` and `{y}` once each and no other brace; no whitespace, quote,
    /// backslash, `<`, `>`, `;` or `,` (it goes into the page and its CSP header).
    pub fn parse(template: &str) -> Result<TileTemplate, TileTemplateError> {
        if template.len() > MAX_TEMPLATE_BYTES {
            return Err(TileTemplateError::TooLong);
        }
        let lower = template.to_ascii_lowercase();
        let scheme_len = if lower.starts_with("https://") {
            8
        } else if lower.starts_with("http://") {
            7
        } else {
            return Err(TileTemplateError::Scheme);
        };
        if let Some(character) = template
            .chars()
            .find(|c| c.is_whitespace() || c.is_control() || "\"'\\<>;,`".contains(*c))
        {
            return Err(TileTemplateError::Character { character });
        }
        let rest = &template[scheme_len..];
        let host_end = rest.find(['/', '?', '#']).unwrap_or(rest.len());
        let host = &rest[..host_end];
        if host.is_empty() {
            return Err(TileTemplateError::NoHost);
        }
        if !host
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || ".-:[]".contains(c))
        {
            return Err(TileTemplateError::Host { host: host.into() });
        }
        for placeholder in PLACEHOLDERS {
            match template.matches(placeholder).count() {
                0 => return Err(TileTemplateError::Missing { placeholder }),
                1 => {}
                _ => return Err(TileTemplateError::Repeated { placeholder }),
            }
        }
        let mut bare = template.to_string();
        for placeholder in PLACEHOLDERS {
            bare = bare.replace(placeholder, "");
        }
        if let Some(i) = bare.find(['{', '}']) {
            let at: String = bare[i..].chars().take(8).collect();
            return Err(TileTemplateError::Unknown { at });
        }
        Ok(TileTemplate {
            template: template.to_string(),
            origin: format!("{}{}", &lower[..scheme_len], host.to_ascii_lowercase()),
        })
    }

    /// The template as given.
    #[must_use]
    pub fn as_str(&self) -> &str {
        &self.template
    }

    /// `scheme://host[:port]` (lower case): the one origin the page may load images from.
    #[must_use]
    pub fn origin(&self) -> &str {
        &self.origin
    }

    /// The URL of tile (`z`, `x`, `y`).
    #[must_use]
    pub fn url(&self, z: u8, x: u32, y: u32) -> String {
        self.template
            .replace("{z}", &z.to_string())
            .replace("{x}", &x.to_string())
            .replace("{y}", &y.to_string())
    }
}

/// Longest `tiles_attribution` accepted (characters).
pub const MAX_ATTRIBUTION_CHARS: usize = 200;

/// The map's background, as the page gets it: the template and the text credited on the map.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct MapTiles {
    pub template: TileTemplate,
    /// `[web] tiles_attribution` (e.g. `© OpenStreetMap contributors`), shown under the map.
    pub attribution: Option<String>,
}

/// Why the `[web]` tile keys are refused; the message names the key.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum TilesConfigError {
    #[error("[web] tiles = {given:?}: {error}")]
    Template {
        given: String,
        error: TileTemplateError,
    },
    #[error("[web] tiles is set but [web] listen is not (the tiles are the dashboard's)")]
    WithoutListen,
    #[error("[web] tiles_attribution is set but [web] tiles is not")]
    AttributionWithoutTiles,
    #[error(
        "[web] tiles_attribution: at most {MAX_ATTRIBUTION_CHARS} characters, no control \
         character"
    )]
    Attribution,
}

impl MapTiles {
    /// Checks `[web] tiles` and `tiles_attribution` (`listen`: whether `[web] listen` is set).
    pub fn from_config(
        listen: bool,
        tiles: Option<&str>,
        attribution: Option<&str>,
    ) -> Result<Option<MapTiles>, TilesConfigError> {
        let Some(given) = tiles else {
            return match attribution {
                Some(_) => Err(TilesConfigError::AttributionWithoutTiles),
                None => Ok(None),
            };
        };
        if !listen {
            return Err(TilesConfigError::WithoutListen);
        }
        let template = TileTemplate::parse(given).map_err(|error| TilesConfigError::Template {
            given: given.into(),
            error,
        })?;
        if let Some(a) = attribution {
            if a.chars().count() > MAX_ATTRIBUTION_CHARS || a.chars().any(char::is_control) {
                return Err(TilesConfigError::Attribution);
            }
        }
        Ok(Some(MapTiles {
            template,
            attribution: attribution.map(str::to_string),
        }))
    }

    /// The page's `img-src` CSP source list: the node and the tiles' origin.
    #[must_use]
    pub fn img_src(&self) -> String {
        format!("'self' {}", self.template.origin())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_slippy_map_template_is_accepted_with_its_origin() {
        let t = TileTemplate::parse("https://tile.openstreetmap.org/{z}/{x}/{y}.png").unwrap();
        assert_eq!(t.origin(), "https://tile.openstreetmap.org");
        assert_eq!(
            t.url(12, 701, 1635),
            "https://tile.openstreetmap.org/12/701/1635.png"
        );
        let t = TileTemplate::parse("HTTP://127.0.0.1:8081/t?z={z}&x={x}&y={y}").unwrap();
        assert_eq!(t.origin(), "http://127.0.0.1:8081");
        let t = TileTemplate::parse("http://[::1]:9/{z}/{y}/{x}").unwrap();
        assert_eq!(t.origin(), "http://[::1]:9");
    }

    #[test]
    fn a_template_without_a_placeholder_or_with_another_is_refused() {
        use TileTemplateError as E;
        let e = |t: &str| TileTemplate::parse(t).unwrap_err();
        assert_eq!(e("ftp://h/{z}/{x}/{y}"), E::Scheme);
        assert_eq!(e("file:///tiles/{z}/{x}/{y}.png"), E::Scheme);
        assert_eq!(e("tile.openstreetmap.org/{z}/{x}/{y}.png"), E::Scheme);
        assert_eq!(e("https:///{z}/{x}/{y}"), E::NoHost);
        assert_eq!(
            e("https://h/{z}/{x}.png"),
            E::Missing { placeholder: "{y}" }
        );
        assert_eq!(
            e("https://h/{z}/{x}/{y}/{x}"),
            E::Repeated { placeholder: "{x}" }
        );
        assert_eq!(
            e("https://{s}.tile.osm.org/{z}/{x}/{y}.png"),
            E::Host {
                host: "{s}.tile.osm.org".into()
            }
        );
        assert_eq!(
            e("https://h/{z}/{x}/{y}{r}.png"),
            E::Unknown {
                at: "{r}.png".into()
            }
        );
        assert_eq!(e("https://h/{z}/{x}/{y}}"), E::Unknown { at: "}".into() });
        assert_eq!(
            e("https://user@h/{z}/{x}/{y}"),
            E::Host {
                host: "user@h".into()
            }
        );
        // Nothing that could break out of the page's JSON or the CSP header.
        assert_eq!(
            e("https://h/{z}/{x}/{y}; script-src *"),
            E::Character { character: ';' }
        );
        assert_eq!(
            e("https://h/{z}/{x}/{y}\"<"),
            E::Character { character: '"' }
        );
        assert_eq!(
            e(&format!("https://h/{{z}}/{{x}}/{{y}}{}", "a".repeat(600))),
            E::TooLong
        );
    }

    #[test]
    fn the_tile_keys_are_checked_together_and_errors_name_the_key() {
        let osm = "https://tile.openstreetmap.org/{z}/{x}/{y}.png";
        let t = MapTiles::from_config(true, Some(osm), Some("© OpenStreetMap contributors"))
            .unwrap()
            .unwrap();
        assert_eq!(t.img_src(), "'self' https://tile.openstreetmap.org");
        assert_eq!(MapTiles::from_config(true, None, None), Ok(None));
        assert_eq!(MapTiles::from_config(false, None, None), Ok(None));
        let e = |listen, tiles, attribution| {
            MapTiles::from_config(listen, tiles, attribution)
                .unwrap_err()
                .to_string()
        };
        let m = e(true, Some("https://h/{z}/{x}.png"), None);
        assert!(
            m.starts_with("[web] tiles = \"https://h/{z}/{x}.png\": {y} is missing"),
            "{m}"
        );
        assert!(e(false, Some(osm), None).contains("[web] listen is not"));
        assert!(e(true, None, Some("x")).starts_with("[web] tiles_attribution is set"));
        assert!(e(true, Some(osm), Some("a\nb")).starts_with("[web] tiles_attribution:"));
    }
}
