//! A PNG picture of a fitted patch grid with its control net (like the paper's Figs. 12–14):
//! a CPU rasteriser with a z-buffer, the surface shaded, the net drawn as lines, design points
//! and generated points as dots of two colours, one panel per view. Given the data's offsets,
//! the surface is coloured by the local offset (the largest offset of the data points whose
//! closest points fall near each place), with a labelled colour bar.

use super::mesh::SurfaceMesh;
use crate::chain::PatchGrid;
use crate::error::{Error, Result};
use crate::eval::dense::{dense_grid, uniform, DensePoint};
use crate::eval::Backend;
use crate::fit::SurfaceFit;
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
    /// The closest-point parameters `(u, v)` on the surface of the data points and their
    /// offsets (model units). When given, the surface is coloured by the local offset (see
    /// [`local_offsets`]) from 0 to the largest, with a colour bar on the right. Default none.
    pub offsets: Vec<([f64; 2], f64)>,
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
            offsets: Vec::new(),
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

/// The colour of `t ∈ [0, 1]` on a sequential map that stays light where the offsets are
/// small (so the shading reads) and turns dark red where they are largest (ColorBrewer's
/// YlOrRd, by linear interpolation between its 9 classes): pale yellow for 0, dark red for 1.
#[must_use]
pub fn offset_colour(t: f64) -> Rgb {
    const STOPS: [[f32; 3]; 9] = [
        [255.0, 255.0, 204.0],
        [255.0, 237.0, 160.0],
        [254.0, 217.0, 118.0],
        [254.0, 178.0, 76.0],
        [253.0, 141.0, 60.0],
        [252.0, 78.0, 42.0],
        [227.0, 26.0, 28.0],
        [189.0, 0.0, 38.0],
        [128.0, 0.0, 38.0],
    ];
    let t = if t.is_finite() { t.clamp(0.0, 1.0) } else { 0.0 };
    let x = t * (STOPS.len() - 1) as f64;
    let k = (x.floor() as usize).min(STOPS.len() - 2);
    let f = (x - k as f64) as f32;
    let (a, b) = (STOPS[k], STOPS[k + 1]);
    [0, 1, 2].map(|c| (a[c] + (b[c] - a[c]) * f).round() as u8)
}

/// The local offset at every vertex of `mesh`: the largest offset of the data points whose
/// closest points fall in one of the mesh cells around the vertex; vertices with no such data
/// take the value of the nearest vertex that has (by grid steps). `None` without data.
#[must_use]
pub fn local_offsets(mesh: &SurfaceMesh, offsets: &[([f64; 2], f64)]) -> Option<Vec<f64>> {
    let (rows, cols) = (mesh.rows, mesh.cols);
    if offsets.is_empty() || rows < 2 || cols < 2 {
        return None;
    }
    let us: Vec<f64> = (0..rows).map(|i| mesh.params[i * cols][0]).collect();
    let vs: Vec<f64> = (0..cols).map(|j| mesh.params[j][1]).collect();
    let cell = |xs: &[f64], x: f64| xs.partition_point(|&k| k <= x).clamp(1, xs.len() - 1) - 1;
    let mut value = vec![f64::NAN; rows * cols];
    for &([u, v], e) in offsets {
        if !(u.is_finite() && v.is_finite() && e.is_finite()) {
            continue;
        }
        let (i, j) = (cell(&us, u), cell(&vs, v));
        for (a, b) in [(i, j), (i + 1, j), (i, j + 1), (i + 1, j + 1)] {
            let slot = &mut value[a * cols + b];
            if slot.is_nan() || *slot < e {
                *slot = e;
            }
        }
    }
    // Fill the vertices without data from their nearest neighbours, ring by ring.
    let mut frontier: Vec<usize> = (0..rows * cols).filter(|&k| value[k].is_finite()).collect();
    if frontier.is_empty() {
        return None;
    }
    while !frontier.is_empty() {
        let mut next = Vec::new();
        for &k in &frontier {
            let (i, j) = (k / cols, k % cols);
            let around = [
                (i > 0).then(|| k - cols),
                (i + 1 < rows).then(|| k + cols),
                (j > 0).then(|| k - 1),
                (j + 1 < cols).then(|| k + 1),
            ];
            for n in around.into_iter().flatten() {
                if value[n].is_nan() {
                    value[n] = value[k];
                    next.push(n);
                }
            }
        }
        frontier = next;
    }
    Some(value)
}

