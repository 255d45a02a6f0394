//! A CPU raster: an RGB [`Image`] and its PNG, the [`Canvas`] it is drawn on (with depth, for
//! the surface pictures), the 5 x 7 pixel font of every PNG's labels, and the drawing
//! primitives (text, triangles with depth, lines and discs over a surface), shared by the
//! surface pictures ([`super::render`]) and the PNG plots ([`super::plot_png`]).

use super::offset_map::Rgb;
use crate::error::{Error, Result};

/// The background.
pub const BACKGROUND: Rgb = [255, 255, 255];
/// Control-net lines, and the labels' text.
pub const NET: Rgb = [60, 60, 60];

/// An RGB picture, row-major from the top left.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `3 * width * height` bytes.
    pub rgb: Vec<u8>,
}

impl Image {
    /// The colour at `(x, y)`.
    #[must_use]
    pub fn pixel(&self, x: u32, y: u32) -> Rgb {
        let k = 3 * (y as usize * self.width as usize + x as usize);
        [self.rgb[k], self.rgb[k + 1], self.rgb[k + 2]]
    }

    /// A white picture of `width` x `height` pixels.
    #[must_use]
    pub fn blank(width: u32, height: u32) -> Image {
        Image {
            width,
            height,
            rgb: vec![255; 3 * width as usize * height as usize],
        }
    }

    /// The picture as PNG bytes (8-bit RGB).
    pub fn to_png(&self) -> Result<Vec<u8>> {
        let mut out = Vec::new();
        let mut enc = png::Encoder::new(&mut out, self.width, self.height);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        let mut w = enc
            .write_header()
            .map_err(|e| Error::Output(format!("png: {e}")))?;
        w.write_image_data(&self.rgb)
            .map_err(|e| Error::Output(format!("png: {e}")))?;
        w.finish().map_err(|e| Error::Output(format!("png: {e}")))?;
        Ok(out)
    }
}

/// A render target with depth, at the supersampled size.
pub(crate) struct Canvas {
    pub(crate) w: usize,
    pub(crate) h: usize,
    pub(crate) rgb: Vec<[f32; 3]>,
    pub(crate) depth: Vec<f64>,
}

impl Canvas {
    pub(crate) fn new(w: usize, h: usize) -> Canvas {
        let bg = BACKGROUND.map(f32::from);
        Canvas {
            w,
            h,
            rgb: vec![bg; w * h],
            depth: vec![f64::NEG_INFINITY; w * h],
        }
    }

    /// Blend `c` over pixel `(x, y)` with opacity `a`.
    pub(crate) fn blend(&mut self, x: i64, y: i64, c: Rgb, a: f32) {
        if x < 0 || y < 0 || x >= self.w as i64 || y >= self.h as i64 {
            return;
        }
        let k = y as usize * self.w + x as usize;
        for (d, s) in self.rgb[k].iter_mut().zip(c) {
            *d = *d * (1.0 - a) + f32::from(s) * a;
        }
    }

    /// Opacity for an overlay at depth `z` (larger is nearer): full in front of the surface,
    /// faint behind it.
    pub(crate) fn overlay_alpha(&self, x: i64, y: i64, z: f64, tol: f64) -> f32 {
        if x < 0 || y < 0 || x >= self.w as i64 || y >= self.h as i64 {
            return 0.0;
        }
        if z + tol >= self.depth[y as usize * self.w + x as usize] {
            1.0
        } else {
            0.22
        }
    }
}

