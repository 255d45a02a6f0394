//! A PNG picture of a fitted patch grid with its control net (like the paper's Figs. 12–14):
//! a CPU rasteriser with a z-buffer, the surface shaded, the net drawn as lines, design points
//! and generated points as dots of two colours, one panel per view.

use super::mesh::SurfaceMesh;
use crate::chain::PatchGrid;
use crate::error::{Error, Result};
use crate::eval::dense::{dense_grid, uniform, DensePoint};
use crate::eval::Backend;
use glam::DVec3;

/// An RGB colour.
pub type Rgb = [u8; 3];

/// The background.
pub const BACKGROUND: Rgb = [255, 255, 255];
/// The surface's base colour (shaded by the light).
pub const SURFACE: Rgb = [150, 178, 214];
/// Control-net lines.
pub const NET: Rgb = [60, 60, 60];
/// Data points.
pub const DATA_POINT: Rgb = [20, 20, 20];
/// Patch borders drawn on the surface.
pub const BORDER: Rgb = [38, 62, 110];
/// Design points (the optimisation variables).
pub const DESIGN_POINT: Rgb = [214, 40, 40];
/// Generated points (expanded control points along the patch borders).
pub const GENERATED_POINT: Rgb = [30, 110, 220];

/// A direction to look from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct View {
    /// From the scene towards the camera (any length).
    pub eye: DVec3,
    /// A direction that should point right in the picture (made perpendicular to `eye`), e.g.
    /// a blade's span.
    pub right: DVec3,
}

/// How to draw the picture.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderOptions {
    /// Picture width in pixels. Default 1600.
    pub width: u32,
    /// Picture height in pixels, shared by the views stacked top to bottom. Default 900.
    pub height: u32,
    /// The views, one panel each. Default: a blade along +z seen from the suction side and
    /// the leading edge, then from the pressure side and the trailing edge (like Figs. 13, 14).
    pub views: Vec<View>,
    /// Samples per patch side of the shaded surface. Default 16.
    pub per_patch: usize,
    /// Supersampling factor per axis (anti-aliasing). Default 2.
    pub supersample: u32,
    /// Data points to draw as small dots (e.g. the fitted cloud or a sample of it). Default
    /// none.
    pub cloud: Vec<DVec3>,
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            width: 1600,
            height: 900,
            views: vec![
                View {
                    eye: DVec3::new(-0.45, 0.75, -0.55),
                    right: DVec3::Z,
                },
                View {
                    eye: DVec3::new(0.5, -0.75, -0.5),
                    right: DVec3::Z,
                },
            ],
            per_patch: 16,
            supersample: 2,
            cloud: Vec::new(),
        }
    }
}

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
struct Canvas {
    w: usize,
    h: usize,
    rgb: Vec<[f32; 3]>,
    depth: Vec<f64>,
}

impl Canvas {
    fn new(w: usize, h: usize) -> Canvas {
        let bg = BACKGROUND.map(f32::from);
        Canvas {
            w,
            h,
            rgb: vec![bg; w * h],
            depth: vec![f64::NEG_INFINITY; w * h],
        }
    }