/// 5 x 7 pixel glyphs (one row a byte, the low 5 bits, most significant bit leftmost) for the
/// colour bar's labels.
fn glyph(c: char) -> Option<[u8; 7]> {
    Some(match c {
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
        '-' => [0x00, 0x00, 0x00, 0x1f, 0x00, 0x00, 0x00],
        '+' => [0x00, 0x04, 0x04, 0x1f, 0x04, 0x04, 0x00],
        'e' => [0x00, 0x00, 0x0e, 0x11, 0x1f, 0x10, 0x0e],
        'o' => [0x00, 0x00, 0x0e, 0x11, 0x11, 0x11, 0x0e],
        'f' => [0x06, 0x09, 0x08, 0x1c, 0x08, 0x08, 0x08],
        's' => [0x00, 0x00, 0x0f, 0x10, 0x0e, 0x01, 0x1e],
        't' => [0x08, 0x08, 0x1c, 0x08, 0x08, 0x09, 0x06],
        'm' => [0x00, 0x00, 0x1a, 0x15, 0x15, 0x11, 0x11],
        'a' => [0x00, 0x00, 0x0e, 0x01, 0x0f, 0x11, 0x0f],
        'x' => [0x00, 0x00, 0x11, 0x0a, 0x04, 0x0a, 0x11],
        ' ' => [0; 7],
        _ => return None,
    })
}

