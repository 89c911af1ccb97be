//! A report as a list of blocks, rendered alike as HTML ([`super::html`])
//! and Markdown ([`super::markdown`]). Text is plain: the renderers escape
//! it.

/// How a paragraph is shown.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Tone {
    /// Plain text.
    Plain,
    /// The verdict: accepted.
    Accepted,
    /// The verdict: rejected.
    Rejected,
    /// A warning.
    Warning,
    /// A note in small print.
    Note,
}

/// One table cell: text, and whether it is a number (right-aligned) and
/// flagged (shown in red: a failed test).
#[derive(Debug, Clone, PartialEq)]
pub struct Cell {
    /// The text.
    pub text: String,
    /// A number: aligned right.
    pub numeric: bool,
    /// A failed test.
    pub flagged: bool,
}

impl Cell {
    /// A text cell.
    pub fn text(text: impl Into<String>) -> Self {
        Self {
            text: text.into(),
            numeric: false,
            flagged: false,
        }
    }

    /// A number cell.
    pub fn number(text: impl Into<String>) -> Self {
        Self {
            numeric: true,
            ..Self::text(text)
        }
    }

    /// This cell, flagged if `flag`.
    pub fn flagged(self, flag: bool) -> Self {
        Self {
            flagged: flag,
            ..self
        }
    }
}

/// One block of a report.
#[derive(Debug, Clone, PartialEq)]
pub enum Block {
    /// A section title (level 1 is the page's title).
    Heading(u8, String),
    /// A paragraph.
    Paragraph(Tone, String),
    /// A bulleted list.
    List(Tone, Vec<String>),
    /// A table: its header and rows.
    Table {
        /// Column titles.
        header: Vec<String>,
        /// Rows of cells.
        rows: Vec<Vec<Cell>>,
    },
    /// A figure: SVG text (from [`crate::plots`]) and its caption.
    Figure {
        /// The SVG.
        svg: String,
        /// The caption.
        caption: String,
    },
}