    /// Blend `c` over pixel `(x, y)` with opacity `a`.
    fn blend(&mut self, x: i64, y: i64, c: Rgb, a: f32) {
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
    fn overlay_alpha(&self, x: i64, y: i64, z: f64, tol: f64) -> f32 {
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

/// An orthographic camera fitted to a panel.
struct Camera {
    right: DVec3,
    up: DVec3,
    eye: DVec3,
    scale: f64,
    offset: (f64, f64),
}

impl Camera {
    fn new(view: &View, points: &[DVec3], panel: (f64, f64, f64, f64)) -> Result<Camera> {
        let eye = view
            .eye
            .try_normalize()
            .ok_or_else(|| Error::invalid("a view direction is zero"))?;
        let right = (view.right - eye * view.right.dot(eye))
            .try_normalize()
            .or_else(|| eye.any_orthonormal_vector().try_normalize())
            .ok_or_else(|| Error::invalid("a view direction is not finite"))?;
        let up = eye.cross(right);
        let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
        for p in points {
            let (x, y) = (p.dot(right), p.dot(up));
            x0 = x0.min(x);
            x1 = x1.max(x);
            y0 = y0.min(y);
            y1 = y1.max(y);
        }
        let (px, py, pw, ph) = panel;
        let margin = 0.06;
        let span_x = (x1 - x0).max(f64::MIN_POSITIVE);
        let span_y = (y1 - y0).max(f64::MIN_POSITIVE);
        let scale = ((1.0 - 2.0 * margin) * pw / span_x).min((1.0 - 2.0 * margin) * ph / span_y);
        if !scale.is_finite() {
            return Err(Error::Output("nothing to draw: the surface has no extent".into()));
        }
        // Centre the drawing in the panel.
        let offset = (
            px + 0.5 * pw - scale * 0.5 * (x0 + x1),
            py + 0.5 * ph + scale * 0.5 * (y0 + y1),
        );
        Ok(Camera {
            right,
            up,
            eye,
            scale,
            offset,
        })
    }

    /// Pixel coordinates and depth (larger is nearer) of `p`.
    fn project(&self, p: DVec3) -> (f64, f64, f64) {
        (
            self.offset.0 + self.scale * p.dot(self.right),
            self.offset.1 - self.scale * p.dot(self.up),
            p.dot(self.eye),
        )
    }
}

/// The rows of a row-major dense grid of `cols` columns, as curves (each at one u).
fn rows_of(points: &[DensePoint], cols: usize) -> Vec<Vec<DVec3>> {
    points
        .chunks_exact(cols)
        .map(|row| row.iter().map(|p| p.position).collect())
        .collect()
}

/// The columns of a row-major dense grid of `cols` columns, as curves (each at one v).
fn columns_of(points: &[DensePoint], cols: usize) -> Vec<Vec<DVec3>> {
    (0..cols)
        .map(|j| points.iter().skip(j).step_by(cols).map(|p| p.position).collect())
        .collect()
}

/// Draw `grid` (with its control net) in every view of `opts`.
pub fn render(grid: &PatchGrid<DVec3>, opts: &RenderOptions) -> Result<Image> {
    if opts.width < 16 || opts.height < 16 || opts.width > 16384 || opts.height > 16384 {
        return Err(Error::invalid(format!(
            "picture size {} x {} is outside 16 to 16384 pixels each way",
            opts.width, opts.height
        )));
    }
    if opts.views.is_empty() {
        return Err(Error::invalid("a picture needs at least one view"));
    }
    let ss = opts.supersample.clamp(1, 4) as usize;
    let (w, h) = (opts.width as usize * ss, opts.height as usize * ss);
    let mesh = SurfaceMesh::from_grid(grid, opts.per_patch.max(1))?;
    let l = grid.layout();
    let (bu, bv) = (l.u.breaks(), l.v.breaks());
    let along = uniform(401);
    let borders: Vec<Vec<DVec3>> = [
        rows_of(&dense_grid(grid, bu, &along, Backend::Cpu)?.0, along.len()),
        columns_of(&dense_grid(grid, &along, bv, Backend::Cpu)?.0, bv.len()),
    ]
    .concat();
    let (mu, mv) = l.net_shape();
    let net = grid.net();
    let mut everything: Vec<DVec3> = mesh.positions.clone();
    everything.extend_from_slice(net);
    let size = everything
        .iter()
        .fold((DVec3::splat(f64::MAX), DVec3::splat(f64::MIN)), |(lo, hi), p| {
            (lo.min(*p), hi.max(*p))
        });
    let tol = 2e-3 * (size.1 - size.0).max_element();
    let mut canvas = Canvas::new(w, h);
    let panel_h = h as f64 / opts.views.len() as f64;
    for (k, view) in opts.views.iter().enumerate() {
        let cam = Camera::new(view, &everything, (0.0, k as f64 * panel_h, w as f64, panel_h))?;
        // Light from above left of the camera, so curvature shows as a gradient; a soft
        // highlight (Blinn-Phong) for the sheen of a smooth surface. Both sides are lit alike.
        let light = (cam.eye * 0.6 + cam.up * 1.0 - cam.right * 0.35).normalize();
        let half = (light + cam.eye).normalize();
        let shade: Vec<[f32; 2]> = mesh
            .normals
            .iter()
            .map(|n| {
                let n = if n.dot(cam.eye) < 0.0 { -*n } else { *n };
                let diffuse = 0.3 + 0.72 * n.dot(light).max(0.0);
                let specular = 0.45 * n.dot(half).max(0.0).powi(40);
                [diffuse as f32, specular as f32]
            })
            .collect();
        let screen: Vec<(f64, f64, f64)> = mesh.positions.iter().map(|p| cam.project(*p)).collect();
        for t in &mesh.triangles {
            let [a, b, c] = t.map(|i| i as usize);
            fill_triangle(
                &mut canvas,
                [screen[a], screen[b], screen[c]],
                [shade[a], shade[b], shade[c]],
            );
        }
        // Patch borders (and the surface's edges) as curves on the surface.
        for curve in &borders {
            let curve: Vec<_> = curve.iter().map(|p| cam.project(*p)).collect();
            for w in curve.windows(2) {
                draw_line(&mut canvas, w[0], w[1], ss as f64 * 0.7, tol, BORDER, 0.85, 0.0);
            }
        }
        // Data points: small dots, faint where the surface hides them.
        for p in &opts.cloud {
            let (x, y, z) = cam.project(*p);
            if !(x.is_finite() && y.is_finite()) {
                continue;
            }
            let r = 0.9 * ss as f64;
            let ri = r.ceil() as i64;
            let (cx, cy) = (x.round() as i64, y.round() as i64);
            for dy in -ri..=ri {
                for dx in -ri..=ri {
                    if ((dx * dx + dy * dy) as f64).sqrt() <= r {
                        let a = canvas.overlay_alpha(cx + dx, cy + dy, z, tol);
                        canvas.blend(cx + dx, cy + dy, DATA_POINT, 0.8 * a);
                    }
                }
            }
        }
        // Control net: lines, then generated points, then design points on top.
        let at = |r: usize, c: usize| cam.project(net[r * mv + c]);
        let thick = ss as f64 * 0.6;
        for r in 0..mu {
            for c in 0..mv {
                if c + 1 < mv {
                    draw_line(&mut canvas, at(r, c), at(r, c + 1), thick, tol, NET, 0.75, 0.2);
                }
                if r + 1 < mu {
                    draw_line(&mut canvas, at(r, c), at(r + 1, c), thick, tol, NET, 0.75, 0.2);
                }
            }
        }
        for design in [false, true] {
            for r in 0..mu {
                for c in 0..mv {
                    let is_design = l.u.map().is_copy(r) && l.v.map().is_copy(c);
                    if is_design != design {
                        continue;
                    }
                    let (colour, radius) = if design {
                        (DESIGN_POINT, 3.0 * ss as f64)
                    } else {
                        (GENERATED_POINT, 2.8 * ss as f64)
                    };
                    draw_disc(&mut canvas, at(r, c), radius, colour, tol);
                }
            }
        }
        // A thin rule between panels.
        if k > 0 {
            let y = (k as f64 * panel_h) as i64;
            for x in 0..w as i64 {
                canvas.blend(x, y, [200, 200, 200], 1.0);
            }
        }
    }
    // Box-filter down to the requested size.
    let (ow, oh) = (opts.width as usize, opts.height as usize);
    let mut rgb = Vec::with_capacity(3 * ow * oh);
    for y in 0..oh {
        for x in 0..ow {
            let mut acc = [0.0f32; 3];
            for sy in 0..ss {
                for sx in 0..ss {
                    let p = canvas.rgb[(y * ss + sy) * w + x * ss + sx];
                    for (a, v) in acc.iter_mut().zip(p) {
                        *a += v;
                    }
                }
            }
            let n = (ss * ss) as f32;
            rgb.extend(acc.map(|a| (a / n).round().clamp(0.0, 255.0) as u8));
        }
    }
    Ok(Image {
        width: opts.width,
        height: opts.height,
        rgb,
    })
}

/// The views of [`render`] as an SVG drawing (no supersampling, no hidden-line removal):
/// iso-parameter curves of the surface (eight per patch side, the patch borders darker), the
/// control net, generated and design points, and up to 3,000 of `opts.cloud` as dots.
pub fn render_svg(grid: &PatchGrid<DVec3>, opts: &RenderOptions) -> Result<String> {
    use std::fmt::Write as _;
    if opts.width < 16 || opts.height < 16 || opts.width > 16384 || opts.height > 16384 {
        return Err(Error::invalid(format!(
            "picture size {} x {} is outside 16 to 16384 pixels each way",
            opts.width, opts.height
        )));
    }
    if opts.views.is_empty() {
        return Err(Error::invalid("a picture needs at least one view"));
    }
    let (w, h) = (f64::from(opts.width), f64::from(opts.height));
    let l = grid.layout();
    let (mu, mv) = l.net_shape();
    let net = grid.net();
    let (bu, bv) = (l.u.breaks(), l.v.breaks());
    // Iso-curves: eight per patch side, each sampled at 24 points per patch it crosses.
    let iso = |b: &[f64]| -> Vec<(f64, bool)> {
        let mut out = Vec::new();
        for k in 0..b.len() - 1 {
            for i in 0..8 {
                out.push((b[k] + (b[k + 1] - b[k]) * f64::from(i) / 8.0, i == 0));
            }
        }
        out.push((1.0, true));
        out
    };
    let (iso_u, iso_v) = (iso(bu), iso(bv));
    let ts = |b: &[(f64, bool)]| b.iter().map(|&(t, _)| t).collect::<Vec<f64>>();
    let (along_v, along_u) = (uniform(24 * l.v.segments() + 1), uniform(24 * l.u.segments() + 1));
    let u_curves = rows_of(
        &dense_grid(grid, &ts(&iso_u), &along_v, Backend::Cpu)?.0,
        along_v.len(),
    );
    let v_curves = columns_of(
        &dense_grid(grid, &along_u, &ts(&iso_v), Backend::Cpu)?.0,
        iso_v.len(),
    );
    let mut curves: Vec<(Vec<DVec3>, bool)> = Vec::new();
    for (curve, &(_, border)) in u_curves.into_iter().zip(&iso_u) {
        curves.push((curve, border));
    }
    for (curve, &(_, border)) in v_curves.into_iter().zip(&iso_v) {
        curves.push((curve, border));
    }
    let mut everything: Vec<DVec3> = curves.iter().flat_map(|c| c.0.iter().copied()).collect();
    everything.extend_from_slice(net);
    let step = opts.cloud.len().div_ceil(3000).max(1);
    let mut svg = String::new();
    let _ = writeln!(
        svg,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" viewBox="0 0 {w} {h}">"#
    );
    let _ = writeln!(svg, r#"<rect width="{w}" height="{h}" fill="white"/>"#);
    let hex = |c: Rgb| format!("#{:02x}{:02x}{:02x}", c[0], c[1], c[2]);
    let panel_h = h / opts.views.len() as f64;
    for (k, view) in opts.views.iter().enumerate() {
        let cam = Camera::new(view, &everything, (0.0, k as f64 * panel_h, w, panel_h))?;
        let xy = |p: DVec3| {
            let (x, y, _) = cam.project(p);
            format!("{x:.1},{y:.1}")
        };
        let _ = writeln!(svg, r#"<g fill="none" stroke-linejoin="round">"#);
        for (pts, border) in &curves {
            let (colour, width, opacity) = if *border {
                (BORDER, 1.3, 0.9)
            } else {
                (SURFACE, 0.8, 0.9)
            };
            let path: Vec<String> = pts.iter().map(|&p| xy(p)).collect();
            let _ = writeln!(
                svg,
                r#"<polyline points="{}" stroke="{}" stroke-width="{width}" stroke-opacity="{opacity}"/>"#,
                path.join(" "),
                hex(colour)
            );
        }
        for r in 0..mu {
            let row: Vec<String> = (0..mv).map(|c| xy(net[r * mv + c])).collect();
            let _ = writeln!(
                svg,
                r#"<polyline points="{}" stroke="{}" stroke-width="0.9" stroke-opacity="0.75"/>"#,
                row.join(" "),
                hex(NET)
            );
        }
        for c in 0..mv {
            let col: Vec<String> = (0..mu).map(|r| xy(net[r * mv + c])).collect();
            let _ = writeln!(
                svg,
                r#"<polyline points="{}" stroke="{}" stroke-width="0.9" stroke-opacity="0.75"/>"#,
                col.join(" "),
                hex(NET)
            );
        }
        let _ = writeln!(svg, "</g>");
        let _ = writeln!(svg, r#"<g fill="{}" fill-opacity="0.6">"#, hex(DATA_POINT));
        for p in opts.cloud.iter().step_by(step) {
            let (x, y, _) = cam.project(*p);
            if x.is_finite() && y.is_finite() {
                let _ = writeln!(svg, r#"<circle cx="{x:.1}" cy="{y:.1}" r="0.8"/>"#);
            }
        }
        let _ = writeln!(svg, "</g>");
        for design in [false, true] {
            let (colour, radius) = if design {
                (DESIGN_POINT, 3.0)
            } else {
                (GENERATED_POINT, 2.8)
            };
            let _ = writeln!(
                svg,
                r#"<g fill="{}" stroke="white" stroke-width="0.8">"#,
                hex(colour)
            );
            for r in 0..mu {
                for c in 0..mv {
                    if (l.u.map().is_copy(r) && l.v.map().is_copy(c)) == design {
                        let (x, y, _) = cam.project(net[r * mv + c]);
                        let _ = writeln!(svg, r#"<circle cx="{x:.1}" cy="{y:.1}" r="{radius}"/>"#);
                    }
                }
            }
            let _ = writeln!(svg, "</g>");
        }
        if k > 0 {
            let y = k as f64 * panel_h;
            let _ = writeln!(
                svg,
                r##"<line x1="0" y1="{y}" x2="{w}" y2="{y}" stroke="#c8c8c8"/>"##
            );
        }
    }
    svg.push_str("</svg>\n");
    Ok(svg)
}

/// Fill a triangle with per-vertex shading (diffuse factor, white highlight), keeping the
/// nearest surface per pixel.
fn fill_triangle(canvas: &mut Canvas, v: [(f64, f64, f64); 3], shade: [[f32; 2]; 3]) {
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
                canvas.rgb[k] = SURFACE.map(|c| (f32::from(c) * d + 255.0 * h).min(255.0));
            }
        }
    }
}

/// A line of half-width `thick` and colour `colour`: opacity `front` where in front of the
/// surface, `behind` behind it.
#[allow(clippy::too_many_arguments)]
fn draw_line(
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
fn draw_disc(canvas: &mut Canvas, p: (f64, f64, f64), radius: f64, colour: Rgb, tol: f64) {
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
            let alpha = canvas.overlay_alpha(cx + dx, cy + dy, p.2, tol);
            let c = if d > radius { BACKGROUND } else { colour };
            canvas.blend(cx + dx, cy + dy, c, alpha);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::chain::{ChainLayout, Continuity, GridLayout};

    #[test]
    fn a_saddle_is_drawn_where_it_projects() {
        let layout = GridLayout::new(
            ChainLayout::uniform(3, 2, Continuity::C1).unwrap(),
            ChainLayout::uniform(3, 2, Continuity::C1).unwrap(),
        );
        let (nu, nv) = layout.design_shape();
        let design = (0..nu * nv)
            .map(|i| {
                let (a, b) = (
                    (i / nv) as f64 / (nu - 1) as f64 - 0.5,
                    (i % nv) as f64 / (nv - 1) as f64 - 0.5,
                );
                DVec3::new(a, b, 0.3 * a * b)
            })
            .collect();
        let grid = PatchGrid::new(layout, design).unwrap();
        let opts = RenderOptions {
            width: 200,
            height: 120,
            views: vec![View {
                eye: DVec3::Z,
                right: DVec3::X,
            }],
            ..RenderOptions::default()
        };
        let img = render(&grid, &opts).unwrap();
        assert_eq!((img.width, img.height, img.rgb.len()), (200, 120, 200 * 120 * 3));
        // Seen from above the unit square fills the middle of the panel: surface there,
        // background in the corners and at the sides beyond the square.
        assert_eq!(img.pixel(0, 0), BACKGROUND);
        assert_eq!(img.pixel(10, 60), BACKGROUND);
        let centre = img.pixel(100, 60);
        assert_ne!(centre, BACKGROUND);
        let reddish = |c: Rgb| c[0] > 150 && c[1] < 110 && c[2] < 110;
        let bluish = |c: Rgb| c[2] > 170 && c[0] < 90;
        let pixels: Vec<Rgb> = (0..120)
            .flat_map(|y| (0..200).map(move |x| (x, y)))
            .map(|(x, y)| img.pixel(x, y))
            .collect();
        assert!(pixels.iter().any(|&c| reddish(c)), "design points drawn");
        assert!(pixels.iter().any(|&c| bluish(c)), "generated points drawn");
        // The SVG: one disc per net point in its colour, one polyline per net row and
        // column and per iso-curve (8 per patch side plus the far edge, both ways).
        let svg = render_svg(&grid, &opts).unwrap();
        assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
        let (mu, mv) = grid.layout().net_shape();
        let (nu, nv) = grid.layout().design_shape();
        let group = |colour: Rgb| {
            let head = format!(
                r##"<g fill="#{:02x}{:02x}{:02x}" stroke="white""##,
                colour[0], colour[1], colour[2]
            );
            let start = svg.find(&head).expect("point group");
            let end = start + svg[start..].find("</g>").unwrap();
            svg[start..end].matches("<circle").count()
        };
        assert_eq!(group(DESIGN_POINT), nu * nv);
        assert_eq!(group(GENERATED_POINT), mu * mv - nu * nv);
        assert_eq!(svg.matches("<polyline").count(), mu + mv + 2 * (8 * 2 + 1));
        let png = img.to_png().unwrap();
        assert_eq!(&png[1..4], b"PNG");
        assert!(render(&grid, &RenderOptions { width: 4, ..opts }).is_err());
    }
}