/// Draw `text` with its top-left corner at `(x, y)`, each font pixel `scale` canvas pixels.
fn draw_text(canvas: &mut Canvas, x: i64, y: i64, text: &str, scale: i64, colour: Rgb) {
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

/// A label for an offset: three significant digits, exponent form (`1.23e-3`).
fn offset_label(x: f64) -> String {
    if x == 0.0 {
        return "0".into();
    }
    let s = format!("{x:.2e}");
    s.replace("e-0", "e-").replace("e0", "e")
}

/// The colour bar: a vertical strip from `lo` (bottom) to `hi` (top) of offset 0 to `max`,
/// ticks and labels at 0, 1/4, ..., 1 of `max`, and the title `offset` above.
fn draw_colour_bar(canvas: &mut Canvas, x: i64, top: i64, bottom: i64, width: i64, max: f64, scale: i64) {
    let height = (bottom - top).max(1);
    for y in top..=bottom {
        let c = offset_colour((bottom - y) as f64 / height as f64);
        for dx in 0..width {
            canvas.blend(x + dx, y, c, 1.0);
        }
    }
    for q in 0..=4 {
        let y = bottom - height * q / 4;
        for dx in 0..(width / 3).max(2) {
            canvas.blend(x + width + dx, y, NET, 1.0);
        }
        let label = offset_label(max * q as f64 / 4.0);
        draw_text(canvas, x + width + width / 2, y - 3 * scale, &label, scale, NET);
    }
    draw_text(canvas, x, top - 12 * scale, "offset", scale, NET);
}

impl RenderOptions {
    /// The picture of a grid fitted to `points`, `width` × `height` pixels: the data as dots
    /// (every point of a cloud up to 20,000, an even sample of a larger one), the surface
    /// coloured by the offsets of the fit's points. The default views look at a blade along
    /// +z, its thickness along y; they turn with the fit's span axis, and to x when the cloud
    /// is thinnest along x (a windIO or AeroDyn blade in its blade-root axes).
    #[must_use]
    pub fn of_fit(fit: &SurfaceFit, points: &[DVec3], width: u32, height: u32) -> RenderOptions {
        RenderOptions::of_surface(&fit.grid, &fit.params, fit.axis.dir, points, width, height)
    }

    /// [`of_fit`](Self::of_fit) for any `grid` fitted to `points`, their closest-point
    /// parameters `params` on it and the span direction `span`.
    #[must_use]
    pub fn of_surface(
        grid: &PatchGrid<DVec3>,
        params: &[[f64; 2]],
        span: DVec3,
        points: &[DVec3],
        width: u32,
        height: u32,
    ) -> RenderOptions {
        let mut o = RenderOptions {
            width,
            height,
            ..RenderOptions::default()
        };
        let step = points.len().div_ceil(20_000).max(1);
        o.cloud = points.iter().step_by(step).copied().collect();
        o.offsets = params
            .iter()
            .zip(points)
            .map(|(&[u, v], p)| ([u, v], (grid.eval(u, v) - *p).length()))
            .collect();
        let extent = |axis: DVec3| {
            let (lo, hi) = points.iter().fold((f64::MAX, f64::MIN), |(lo, hi), p| {
                (lo.min(p.dot(axis)), hi.max(p.dot(axis)))
            });
            hi - lo
        };
        let thin_x = span.x.abs() < 0.5 && extent(DVec3::X) < extent(DVec3::Y);
        for v in o.views.iter_mut() {
            v.right = span;
            if thin_x {
                v.eye = DVec3::new(v.eye.y, v.eye.x, v.eye.z);
            }
        }
        o
    }

    /// A picture of 16 to 16384 pixels each way with at least one view.
    fn check(&self) -> Result<()> {
        if self.width < 16 || self.height < 16 || self.width > 16384 || self.height > 16384 {
            return Err(Error::invalid(format!(
                "picture size {} x {} is outside 16 to 16384 pixels each way",
                self.width, self.height
            )));
        }
        if self.views.is_empty() {
            return Err(Error::invalid("a picture needs at least one view"));
        }
        Ok(())
    }
}

/// Draw `grid` (with its control net) in every view of `opts`.
pub fn render(grid: &PatchGrid<DVec3>, opts: &RenderOptions) -> Result<Image> {
    opts.check()?;
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
    // The surface's base colour per vertex: by the local offset when given.
    let local = local_offsets(&mesh, &opts.offsets);
    let largest = local
        .as_ref()
        .map_or(0.0, |l| l.iter().fold(0.0, |m: f64, &e| m.max(e)));
    let base: Vec<[f32; 3]> = match &local {
        Some(l) => l
            .iter()
            .map(|&e| offset_colour(if largest > 0.0 { e / largest } else { 0.0 }).map(f32::from))
            .collect(),
        None => vec![SURFACE.map(f32::from); mesh.positions.len()],
    };
    // Room for the colour bar on the right.
    let bar_room = if local.is_some() {
        (0.09 * w as f64).max(60.0 * ss as f64)
    } else {
        0.0
    };
    let panel_w = w as f64 - bar_room;
    for (k, view) in opts.views.iter().enumerate() {
        let cam = Camera::new(view, &everything, (0.0, k as f64 * panel_h, panel_w, panel_h))?;
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
                [base[a], base[b], base[c]],
            );
        }
        // Patch borders (and the surface's edges) as curves on the surface; fainter over a
        // surface coloured by offsets.
        let border_alpha = if local.is_some() { 0.35 } else { 0.85 };
        for curve in &borders {
            let curve: Vec<_> = curve.iter().map(|p| cam.project(*p)).collect();
            for w in curve.windows(2) {
                draw_line(
                    &mut canvas,
                    w[0],
                    w[1],
                    ss as f64 * 0.7,
                    tol,
                    BORDER,
                    border_alpha,
                    0.0,
                );
            }
        }
        // Data points: small dots, faint where the surface hides them (and over a surface
        // coloured by offsets, whose colours they would hide).
        let dot_alpha = if local.is_some() { 0.15 } else { 0.8 };
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
                        canvas.blend(cx + dx, cy + dy, DATA_POINT, dot_alpha * a);
                    }
                }
            }
        }
        // Control net: lines, then generated points, then design points on top.
        let at = |r: usize, c: usize| cam.project(net[r * mv + c]);
        let thick = ss as f64 * 0.6;
        // Over a surface coloured by offsets the net is drawn fainter, so the colours show.
        let net_alpha = if local.is_some() { 0.3 } else { 0.75 };
        for r in 0..mu {
            for c in 0..mv {
                if c + 1 < mv {
                    draw_line(
                        &mut canvas,
                        at(r, c),
                        at(r, c + 1),
                        thick,
                        tol,
                        NET,
                        net_alpha,
                        0.2 * net_alpha,
                    );
                }
                if r + 1 < mu {
                    draw_line(
                        &mut canvas,
                        at(r, c),
                        at(r + 1, c),
                        thick,
                        tol,
                        NET,
                        net_alpha,
                        0.2 * net_alpha,
                    );
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
    if local.is_some() {
        let scale = ((h as f64 / 450.0).round() as i64).max(ss as i64);
        let bar_w = (bar_room * 0.12).max(6.0) as i64;
        let x = (panel_w + bar_room * 0.05) as i64;
        draw_colour_bar(
            &mut canvas,
            x,
            (0.12 * h as f64) as i64,
            (0.9 * h as f64) as i64,
            bar_w,
            largest,
            scale,
        );
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
    opts.check()?;
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
        // The control net: its rows, then its columns.
        let rows = (0..mu).map(|r| (0..mv).map(|c| r * mv + c).collect::<Vec<_>>());
        let cols = (0..mv).map(|c| (0..mu).map(|r| r * mv + c).collect::<Vec<_>>());
        for line in rows.chain(cols) {
            let path: Vec<String> = line.iter().map(|&k| xy(net[k])).collect();
            let _ = writeln!(
                svg,
                r#"<polyline points="{}" stroke="{}" stroke-width="0.9" stroke-opacity="0.75"/>"#,
                path.join(" "),
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

/// Fill a triangle with per-vertex base colours and shading (diffuse factor, white highlight),
/// keeping the nearest surface per pixel.
fn fill_triangle(canvas: &mut Canvas, v: [(f64, f64, f64); 3], shade: [[f32; 2]; 3], base: [[f32; 3]; 3]) {
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
    use crate::chain::{Continuity, GridLayout};

    #[test]
    fn a_saddle_is_drawn_where_it_projects() {
        let layout = GridLayout::uniform((3, 3), (2, 2), Continuity::C1).unwrap();
        let design = layout.design_from(|a, b| {
            let (a, b) = (a - 0.5, b - 0.5);
            DVec3::new(a, b, 0.3 * a * b)
        });
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

    #[test]
    fn the_surface_is_coloured_by_the_local_offset_with_a_bar() {
        let layout = GridLayout::uniform((1, 1), (1, 1), Continuity::C0).unwrap();
        // The unit square in z = 0, seen from above: u along x, v along y.
        let design = vec![DVec3::ZERO, DVec3::Y, DVec3::X, DVec3::new(1.0, 1.0, 0.0)];
        let grid = PatchGrid::new(layout, design).unwrap();
        // Offsets: large near (u, v) = (1, 1), small elsewhere.
        let offsets: Vec<([f64; 2], f64)> = (0..=20)
            .flat_map(|i| (0..=20).map(move |j| (i as f64 / 20.0, j as f64 / 20.0)))
            .map(|(u, v)| ([u, v], if u > 0.8 && v > 0.8 { 1e-2 } else { 1e-4 }))
            .collect();
        let mesh = SurfaceMesh::from_grid(&grid, 16).unwrap();
        let local = local_offsets(&mesh, &offsets).unwrap();
        assert_eq!(local.len(), mesh.positions.len());
        let at = |u: f64, v: f64| {
            let k = mesh
                .params
                .iter()
                .position(|p| (p[0] - u).abs() < 1e-12 && (p[1] - v).abs() < 1e-12)
                .unwrap();
            local[k]
        };
        assert_eq!(at(1.0, 1.0), 1e-2);
        assert_eq!(at(0.0, 0.0), 1e-4);
        // A vertex with no data of its own takes its nearest neighbour's value.
        let sparse = [([0.95, 0.95], 5e-3)];
        assert!(local_offsets(&mesh, &sparse).unwrap().iter().all(|&e| e == 5e-3));
        let opts = RenderOptions {
            width: 400,
            height: 200,
            views: vec![View {
                eye: DVec3::Z,
                right: DVec3::X,
            }],
            supersample: 1,
            offsets,
            ..RenderOptions::default()
        };
        let img = render(&grid, &opts).unwrap();
        let (worst, best) = (offset_colour(1.0), offset_colour(0.0));
        let near = |c: Rgb, want: Rgb, tol: i32| {
            c.iter()
                .zip(want)
                .all(|(a, b)| (i32::from(*a) - i32::from(b)).abs() <= tol)
        };
        let pixels: Vec<(u32, u32, Rgb)> = (0..200)
            .flat_map(|y| (0..400).map(move |x| (x, y)))
            .map(|(x, y)| (x, y, img.pixel(x, y)))
            .collect();
        // The large offsets are drawn red (shaded) where x and y are large (image y grows
        // downwards), the small ones pale yellow; the bar is right of the surface.
        let is_red = |c: Rgb| c[0] > 90 && c[1] < 40 && c[2] < 60;
        let is_pale = |c: Rgb| c[0] > 150 && c[1] > 150 && c[2] > 100;
        let surface_red: Vec<_> = pixels.iter().filter(|p| p.0 < 330 && is_red(p.2)).collect();
        assert!(!surface_red.is_empty(), "the worst corner is red");
        assert!(
            surface_red.iter().all(|p| p.1 < 100),
            "and it is the upper corner"
        );
        assert!(
            pixels.iter().any(|p| p.0 < 330 && is_pale(p.2)),
            "the rest is pale"
        );
        assert!(
            pixels.iter().any(|p| p.0 > 330 && near(p.2, worst, 2)),
            "the bar's top"
        );
        assert!(
            pixels.iter().any(|p| p.0 > 330 && near(p.2, best, 2)),
            "the bar's bottom"
        );
        assert_eq!(offset_label(1.234e-3), "1.23e-3");
        assert_eq!(offset_label(0.0), "0");
    }
}
