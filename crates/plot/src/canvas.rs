//! The drawing backend: plotters' in-memory bitmap with text rasterised
//! here.
//!
//! Plotters 0.3.7's `ab_glyph` text path places each glyph's ink at the pen
//! position, ignoring its left side bearing and rounding the pen down, which
//! spaces letters unevenly ("tim e"). [`Canvas`] forwards everything to a
//! [`BitMapBackend`] except text, which it lays out with kerning and
//! sub-pixel positions and anti-aliases itself, always in the bundled font.

use std::sync::OnceLock;

use ab_glyph::{Font, FontRef, PxScale, ScaleFont, point};
use plotters::prelude::BitMapBackend;
use plotters_backend::text_anchor::{HPos, VPos};
use plotters_backend::{
    BackendColor, BackendCoord, BackendStyle, BackendTextStyle, DrawingBackend, DrawingErrorKind,
};

/// DejaVu Sans 2.37, see `assets/LICENSE-DejaVu.txt`.
pub(crate) const DEJAVU_SANS: &[u8] = include_bytes!("../assets/DejaVuSans.ttf");

/// The bundled font, parsed once; `None` if it cannot be parsed.
pub(crate) fn font() -> Option<&'static FontRef<'static>> {
    static FONT: OnceLock<Option<FontRef<'static>>> = OnceLock::new();
    FONT.get_or_init(|| FontRef::try_from_slice(DEJAVU_SANS).ok())
        .as_ref()
}

/// A [`BitMapBackend`] that draws text in the bundled font.
pub(crate) struct Canvas<'a> {
    inner: BitMapBackend<'a>,
    font: &'static FontRef<'static>,
}

impl<'a> Canvas<'a> {
    pub(crate) fn new(inner: BitMapBackend<'a>, font: &'static FontRef<'static>) -> Self {
        Canvas { inner, font }
    }
}

/// Glyphs of one line of text: positions relative to the top left of its box.
struct Layout {
    glyphs: Vec<(ab_glyph::GlyphId, f32)>,
    scale: PxScale,
    baseline: f32,
    width: f32,
    height: f32,
}

/// Lays out `text` at `size`, the pixel height plotters' own `ab_glyph`
/// text uses. The box is as tall as plotters estimates (`size / 1.24`) so
/// that layouts computed by plotters itself (legends) still fit, and capitals
/// and digits are centred in it.
fn layout(font: &FontRef<'static>, text: &str, size: f64) -> Layout {
    let scale = PxScale::from(size as f32);
    let scaled = font.as_scaled(scale);
    let mut glyphs = Vec::with_capacity(text.len());
    let mut caret = 0.0f32;
    let mut prev = None;
    for c in text.chars() {
        let id = scaled.glyph_id(c);
        if let Some(p) = prev {
            caret += scaled.kern(p, id);
        }
        glyphs.push((id, caret));
        caret += scaled.h_advance(id);
        prev = Some(id);
    }
    // Outline bounds are y-up with min.y the top.
    let cap = font
        .outline(font.glyph_id('H'))
        .map_or(0.7 * scaled.ascent(), |o| {
            o.bounds.min.y * scaled.v_scale_factor()
        });
    let height = size as f32 / 1.24;
    Layout {
        glyphs,
        scale,
        baseline: (height + cap) / 2.0,
        width: caret,
        height,
    }
}

/// Width in pixels of `text` at `size` in the bundled font (0 without it).
pub(crate) fn text_width(text: &str, size: f64) -> f32 {
    font().map_or(0.0, |f| layout(f, text, size).width)
}

impl<'a> DrawingBackend for Canvas<'a> {
    type ErrorType = <BitMapBackend<'a> as DrawingBackend>::ErrorType;

    fn get_size(&self) -> (u32, u32) {
        self.inner.get_size()
    }

    fn ensure_prepared(&mut self) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.inner.ensure_prepared()
    }

    fn present(&mut self) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.inner.present()
    }

    fn draw_pixel(
        &mut self,
        point: BackendCoord,
        color: BackendColor,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.inner.draw_pixel(point, color)
    }

    fn draw_line<S: BackendStyle>(
        &mut self,
        from: BackendCoord,
        to: BackendCoord,
        style: &S,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.inner.draw_line(from, to, style)
    }

    fn draw_rect<S: BackendStyle>(
        &mut self,
        upper_left: BackendCoord,
        bottom_right: BackendCoord,
        style: &S,
        fill: bool,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.inner.draw_rect(upper_left, bottom_right, style, fill)
    }

    fn draw_path<S: BackendStyle, I: IntoIterator<Item = BackendCoord>>(
        &mut self,
        path: I,
        style: &S,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.inner.draw_path(path, style)
    }

    fn draw_circle<S: BackendStyle>(
        &mut self,
        center: BackendCoord,
        radius: u32,
        style: &S,
        fill: bool,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.inner.draw_circle(center, radius, style, fill)
    }

    fn fill_polygon<S: BackendStyle, I: IntoIterator<Item = BackendCoord>>(
        &mut self,
        vert: I,
        style: &S,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.inner.fill_polygon(vert, style)
    }

    fn blit_bitmap(
        &mut self,
        pos: BackendCoord,
        size: (u32, u32),
        src: &[u8],
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.inner.blit_bitmap(pos, size, src)
    }

    fn estimate_text_size<S: BackendTextStyle>(
        &self,
        text: &str,
        style: &S,
    ) -> Result<(u32, u32), DrawingErrorKind<Self::ErrorType>> {
        let layout = layout(self.font, text, style.size());
        Ok((layout.width.ceil() as u32, layout.height.ceil() as u32))
    }

    fn draw_text<S: BackendTextStyle>(
        &mut self,
        text: &str,
        style: &S,
        pos: BackendCoord,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        let color = style.color();
        if color.alpha == 0.0 || text.is_empty() {
            return Ok(());
        }
        let layout = layout(self.font, text, style.size());
        let anchor = style.anchor();
        let dx = match anchor.h_pos {
            HPos::Left => 0.0,
            HPos::Center => -layout.width / 2.0,
            HPos::Right => -layout.width,
        };
        let dy = match anchor.v_pos {
            VPos::Top => 0.0,
            VPos::Center => -layout.height / 2.0,
            VPos::Bottom => -layout.height,
        };
        // Coverage per pixel relative to the anchor, before rotation.
        let mut ink: Vec<(i32, i32, f32)> = Vec::new();
        for &(id, x) in &layout.glyphs {
            let glyph =
                id.with_scale_and_position(layout.scale, point(x + dx, layout.baseline + dy));
            if let Some(outlined) = self.font.outline_glyph(glyph) {
                let bounds = outlined.px_bounds();
                let (x0, y0) = (bounds.min.x as i32, bounds.min.y as i32);
                outlined.draw(|gx, gy, c| ink.push((x0 + gx as i32, y0 + gy as i32, c)));
            }
        }
        let transform = style.transform();
        let (w, h) = self.get_size();
        for (x, y, coverage) in ink {
            if coverage <= 0.0 {
                continue;
            }
            let (tx, ty) = transform.transform(x, y);
            let (px, py) = (pos.0 + tx, pos.1 + ty);
            if px >= 0 && py >= 0 && (px as u32) < w && (py as u32) < h {
                let alpha = color.alpha * f64::from(coverage.min(1.0));
                self.inner.draw_pixel(
                    (px, py),
                    BackendColor {
                        alpha,
                        rgb: color.rgb,
                    },
                )?;
            }
        }
        Ok(())
    }
}
