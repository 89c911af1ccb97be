//! A report as Markdown: headings, paragraphs, lists and pipe tables;
//! figures by their caption only (the HTML page has them).

use std::fmt::Write;

use super::document::{Block, Tone};

/// `text` with the characters that would end a table cell or start markup
/// escaped, line breaks as spaces, and other control characters shown as
/// Rust escapes them (`\u{1b}`).
fn escape(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '|' | '\\' | '*' | '_' | '`' | '[' | ']' | '<' | '>' | '#' => {
                out.push('\\');
                out.push(c);
            }
            '\n' | '\r' => out.push(' '),
            c if c.is_control() => out.extend(c.escape_debug()),
            c => out.push(c),
        }
    }
    out
}

/// The Markdown of `blocks`.
pub fn render(blocks: &[Block]) -> String {
    let mut out = String::new();
    for block in blocks {
        match block {
            Block::Heading(level, text) => {
                let _ = writeln!(out, "{} {}\n", "#".repeat(*level as usize), escape(text));
            }
            Block::Paragraph(tone, text) => {
                let text = escape(text);
                let _ = match tone {
                    Tone::Accepted | Tone::Rejected => writeln!(out, "**{text}**\n"),
                    Tone::Warning => writeln!(out, "WARNING: {text}\n"),
                    Tone::Note => writeln!(out, "_{text}_\n"),
                    Tone::Plain => writeln!(out, "{text}\n"),
                };
            }
            Block::List(_, items) => {
                for item in items {
                    let _ = writeln!(out, "- {}", escape(item));
                }
                out.push('\n');
            }
            Block::Table { header, rows } => {
                let cells = |cells: Vec<String>| format!("| {} |\n", cells.join(" | "));
                out.push_str(&cells(header.iter().map(|h| escape(h)).collect()));
                let align = |numeric: bool| if numeric { "---:" } else { "---" }.to_string();
                let first = rows.first();
                out.push_str(&cells(
                    (0..header.len())
                        .map(|k| align(first.and_then(|r| r.get(k)).is_some_and(|c| c.numeric)))
                        .collect(),
                ));
                for row in rows {
                    out.push_str(&cells(
                        row.iter()
                            .map(|c| {
                                let text = escape(&c.text);
                                if c.flagged {
                                    format!("**{text}**")
                                } else {
                                    text
                                }
                            })
                            .collect(),
                    ));
                }
                out.push('\n');
            }
            Block::Figure { caption, .. } => {
                let _ = writeln!(out, "_Figure (in the HTML report): {}_\n", escape(caption));
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn control_characters_are_shown_escaped() {
        assert_eq!(escape("a|b\u{1b}[31m\nc"), "a\\|b\\u{1b}\\[31m c");
    }
}
