//! A report as one self-contained HTML page: inline CSS and SVG, no
//! script, no external resource. Every text is escaped.

use std::fmt::Write;

use super::document::{Block, Cell, Tone};

/// `text` with the five HTML metacharacters escaped (for element content
/// and quoted attribute values alike), and control characters but line
/// breaks and tabs shown as Rust escapes them (`\u{1b}`).
pub fn escape(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            '\n' | '\t' => out.push(c),
            c if c.is_control() => out.extend(c.escape_debug()),
            c => out.push(c),
        }
    }
    out
}

const STYLE: &str = "body{font-family:-apple-system,'Segoe UI',Helvetica,Arial,sans-serif;max-width:1100px;margin:2em auto;padding:0 1.5em;color:#222;line-height:1.45}
h1{font-size:1.7em;border-bottom:2px solid #333;padding-bottom:.3em}
h2{font-size:1.3em;margin-top:1.8em;border-bottom:1px solid #ccc;padding-bottom:.2em}
table{border-collapse:collapse;margin:.8em 0;font-size:.92em}
th,td{border:1px solid #ccc;padding:.25em .6em;vertical-align:top}
th{background:#f0f0f0;text-align:left}
td.num{text-align:right;font-variant-numeric:tabular-nums;white-space:nowrap}
tr:nth-child(even) td{background:#fafafa}
td.flag{color:#b00;font-weight:bold}
p.verdict{font-size:1.35em;font-weight:bold;padding:.6em .9em;border-radius:4px}
p.accepted{background:#e3f4e3;border:2px solid #2a7a2a;color:#1d5e1d}
p.rejected{background:#fbe3e3;border:2px solid #b00;color:#8a0000}
.warning{color:#8a5a00}
ul.warning li{margin:.2em 0}
p.note{font-size:.85em;color:#555}
figure{margin:1em 0;display:inline-block;vertical-align:top}
figure svg{max-width:100%;height:auto;border:1px solid #ddd}
figcaption{font-size:.9em;color:#444;max-width:760px}";

/// The page of `blocks` titled `title`.
pub fn render(title: &str, blocks: &[Block]) -> String {
    let mut out = String::new();
    let _ = write!(
        out,
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>{}</title>\n<style>\n{STYLE}\n</style>\n</head>\n<body>\n",
        escape(title)
    );
    let mut verdict_given = false;
    for block in blocks {
        match block {
            Block::Heading(level, text) => {
                let level = level.clamp(&1, &4);
                let _ = writeln!(out, "<h{level}>{}</h{level}>", escape(text));
            }
            Block::Paragraph(tone, text) => {
                let attributes = match tone {
                    Tone::Plain => String::new(),
                    Tone::Accepted | Tone::Rejected => {
                        // The first verdict paragraph is the page's verdict line.
                        let id = if verdict_given { "" } else { " id=\"verdict\"" };
                        verdict_given = true;
                        let class = if *tone == Tone::Accepted {
                            "accepted"
                        } else {
                            "rejected"
                        };
                        format!("{id} class=\"verdict {class}\"")
                    }
                    Tone::Warning => " class=\"warning\"".to_string(),
                    Tone::Note => " class=\"note\"".to_string(),
                };
                let _ = writeln!(out, "<p{attributes}>{}</p>", escape(text));
            }
            Block::List(tone, items) => {
                let class = match tone {
                    Tone::Warning | Tone::Rejected => " class=\"warning\"",
                    _ => "",
                };
                let _ = writeln!(out, "<ul{class}>");
                for item in items {
                    let _ = writeln!(out, "<li>{}</li>", escape(item));
                }
                out.push_str("</ul>\n");
            }
            Block::Table { header, rows } => table(&mut out, header, rows),
            Block::Figure { svg, caption } => {
                let _ = writeln!(
                    out,
                    "<figure>\n{svg}\n<figcaption>{}</figcaption>\n</figure>",
                    escape(caption)
                );
            }
        }
    }
    out.push_str("</body>\n</html>\n");
    out
}

fn table(out: &mut String, header: &[String], rows: &[Vec<Cell>]) {
    out.push_str("<table>\n<thead><tr>");
    for h in header {
        let _ = write!(out, "<th>{}</th>", escape(h));
    }
    out.push_str("</tr></thead>\n<tbody>\n");
    for row in rows {
        out.push_str("<tr>");
        for cell in row {
            let classes: Vec<&str> = [(cell.numeric, "num"), (cell.flagged, "flag")]
                .iter()
                .filter(|(on, _)| *on)
                .map(|(_, c)| *c)
                .collect();
            let class = if classes.is_empty() {
                String::new()
            } else {
                format!(" class=\"{}\"", classes.join(" "))
            };
            let _ = write!(out, "<td{class}>{}</td>", escape(&cell.text));
        }
        out.push_str("</tr>\n");
    }
    out.push_str("</tbody>\n</table>\n");
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn metacharacters_are_escaped() {
        assert_eq!(
            escape("<script>alert('x')</script> & \"b\""),
            "&lt;script&gt;alert(&#39;x&#39;)&lt;/script&gt; &amp; &quot;b&quot;"
        );
    }

    #[test]
    fn control_characters_are_shown_escaped() {
        assert_eq!(escape("a\u{1b}[31m\u{7}b\nc"), "a\\u{1b}[31m\\u{7}b\nc");
    }
}
