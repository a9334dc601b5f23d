//! Text from outside (station ids, block ids, a peer's messages) made fit for one log or
//! output line, so that a hostile id can neither forge lines nor flood them.

/// Most characters of a station id shown in a log line.
pub const STATION_CHARS: usize = 48;

/// Most characters of a block id shown in a log line or a reply.
pub const PBR_ID_CHARS: usize = 200;

/// Most characters of a message shown in a log line.
pub const MESSAGE_CHARS: usize = 400;

/// `text` fit for one line: control characters escaped (`\n`, `\u{0}`, …), at most
/// `max_chars` characters (the rest replaced by a count of its bytes).
#[must_use]
pub fn printable(text: &str, max_chars: usize) -> String {
    let mut out = String::new();
    for (n, c) in text.chars().enumerate() {
        if n == max_chars {
            out += &format!(
                "…(+{} bytes)",
                text.len() - text.char_indices().nth(n).map_or(0, |(i, _)| i)
            );
            break;
        }
        if c.is_control() {
            out.extend(c.escape_default());
        } else {
            out.push(c);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::printable;

    #[test]
    fn printable_escapes_control_characters_and_bounds_the_length() {
        assert_eq!(printable("CI.RRS.00", 48), "CI.RRS.00");
        assert_eq!(
            printable("CI.RRS.00\0\nforged", 48),
            "CI.RRS.00\\u{0}\\nforged"
        );
        let long = "A".repeat(100_000);
        assert_eq!(
            printable(&long, 8),
            format!("AAAAAAAA…(+{} bytes)", 100_000 - 8)
        );
        // Multi-byte characters are counted as characters, never split.
        assert_eq!(printable("ééé", 2), "éé…(+2 bytes)");
    }
}