/// 5 x 7 pixel glyphs (one row a byte, the low 5 bits, most significant bit leftmost) for the
/// picture's labels: digits, lower-case letters (capitals are drawn lower-case), α, ° and the
/// signs the labels use; other characters are left out.
pub(crate) fn glyph(c: char) -> Option<[u8; 7]> {
    Some(match c.to_ascii_lowercase() {
        '0' => [0x0e, 0x11, 0x13, 0x15, 0x19, 0x11, 0x0e],
        '1' => [0x04, 0x0c, 0x04, 0x04, 0x04, 0x04, 0x0e],
        '2' => [0x0e, 0x11, 0x01, 0x02, 0x04, 0x08, 0x1f],
        '3' => [0x1f, 0x02, 0x04, 0x02, 0x01, 0x11, 0x0e],
        '4' => [0x02, 0x06, 0x0a, 0x12, 0x1f, 0x02, 0x02],
        '5' => [0x1f, 0x10, 0x1e, 0x01, 0x01, 0x11, 0x0e],
        '6' => [0x06, 0x08, 0x10, 0x1e, 0x11, 0x11, 0x0e],
        '7' => [0x1f, 0x01, 0x02, 0x04, 0x08, 0x08, 0x08],
        '8' => [0x0e, 0x11, 0x11, 0x0e, 0x11, 0x11, 0x0e],
        '9' => [0x0e, 0x11, 0x11, 0x0f, 0x01, 0x02, 0x0c],
        '.' => [0x00, 0x00, 0x00, 0x00, 0x00, 0x0c, 0x0c],
        ',' => [0x00, 0x00, 0x00, 0x00, 0x0c, 0x04, 0x08],
        ':' => [0x00, 0x0c, 0x0c, 0x00, 0x0c, 0x0c, 0x00],
        ';' => [0x00, 0x0c, 0x0c, 0x00, 0x0c, 0x04, 0x08],
        '-' => [0x00, 0x00, 0x00, 0x1f, 0x00, 0x00, 0x00],
        '+' => [0x00, 0x04, 0x04, 0x1f, 0x04, 0x04, 0x00],
        '=' => [0x00, 0x00, 0x1f, 0x00, 0x1f, 0x00, 0x00],
        '/' => [0x00, 0x01, 0x02, 0x04, 0x08, 0x10, 0x00],
        '%' => [0x18, 0x19, 0x02, 0x04, 0x08, 0x13, 0x03],
        '\'' => [0x04, 0x04, 0x08, 0x00, 0x00, 0x00, 0x00],
        '(' => [0x02, 0x04, 0x08, 0x08, 0x08, 0x04, 0x02],
        ')' => [0x08, 0x04, 0x02, 0x02, 0x02, 0x04, 0x08],
        'a' => [0x00, 0x00, 0x0e, 0x01, 0x0f, 0x11, 0x0f],
        'b' => [0x10, 0x10, 0x16, 0x19, 0x11, 0x11, 0x1e],
        'c' => [0x00, 0x00, 0x0e, 0x10, 0x10, 0x11, 0x0e],
        'd' => [0x01, 0x01, 0x0d, 0x13, 0x11, 0x11, 0x0f],
        'e' => [0x00, 0x00, 0x0e, 0x11, 0x1f, 0x10, 0x0e],
        'f' => [0x06, 0x09, 0x08, 0x1c, 0x08, 0x08, 0x08],
        'g' => [0x00, 0x0f, 0x11, 0x11, 0x0f, 0x01, 0x0e],
        'h' => [0x10, 0x10, 0x16, 0x19, 0x11, 0x11, 0x11],
        'i' => [0x04, 0x00, 0x0c, 0x04, 0x04, 0x04, 0x0e],
        'j' => [0x02, 0x00, 0x06, 0x02, 0x02, 0x12, 0x0c],
        'k' => [0x10, 0x10, 0x12, 0x14, 0x18, 0x14, 0x12],
        'l' => [0x0c, 0x04, 0x04, 0x04, 0x04, 0x04, 0x0e],
        'm' => [0x00, 0x00, 0x1a, 0x15, 0x15, 0x11, 0x11],
        'n' => [0x00, 0x00, 0x16, 0x19, 0x11, 0x11, 0x11],
        'o' => [0x00, 0x00, 0x0e, 0x11, 0x11, 0x11, 0x0e],
        'p' => [0x00, 0x00, 0x1e, 0x11, 0x1e, 0x10, 0x10],
        'q' => [0x00, 0x00, 0x0d, 0x13, 0x0f, 0x01, 0x01],
        'r' => [0x00, 0x00, 0x16, 0x19, 0x10, 0x10, 0x10],
        's' => [0x00, 0x00, 0x0f, 0x10, 0x0e, 0x01, 0x1e],
        't' => [0x08, 0x08, 0x1c, 0x08, 0x08, 0x09, 0x06],
        'u' => [0x00, 0x00, 0x11, 0x11, 0x11, 0x13, 0x0d],
        'v' => [0x00, 0x00, 0x11, 0x11, 0x11, 0x0a, 0x04],
        'w' => [0x00, 0x00, 0x11, 0x11, 0x15, 0x15, 0x0a],
        'x' => [0x00, 0x00, 0x11, 0x0a, 0x04, 0x0a, 0x11],
        'y' => [0x00, 0x00, 0x11, 0x11, 0x0f, 0x01, 0x0e],
        'z' => [0x00, 0x00, 0x1f, 0x02, 0x04, 0x08, 0x1f],
        '[' => [0x0e, 0x08, 0x08, 0x08, 0x08, 0x08, 0x0e],
        ']' => [0x0e, 0x02, 0x02, 0x02, 0x02, 0x02, 0x0e],
        '_' => [0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x1f],
        '<' => [0x02, 0x04, 0x08, 0x10, 0x08, 0x04, 0x02],
        '>' => [0x08, 0x04, 0x02, 0x01, 0x02, 0x04, 0x08],
        '×' => [0x00, 0x11, 0x0a, 0x04, 0x0a, 0x11, 0x00],
        '°' => [0x0c, 0x12, 0x12, 0x0c, 0x00, 0x00, 0x00],
        'α' => [0x00, 0x00, 0x09, 0x15, 0x12, 0x12, 0x0d],
        ' ' => [0; 7],
        _ => return None,
    })
}

