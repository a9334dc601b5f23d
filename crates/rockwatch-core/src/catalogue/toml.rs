//! The TOML reader: an array of `[[pbr]]` tables and nothing else at the top level (format in
//! the module doc of [`crate::catalogue`]). Each entry is located by the line of its
//! `[[pbr]]` header (1-based) and its 0-based index; sub-fields are named `width_m.min`.

use std::path::Path;

use serde::Deserialize;

use super::validate::RawPbr;
use super::{Catalogue, CatalogueError, EntryContext};

impl Catalogue {
    /// Parses a TOML catalogue; `source_name` names it in error messages. Relative `mesh`
    /// paths are taken from the current directory (see [`Catalogue::from_toml_str_in`]).
    pub fn from_toml_str(text: &str, source_name: &str) -> Result<Catalogue, CatalogueError> {
        Catalogue::from_toml_str_in(text, source_name, None)
    }

    /// Parses a TOML catalogue whose relative `mesh` paths are relative to `base_dir` (the
    /// catalogue file's directory).
    pub fn from_toml_str_in(
        text: &str,
        source_name: &str,
        base_dir: Option<&Path>,
    ) -> Result<Catalogue, CatalogueError> {
        #[derive(Deserialize)]
        #[serde(deny_unknown_fields)]
        struct Document {
            #[serde(default)]
            pbr: Vec<toml::Spanned<toml::Table>>,
        }
        let document: Document = toml::from_str(text).map_err(|e| CatalogueError::Syntax {
            location: source_name.to_owned(),
            message: toml_error_line(text, &e),
        })?;
        let mut entries = Vec::with_capacity(document.pbr.len());
        for (index, spanned) in document.pbr.into_iter().enumerate() {
            let line = Some(line_of_offset(text, spanned.span().start));
            let table = spanned.into_inner();
            let id = table
                .get("id")
                .and_then(toml::Value::as_str)
                .filter(|s| !s.is_empty())
                .map(str::to_owned);
            let context = EntryContext {
                source_name,
                line,
                index,
                id,
                sub_separator: '.',
            };
            let raw: RawPbr = serde_path_to_error::deserialize(table).map_err(|e| {
                let path = e.path().to_string();
                let message = e.inner().message().to_owned();
                if path == "." || path.is_empty() {
                    context.error(None, message)
                } else if message.starts_with("unknown field") {
                    // serde's message already names the field.
                    context.error(Some(path), message)
                } else {
                    let message = format!("{path}: {message}");
                    context.error(Some(path), message)
                }
            })?;
            entries.push((context, raw));
        }
        Catalogue::build(source_name, entries, base_dir)
    }
}

/// A TOML error as one line, `line N: message` (toml's own rendering spans several lines).
pub fn toml_error_line(text: &str, error: &toml::de::Error) -> String {
    let message = error.message().replace('\n', " ");
    match error.span() {
        Some(span) => format!("line {}: {message}", line_of_offset(text, span.start)),
        None => message,
    }
}

fn line_of_offset(text: &str, offset: usize) -> usize {
    let end = offset.min(text.len());
    text.as_bytes()[..end]
        .iter()
        .filter(|&&b| b == b'\n')
        .count()
        + 1
}
