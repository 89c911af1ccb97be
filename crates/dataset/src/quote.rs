//! Text from input, as messages quote it: escaped, so that control
//! characters (a terminal's escape sequences) are shown, not obeyed, and
//! shortened, so that a 10 MB field does not become a 10 MB message.

/// Characters of a quoted value kept in a message.
const VALUE_CHARS: usize = 60;
/// Characters kept of each end of a longer text (a field path, a parser's
/// message) that may hold input.
const HEAD_CHARS: usize = 120;
const TAIL_CHARS: usize = 60;

/// `text` in double quotes, escaped as Rust's `{:?}` escapes a string
/// (`"a\u{1b}[31m"`); beyond 60 characters, its first 60, an ellipsis and
/// its length: `"xxx…" (10485760 characters)`.
pub(crate) fn quoted(text: &str) -> String {
    let length = text.chars().count();
    if length <= VALUE_CHARS {
        return format!("{text:?}");
    }
    let head: String = text.chars().take(VALUE_CHARS).collect();
    format!("\"{}…\" ({length} characters)", head.escape_debug())
}

/// [`quoted`] of bytes, which need not be UTF-8 (invalid sequences show as
/// U+FFFD).
pub(crate) fn quoted_bytes(bytes: &[u8]) -> String {
    quoted(&String::from_utf8_lossy(bytes))
}

/// A text that holds input somewhere (a field path with a ball id, a
/// parser's message quoting a value): every character `{:?}` would escape
/// is escaped except quotes and backslashes (the text may be quoting
/// already), and beyond 180 characters the middle is replaced by
/// `…[N characters]…`.
pub(crate) fn sanitized(text: &str) -> String {
    let escape = |chars: &mut dyn Iterator<Item = char>| {
        let mut out = String::new();
        for c in chars {
            if matches!(c, '"' | '\'' | '\\') {
                out.push(c);
            } else {
                out.extend(c.escape_debug());
            }
        }
        out
    };
    let length = text.chars().count();
    if length <= HEAD_CHARS + TAIL_CHARS {
        return escape(&mut text.chars());
    }
    let elided = length - HEAD_CHARS - TAIL_CHARS;
    format!(
        "{}…[{elided} characters]…{}",
        escape(&mut text.chars().take(HEAD_CHARS)),
        escape(&mut text.chars().skip(HEAD_CHARS + elided))
    )
}

/// [`sanitized`] `text` when it is formatted: a field path of a check
/// that is only written out if the check fails.
pub(crate) struct Sanitized<'a>(pub(crate) &'a str);

impl std::fmt::Display for Sanitized<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&sanitized(self.0))
    }
}

/// Whether `text` has a control character (which a label or an id must
/// not have: it would act on the terminal that shows it).
pub(crate) fn has_control(text: &str) -> bool {
    text.chars().any(char::is_control)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn short_text_is_quoted_and_escaped() {
        assert_eq!(quoted("b01"), "\"b01\"");
        assert_eq!(quoted("a\u{1b}[31mred"), "\"a\\u{1b}[31mred\"");
        assert_eq!(quoted("tab\there\n"), "\"tab\\there\\n\"");
        assert_eq!(quoted_bytes(b"x\xffy"), "\"x\u{fffd}y\"");
    }

    #[test]
    fn long_text_is_shortened_with_its_length() {
        let long = "x".repeat(10_000_000);
        let q = quoted(&long);
        assert_eq!(q, format!("\"{}…\" (10000000 characters)", "x".repeat(60)));
        let q = quoted(&format!("{}\u{1b}{}", "y".repeat(59), long));
        assert!(
            q.starts_with(&format!("\"{}\\u{{1b}}…\"", "y".repeat(59))),
            "{q}"
        );
    }

    #[test]
    fn sanitized_keeps_both_ends_and_escapes_controls_only() {
        assert_eq!(
            sanitized("invalid type: string \"a\\\"b\u{7}\", expected f64"),
            "invalid type: string \"a\\\"b\\u{7}\", expected f64"
        );
        let message = format!("string \"{}\", expected f64", "z".repeat(1_000_000));
        let s = sanitized(&message);
        assert!(s.starts_with("string \"zzz"), "{s}");
        assert!(s.ends_with("zzz\", expected f64"), "{s}");
        let elided = message.chars().count() - 180;
        assert!(s.contains(&format!("…[{elided} characters]…")), "{s}");
        assert!(s.chars().count() < 220);
    }
}