/// Draw `text` with its top-left corner at `(x, y)`, each font pixel `scale` canvas pixels.
pub(crate) fn draw_text(canvas: &mut Canvas, x: i64, y: i64, text: &str, scale: i64, colour: Rgb) {
    for (k, c) in text.chars().enumerate() {
        let Some(g) = glyph(c) else { continue };
        let x0 = x + k as i64 * 6 * scale;
        for (r, bits) in g.iter().enumerate() {
            for col in 0..5 {
                if bits & (0x10 >> col) != 0 {
                    for dy in 0..scale {
                        for dx in 0..scale {
                            canvas.blend(x0 + col * scale + dx, y + r as i64 * scale + dy, colour, 1.0);
                        }
                    }
                }
            }
        }
    }
}

/// Text on a light box (so that it reads over any colour), top-left at `(x, y)`.
pub(crate) fn draw_boxed_text(canvas: &mut Canvas, x: i64, y: i64, text: &str, scale: i64) {
    let (bw, bh) = (text.chars().count() as i64 * 6 * scale + 2 * scale, 9 * scale);
    for yy in y - scale..y - scale + bh {
        for xx in x - scale..x - scale + bw {
            canvas.blend(xx, yy, BACKGROUND, 0.8);
        }
    }
    draw_text(canvas, x, y, text, scale, NET);
}

