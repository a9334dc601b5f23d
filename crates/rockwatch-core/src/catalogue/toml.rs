//! The TOML reader: an array of `[[pbr]]` tables and nothing else at the top level (format in
//! the module doc of [`crate::catalogue`]). Each entry is located by the line of its
//! `[[pbr]]` header (1-based) and its 0-based index; sub-fields are named `width_m.min`.

use std::path::Path;

use serde::Deserialize;

use super::validate::RawPbr;
use super::{Catalogue, CatalogueError, EntryContext, LoadWork};

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
        Catalogue::from_toml_counted(text, source_name, base_dir, &mut LoadWork::default())
    }

    /// [`Catalogue::from_toml_str_in`], adding its work to `work`.
    pub(super) fn from_toml_counted(
        text: &str,
        source_name: &str,
        base_dir: Option<&Path>,
        work: &mut LoadWork,
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
        // The entries come in file order: each one's line is counted on from the previous one.
        let mut lines = LineCursor::new(text);
        for (index, spanned) in document.pbr.into_iter().enumerate() {
            let line = Some(lines.line_at(spanned.span().start));
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
            let raw = serde_path_to_error::deserialize::<_, RawPbr>(table).map_err(|e| {
                let path = e.path().to_string();
                let message = e.inner().message().to_owned();
                vec![if path == "." || path.is_empty() {
                    context.error(None, message)
                } else if message.starts_with("unknown field") {
                    // serde's message already names the field.
                    context.error(Some(path), message)
                } else {
                    let message = format!("{path}: {message}");
                    context.error(Some(path), message)
                }]
            });
            entries.push((context, raw));
        }
        work.line_bytes_scanned += lines.scanned;
        Catalogue::build(source_name, entries, base_dir, work)
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

/// The 1-based line of a byte offset of `text`.
fn line_of_offset(text: &str, offset: usize) -> usize {
    LineCursor::new(text).line_at(offset)
}

/// Lines of increasing byte offsets of one text, each counted on from the previous offset, so
/// that placing every entry of a file reads it once (counting from the top for each entry
/// made loading quadratic: issue 24).
struct LineCursor<'a> {
    text: &'a [u8],
    /// The offset reached and its 1-based line.
    offset: usize,
    line: usize,
    /// Bytes read so far (the work the unit tests count).
    scanned: usize,
}

impl<'a> LineCursor<'a> {
    fn new(text: &'a str) -> LineCursor<'a> {
        LineCursor {
            text: text.as_bytes(),
            offset: 0,
            line: 1,
            scanned: 0,
        }
    }

    /// The 1-based line of `offset` (clamped to the text); an offset before the last one
    /// starts again from the top.
    fn line_at(&mut self, offset: usize) -> usize {
        let offset = offset.min(self.text.len());
        if offset < self.offset {
            (self.offset, self.line) = (0, 1);
        }
        let newlines = self.text[self.offset..offset]
            .iter()
            .filter(|&&b| b == b'\n')
            .count();
        self.scanned += offset - self.offset;
        self.line += newlines;
        self.offset = offset;
        self.line
    }
}
