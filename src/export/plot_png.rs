//! PNG plots: a plotters drawing backend over an RGB [`Image`], its text in the 5 x 7 pixel
//! font of every PNG bezchain writes, so that each plot drawn for SVG (generic over the
//! backend) is drawn to PNG by the same code, with no font files.

use super::offset_map::Rgb;
use super::raster::{glyph, Image};
use crate::error::{Error, Result};
use plotters::coord::Shift;
use plotters::prelude::{DrawingArea, IntoDrawingArea};
use plotters_backend::text_anchor::{HPos, VPos};
use plotters_backend::{
    BackendColor, BackendCoord, BackendTextStyle, DrawingBackend, DrawingErrorKind, FontTransform,
};

/// A plotters backend that draws into an RGB picture (see the module docs).
pub struct PixelBackend<'a> {
    image: &'a mut Image,
}

/// The backend's error: drawing into memory does not fail.
#[derive(Debug)]
pub struct NoError;

impl std::fmt::Display for NoError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("no error")
    }
}

impl std::error::Error for NoError {}

impl<'a> PixelBackend<'a> {
    /// A backend drawing into `image`.
    pub fn new(image: &'a mut Image) -> Self {
        PixelBackend { image }
    }

    /// Blend `rgb` over pixel `(x, y)` with opacity `alpha` (outside the picture: nothing).
    fn blend(&mut self, x: i32, y: i32, rgb: Rgb, alpha: f64) {
        let (w, h) = (self.image.width as i32, self.image.height as i32);
        if x < 0 || y < 0 || x >= w || y >= h || alpha <= 0.0 {
            return;
        }
        let k = 3 * (y as usize * w as usize + x as usize);
        let a = alpha.min(1.0);
        for (d, s) in self.image.rgb[k..k + 3].iter_mut().zip(rgb) {
            *d = (f64::from(*d) * (1.0 - a) + f64::from(s) * a).round() as u8;
        }
    }
}

/// Font pixels a glyph pixel of text of `size` (plotters' font size, pixels): the 7-pixel
/// glyphs stand for capitals about 0.7 of the size tall.
fn text_scale(size: f64) -> i32 {
    ((0.7 * size / 7.0).round() as i32).max(1)
}

/// Width and height of `text` at `scale`, unrotated: six font pixels a character (five and a
/// space), seven tall.
fn text_box(text: &str, scale: i32) -> (i32, i32) {
    (text.chars().count() as i32 * 6 * scale - scale, 7 * scale)
}

impl DrawingBackend for PixelBackend<'_> {
    type ErrorType = NoError;

    fn get_size(&self) -> (u32, u32) {
        (self.image.width, self.image.height)
    }

    fn ensure_prepared(&mut self) -> std::result::Result<(), DrawingErrorKind<NoError>> {
        Ok(())
    }

    fn present(&mut self) -> std::result::Result<(), DrawingErrorKind<NoError>> {
        Ok(())
    }

    fn draw_pixel(
        &mut self,
        (x, y): BackendCoord,
        c: BackendColor,
    ) -> std::result::Result<(), DrawingErrorKind<NoError>> {
        self.blend(x, y, [c.rgb.0, c.rgb.1, c.rgb.2], c.alpha);
        Ok(())
    }

    fn draw_text<S: BackendTextStyle>(
        &mut self,
        text: &str,
        style: &S,
        (x, y): BackendCoord,
    ) -> std::result::Result<(), DrawingErrorKind<NoError>> {
        let c = style.color();
        let rgb = [c.rgb.0, c.rgb.1, c.rgb.2];
        let scale = text_scale(style.size());
        let (w, h) = text_box(text, scale);
        // The anchor, in the text's own (unrotated) frame.
        let dx = match style.anchor().h_pos {
            HPos::Left => 0,
            HPos::Center => -w / 2,
            HPos::Right => -w,
        };
        let dy = match style.anchor().v_pos {
            VPos::Top => 0,
            VPos::Center => -h / 2,
            VPos::Bottom => -h,
        };
        let transform = style.transform();
        for (k, ch) in text.chars().enumerate() {
            let Some(rows) = glyph(ch) else { continue };
            for (r, bits) in rows.iter().enumerate() {
                for col in 0..5 {
                    if bits & (0x10 >> col) == 0 {
                        continue;
                    }
                    for sy in 0..scale {
                        for sx in 0..scale {
                            let u = dx + (k as i32 * 6 + col) * scale + sx;
                            let v = dy + r as i32 * scale + sy;
                            let (px, py) = match transform {
                                FontTransform::None => (u, v),
                                FontTransform::Rotate90 => (-v, u),
                                FontTransform::Rotate180 => (-u, -v),
                                FontTransform::Rotate270 => (v, -u),
                            };
                            self.blend(x + px, y + py, rgb, c.alpha);
                        }
                    }
                }
            }
        }
        Ok(())
    }

    fn estimate_text_size<S: BackendTextStyle>(
        &self,
        text: &str,
        style: &S,
    ) -> std::result::Result<(u32, u32), DrawingErrorKind<NoError>> {
        let (w, h) = text_box(text, text_scale(style.size()));
        Ok((w.max(0) as u32, h as u32))
    }
}

/// A plot of `width` x `height` pixels drawn by `draw` (the same drawing code as the plot's
/// SVG), as PNG bytes.
pub fn plot_png(
    width: u32,
    height: u32,
    draw: impl FnOnce(&DrawingArea<PixelBackend<'_>, Shift>) -> Result<()>,
) -> Result<Vec<u8>> {
    let mut image = Image::blank(width, height);
    {
        let root = PixelBackend::new(&mut image).into_drawing_area();
        draw(&root)?;
        root.present()
            .map_err(|e| Error::Output(format!("png plot: {e:?}")))?;
    }
    image.to_png()
}

#[cfg(test)]
mod tests {
    use super::*;
    use plotters::prelude::*;

    /// A line, a filled rectangle and a label land where they were drawn, in their colours.
    #[test]
    fn shapes_and_text_land_where_drawn() {
        let mut img = Image::blank(120, 60);
        let mut backend = PixelBackend::new(&mut img);
        backend.draw_line((10, 10), (110, 10), &RED.to_rgba()).unwrap();
        backend
            .draw_rect((10, 30), (20, 40), &BLUE.to_rgba(), true)
            .unwrap();
        let style = TextStyle::from(("sans-serif", 20).into_font()).color(&BLACK);
        backend.draw_text("10", &style, (60, 30)).unwrap();
        assert_eq!(img.pixel(50, 10), [255, 0, 0]);
        assert_eq!(img.pixel(15, 35), [0, 0, 255]);
        assert_eq!(img.pixel(5, 5), [255, 255, 255]);
        let dark = (30..50)
            .flat_map(|y| (60..80).map(move |x| (x, y)))
            .filter(|&(x, y)| img.pixel(x, y) == [0, 0, 0])
            .count();
        assert!(dark > 10, "the label's pixels: {dark}");
        let (w, h) = text_box("10", text_scale(20.0));
        assert_eq!((w, h), (22, 14));
    }
}