/// Fill a triangle with per-vertex base colours and shading (diffuse factor, white highlight),
/// keeping the nearest surface per pixel.
pub(crate) fn fill_triangle(
    canvas: &mut Canvas,
    v: [(f64, f64, f64); 3],
    shade: [[f32; 2]; 3],
    base: [[f32; 3]; 3],
) {
    let (x0, x1) = (
        v.iter().map(|p| p.0).fold(f64::MAX, f64::min),
        v.iter().map(|p| p.0).fold(f64::MIN, f64::max),
    );
    let (y0, y1) = (
        v.iter().map(|p| p.1).fold(f64::MAX, f64::min),
        v.iter().map(|p| p.1).fold(f64::MIN, f64::max),
    );
    let area = (v[1].0 - v[0].0) * (v[2].1 - v[0].1) - (v[2].0 - v[0].0) * (v[1].1 - v[0].1);
    if area.abs() <= 1e-12 || !area.is_finite() {
        return;
    }
    let xa = x0.floor().max(0.0) as i64;
    let xb = (x1.ceil() as i64).min(canvas.w as i64 - 1);
    let ya = y0.floor().max(0.0) as i64;
    let yb = (y1.ceil() as i64).min(canvas.h as i64 - 1);
    for y in ya..=yb {
        for x in xa..=xb {
            let (px, py) = (x as f64 + 0.5, y as f64 + 0.5);
            let w0 = ((v[1].0 - px) * (v[2].1 - py) - (v[2].0 - px) * (v[1].1 - py)) / area;
            let w1 = ((v[2].0 - px) * (v[0].1 - py) - (v[0].0 - px) * (v[2].1 - py)) / area;
            let w2 = 1.0 - w0 - w1;
            if w0 < -1e-9 || w1 < -1e-9 || w2 < -1e-9 {
                continue;
            }
            let z = w0 * v[0].2 + w1 * v[1].2 + w2 * v[2].2;
            let k = y as usize * canvas.w + x as usize;
            if z > canvas.depth[k] {
                canvas.depth[k] = z;
                let (w0, w1, w2) = (w0 as f32, w1 as f32, w2 as f32);
                let d = w0 * shade[0][0] + w1 * shade[1][0] + w2 * shade[2][0];
                let h = w0 * shade[0][1] + w1 * shade[1][1] + w2 * shade[2][1];
                let colour = [0, 1, 2].map(|c| w0 * base[0][c] + w1 * base[1][c] + w2 * base[2][c]);
                canvas.rgb[k] = colour.map(|c| (c * d + 255.0 * h).min(255.0));
            }
        }
    }
}

/// A line of half-width `thick` and colour `colour`: opacity `front` where in front of the
/// surface, `behind` behind it.
#[allow(clippy::too_many_arguments)]
pub(crate) fn draw_line(
    canvas: &mut Canvas,
    a: (f64, f64, f64),
    b: (f64, f64, f64),
    thick: f64,
    tol: f64,
    colour: Rgb,
    front: f32,
    behind: f32,
) {
    let len = ((b.0 - a.0).powi(2) + (b.1 - a.1).powi(2)).sqrt();
    if !len.is_finite() {
        return;
    }
    let steps = (len * 2.0).ceil().max(1.0) as usize;
    let r = thick.ceil() as i64;
    for s in 0..=steps {
        let f = s as f64 / steps as f64;
        let (x, y, z) = (
            a.0 + f * (b.0 - a.0),
            a.1 + f * (b.1 - a.1),
            a.2 + f * (b.2 - a.2),
        );
        for dy in -r..=r {
            for dx in -r..=r {
                if ((dx * dx + dy * dy) as f64).sqrt() > thick {
                    continue;
                }
                let (px, py) = (x.round() as i64 + dx, y.round() as i64 + dy);
                let alpha = canvas.overlay_alpha(px, py, z, tol);
                let alpha = if alpha >= 1.0 {
                    front
                } else if alpha > 0.0 {
                    behind
                } else {
                    0.0
                };
                canvas.blend(px, py, colour, alpha);
            }
        }
    }
}

/// A filled disc with a thin white rim, opaque in front of the surface, faint behind it.
/// `opacity` scales both.
pub(crate) fn draw_disc(
    canvas: &mut Canvas,
    p: (f64, f64, f64),
    radius: f64,
    colour: Rgb,
    tol: f64,
    opacity: f32,
) {
    if !(p.0.is_finite() && p.1.is_finite()) {
        return;
    }
    let r = (radius + 1.0).ceil() as i64;
    let (cx, cy) = (p.0.round() as i64, p.1.round() as i64);
    for dy in -r..=r {
        for dx in -r..=r {
            let d = ((dx * dx + dy * dy) as f64).sqrt();
            if d > radius + 1.0 {
                continue;
            }
            let alpha = opacity * canvas.overlay_alpha(cx + dx, cy + dy, p.2, tol);
            let c = if d > radius { BACKGROUND } else { colour };
            canvas.blend(cx + dx, cy + dy, c, alpha);
        }
    }
}
