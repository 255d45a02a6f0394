//! A PNG picture of a fitted patch grid with its control net (like the paper's Figs. 12–14):
//! a CPU rasteriser with a z-buffer, the surface shaded, the net drawn as lines, design points
//! and generated points as dots of two colours, one panel per view. Given the data's offsets,
//! the surface is coloured by the local offset (the largest offset of the data points whose
//! closest points fall near each place), relative to the local chord when the cloud has
//! sections ([`super::offset_map`] says what and why), with a colour bar of two scales, the
//! worst points ringed, the stations drawn across the surface and a caption.

mod marks;
mod svg;
use marks::{draw_ring, marks, place_label, ring_boxes};

use super::mesh::SurfaceMesh;
pub use super::offset_map::{offset_colour, OffsetPoint, Remark, Rgb, Station};
use super::offset_map::{offset_label, stations, Colouring, Marked};
use super::raster::{draw_boxed_text, draw_disc, draw_line, draw_text, fill_triangle, Canvas};
pub use super::raster::{Image, BACKGROUND, NET};
use crate::chain::{GridLayout, PatchGrid};
use crate::closest::{grid_feet, FootOptions};
use crate::error::{Error, Result};
use crate::eval::dense::{dense_grid, uniform, DensePoint};
use crate::eval::Backend;
use crate::fit::SurfaceFit;
use crate::geometry::Grid;
use crate::problem::section_params;
use glam::DVec3;
pub use svg::render_svg;

/// The surface's base colour (shaded by the light).
pub const SURFACE: Rgb = [150, 178, 214];
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
    /// The data points with their closest-point parameters on the surface and offsets. When
    /// given, the surface is coloured by the local offset (see [`local_offsets`]; relative to
    /// the local chord when every point has a station, see `export::offset_map`) from 0 to the
    /// largest, with a colour bar on the right, the worst points ringed and a caption below.
    /// Default none.
    pub offsets: Vec<OffsetPoint>,
    /// The data's sections (stations), which [`OffsetPoint::section`] indexes: drawn as lines
    /// across the surface and numbered under it. Default none.
    pub stations: Vec<Station>,
    /// Points ringed with a dotted ring and labelled, when the picture is coloured by offsets
    /// (a section's end that doubles back). Default none.
    pub remarks: Vec<Remark>,
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
            stations: Vec::new(),
            remarks: Vec::new(),
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

/// The colour bar: a vertical strip from `top` to `bottom` of the colouring's 0 (bottom) to its
/// largest value (top), ticks at 0, 1/4, ..., 1 with the data-unit labels on the right and,
/// for a relative colouring, the % of local chord on the left; the title and the two scales'
/// names above it. `x` is the left edge of the bar's room.
fn draw_colour_bar(canvas: &mut Canvas, x: i64, top: i64, bottom: i64, colouring: &Colouring, scale: i64) {
    let width = 8 * scale;
    let left_room = if colouring.relative { 44 * scale } else { 0 };
    let bx = x + left_room;
    let height = (bottom - top).max(1);
    for y in top..=bottom {
        let c = offset_colour((bottom - y) as f64 / height as f64);
        for dx in 0..width {
            canvas.blend(bx + dx, y, c, 1.0);
        }
    }
    for (q, (left, right)) in colouring.ticks().into_iter().enumerate() {
        let y = bottom - height * q as i64 / 4;
        for dx in 0..2 * scale {
            canvas.blend(bx + width + dx, y, NET, 1.0);
            if left.is_some() {
                canvas.blend(bx - 1 - dx, y, NET, 1.0);
            }
        }
        draw_text(canvas, bx + width + 3 * scale, y - 3 * scale, &right, scale, NET);
        if let Some(l) = left {
            let lw = l.chars().count() as i64 * 6 * scale;
            draw_text(canvas, bx - 3 * scale - lw, y - 3 * scale, &l, scale, NET);
        }
    }
    draw_text(canvas, x, top - 22 * scale, colouring.title(), scale, NET);
    if colouring.relative {
        draw_text(canvas, x, top - 11 * scale, "% chord", scale, NET);
        draw_text(
            canvas,
            bx + width + 3 * scale,
            top - 11 * scale,
            "at max c",
            scale,
            NET,
        );
        let c = format!("max chord {}", offset_label(colouring.reference));
        draw_text(canvas, x, bottom + 6 * scale, &c, scale, NET);
    }
}

/// Where a station is numbered under a panel: the screen x of every station's centroid, and
/// the ones to label (no two labels closer than `gap`; the first and the last always).
fn station_ticks(xs: &[f64], gap: f64) -> Vec<bool> {
    let mut order: Vec<usize> = (0..xs.len()).filter(|&k| xs[k].is_finite()).collect();
    order.sort_by(|&a, &b| xs[a].total_cmp(&xs[b]));
    let mut shown = vec![false; xs.len()];
    let mut last: Option<usize> = None;
    for &k in &order {
        if last.is_none_or(|p| xs[k] - xs[p] >= gap) {
            shown[k] = true;
            last = Some(k);
        }
    }
    if let (Some(&end), Some(prev)) = (order.last(), last) {
        if prev != end {
            shown[end] = true;
            if xs[end] - xs[prev] < gap && order.first() != Some(&prev) {
                shown[prev] = false;
            }
        }
    }
    shown
}

/// True when the surface (its projected triangles) lies in front of `p` by more than `tol`.
fn hidden_by(screen: &[(f64, f64, f64)], triangles: &[[u32; 3]], p: (f64, f64, f64), tol: f64) -> bool {
    triangles.iter().any(|t| {
        let [a, b, c] = t.map(|i| screen[i as usize]);
        let area = (b.0 - a.0) * (c.1 - a.1) - (c.0 - a.0) * (b.1 - a.1);
        if area.abs() <= 1e-12 || !area.is_finite() {
            return false;
        }
        let w0 = ((b.0 - p.0) * (c.1 - p.1) - (c.0 - p.0) * (b.1 - p.1)) / area;
        let w1 = ((c.0 - p.0) * (a.1 - p.1) - (a.0 - p.0) * (c.1 - p.1)) / area;
        let w2 = 1.0 - w0 - w1;
        w0 >= 0.0 && w1 >= 0.0 && w2 >= 0.0 && w0 * a.2 + w1 * b.2 + w2 * c.2 > p.2 + tol
    })
}

/// The offsets as the colouring's values at their parameters, for [`local_offsets`].
fn value_points(opts: &RenderOptions, c: &Colouring) -> Vec<([f64; 2], f64)> {
    opts.offsets
        .iter()
        .zip(&c.values)
        .map(|(p, &v)| (p.uv, v))
        .collect()
}

/// The screen x of a station (its centroid's), for its number under the panel.
fn station_x(cam: &Camera, st: &Station) -> f64 {
    let n = st.points.len().max(1) as f64;
    cam.project(st.points.iter().copied().sum::<DVec3>() / n).0
}

/// Per mesh vertex, the diffuse factor and the highlight in `cam`'s light: from above left of
/// the camera, so curvature shows as a gradient, with a soft highlight (Blinn-Phong) for the
/// sheen of a smooth surface; both sides lit alike. Over a surface coloured by offsets the
/// light is softer, so that the colour, not the shading, sets the lightness a grey print shows.
fn shading(mesh: &SurfaceMesh, cam: &Camera, coloured: bool) -> Vec<[f32; 2]> {
    let light = (cam.eye * 0.6 + cam.up * 1.0 - cam.right * 0.35).normalize();
    let half = (light + cam.eye).normalize();
    let (ambient, diffuse, sheen) = if coloured {
        (0.72, 0.32, 0.12)
    } else {
        (0.3, 0.72, 0.45)
    };
    mesh.normals
        .iter()
        .map(|n| {
            let n = if n.dot(cam.eye) < 0.0 { -*n } else { *n };
            let d = ambient + diffuse * n.dot(light).max(0.0);
            let s = sheen * n.dot(half).max(0.0).powi(40);
            [d as f32, s as f32]
        })
        .collect()
}

/// The text scale of a picture `h` canvas pixels high at supersampling `ss`.
fn text_scale(h: usize, ss: usize) -> i64 {
    ((h as f64 / 450.0).round() as i64).max(ss as i64)
}

/// The picture's layout when coloured, at text scale `scale` (canvas pixels a font pixel):
/// the colour bar's room on the right, the caption's height at the bottom, and the caption's
/// lines, wrapped at words to the picture's width.
fn bar_and_caption(
    colouring: Option<&Colouring>,
    opts: &RenderOptions,
    w: f64,
    scale: f64,
) -> (f64, f64, Vec<String>) {
    let Some(c) = colouring else {
        return (0.0, 0.0, Vec::new());
    };
    let bar = if c.relative { 126.0 } else { 62.0 } * scale;
    let width = ((w / (6.0 * scale)) as usize).saturating_sub(2).max(20);
    let mut lines = Vec::new();
    for text in caption(c, opts) {
        let mut line = String::new();
        for word in text.split(' ') {
            if !line.is_empty() && line.chars().count() + 1 + word.chars().count() > width {
                lines.push(std::mem::take(&mut line));
            }
            if !line.is_empty() {
                line.push(' ');
            }
            line.push_str(word);
        }
        lines.push(line);
    }
    (bar.min(0.4 * w), (lines.len() as f64 * 10.0 + 4.0) * scale, lines)
}

/// The caption's lines of a picture coloured by `c` ([`Colouring::caption`]), with a line for
/// the remarks' rings when there are any.
fn caption(c: &Colouring, opts: &RenderOptions) -> Vec<String> {
    let mut lines = c.caption(!opts.stations.is_empty());
    if !opts.remarks.is_empty() {
        lines.push(
            "dotted ring: where a section's end doubles back on itself (the report's section_ends)".into(),
        );
    }
    lines
}

impl RenderOptions {
    /// The picture of a grid fitted to `points`, `width` × `height` pixels: the data as dots
    /// (every point of a cloud up to 20,000, an even sample of a larger one), the surface
    /// coloured by the offsets of the fit's points. The default views look at a blade along
    /// +z, its thickness along y; they turn with the fit's span axis, and to x when the cloud
    /// is thinnest along x (a windIO or AeroDyn blade in its blade-root axes).
    /// With `sections` (the cloud's grid) the colour is relative to each point's local chord
    /// and the stations are drawn (see `export::offset_map`).
    #[must_use]
    pub fn of_fit(
        fit: &SurfaceFit,
        points: &[DVec3],
        sections: Option<Grid>,
        width: u32,
        height: u32,
    ) -> RenderOptions {
        RenderOptions::of_surface(
            &fit.grid,
            &fit.params,
            fit.axis.dir,
            points,
            sections,
            width,
            height,
        )
    }

    /// [`of_surface`](Self::of_surface) for a `grid` made without [`crate::fit`] (an adapted
    /// surface) and the sectioned cloud `points`: their parameters on it by the exact
    /// closest-point search, the span direction the cloud's sections give.
    pub fn of_sectioned(
        grid: &PatchGrid<DVec3>,
        points: &[DVec3],
        sections: Grid,
        width: u32,
        height: u32,
    ) -> Result<RenderOptions> {
        let params: Vec<[f64; 2]> = grid_feet(grid, points, &FootOptions::default())
            .iter()
            .map(|f| f.t)
            .collect();
        let (_, axis) = section_params(points, sections, None)?;
        Ok(RenderOptions::of_surface(
            grid,
            &params,
            axis.dir,
            points,
            Some(sections),
            width,
            height,
        ))
    }

    /// [`of_fit`](Self::of_fit) for any `grid` fitted to `points`, their closest-point
    /// parameters `params` on it and the span direction `span`.
    #[must_use]
    pub fn of_surface(
        grid: &PatchGrid<DVec3>,
        params: &[[f64; 2]],
        span: DVec3,
        points: &[DVec3],
        sections: Option<Grid>,
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
        // A grid that does not match the points (not section-major) names no sections.
        let sections = sections.filter(|g| g.sections * g.per_section == points.len() && g.per_section > 0);
        o.offsets = params
            .iter()
            .zip(points)
            .enumerate()
            .map(|(k, (&[u, v], p))| OffsetPoint {
                uv: [u, v],
                offset: (grid.eval(u, v) - *p).length(),
                position: *p,
                section: sections.map(|g| k / g.per_section),
            })
            .collect();
        o.stations = sections.map_or_else(Vec::new, |g| stations(points, g));
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

/// The patch borders of `grid` sampled at `along` (rows at the u breaks, columns at the v
/// breaks), every point the views frame (the mesh and the control net), and the depth
/// tolerance of the hidden-line test: 2e-3 of their largest extent.
fn borders_and_frame(
    grid: &PatchGrid<DVec3>,
    mesh: &SurfaceMesh,
    along: &[f64],
) -> Result<(Vec<Vec<DVec3>>, Vec<DVec3>, f64)> {
    let l = grid.layout();
    let (bu, bv) = (l.u.breaks(), l.v.breaks());
    let borders: Vec<Vec<DVec3>> = [
        rows_of(&dense_grid(grid, bu, along, Backend::Cpu)?.0, along.len()),
        columns_of(&dense_grid(grid, along, bv, Backend::Cpu)?.0, bv.len()),
    ]
    .concat();
    let mut everything: Vec<DVec3> = mesh.positions.clone();
    everything.extend_from_slice(grid.net());
    let (lo, hi) = everything
        .iter()
        .fold((DVec3::splat(f64::MAX), DVec3::splat(f64::MIN)), |(lo, hi), p| {
            (lo.min(*p), hi.max(*p))
        });
    Ok((borders, everything, 2e-3 * (hi - lo).max_element()))
}

/// Draw `grid` (with its control net) in every view of `opts`.
pub fn render(grid: &PatchGrid<DVec3>, opts: &RenderOptions) -> Result<Image> {
    opts.check()?;
    let ss = opts.supersample.clamp(1, 4) as usize;
    let (w, h) = (opts.width as usize * ss, opts.height as usize * ss);
    let mesh = SurfaceMesh::from_grid(grid, opts.per_patch.max(1))?;
    let l = grid.layout();
    let along = uniform(401);
    let (borders, everything, tol) = borders_and_frame(grid, &mesh, &along)?;
    let (mu, mv) = l.net_shape();
    let net = grid.net();
    let mut canvas = Canvas::new(w, h);
    // The surface's base colour per vertex: by the local offset when given.
    let colouring = Colouring::new(&opts.offsets, &opts.stations);
    let local = colouring
        .as_ref()
        .and_then(|c| local_offsets(&mesh, &value_points(opts, c)));
    let colouring = colouring.filter(|_| local.is_some());
    let base: Vec<[f32; 3]> = match &local {
        Some(l) => l
            .iter()
            .map(|&e| offset_colour(colouring.as_ref().map_or(0.0, |c| c.position(e))).map(f32::from))
            .collect(),
        None => vec![SURFACE.map(f32::from); mesh.positions.len()],
    };
    // Room for the colour bar on the right and the caption at the bottom.
    let tscale = text_scale(h, ss);
    let (bar_room, caption_h, caption) = bar_and_caption(colouring.as_ref(), opts, w as f64, tscale as f64);
    let panel_w = w as f64 - bar_room;
    let panel_h = (h as f64 - caption_h) / opts.views.len() as f64;
    for (k, view) in opts.views.iter().enumerate() {
        let cam = Camera::new(view, &everything, (0.0, k as f64 * panel_h, panel_w, panel_h))?;
        let shade = shading(&mesh, &cam, local.is_some());
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
        // The stations: every data section as a line across the surface (dark with a light
        // core, so that it shows over light and dark colours alike), numbered under the panel.
        let panel_bottom = (k + 1) as f64 * panel_h;
        for st in &opts.stations {
            let line: Vec<_> = st.points.iter().map(|p| cam.project(*p)).collect();
            for (width, colour, alpha) in [(0.9, [20, 20, 20], 0.55), (0.35, BACKGROUND, 0.8)] {
                for s in line.windows(2) {
                    draw_line(
                        &mut canvas,
                        s[0],
                        s[1],
                        ss as f64 * width,
                        tol,
                        colour,
                        alpha,
                        0.0,
                    );
                }
            }
        }
        let xs: Vec<f64> = opts.stations.iter().map(|st| station_x(&cam, st)).collect();
        let label_w = 6.0 * tscale as f64;
        for (n, shown) in station_ticks(&xs, 4.0 * label_w).into_iter().enumerate() {
            let x = xs[n];
            if !(x.is_finite() && x < panel_w) {
                continue;
            }
            let len = if shown { 3 * tscale } else { 2 * tscale };
            for dy in 0..len {
                canvas.blend(
                    x as i64,
                    (panel_bottom - 12.0 * tscale as f64) as i64 + dy,
                    NET,
                    1.0,
                );
            }
            if shown {
                let text = n.to_string();
                let tx = x - 0.5 * label_w * text.len() as f64;
                draw_text(
                    &mut canvas,
                    tx as i64,
                    (panel_bottom - 8.0 * tscale as f64) as i64,
                    &text,
                    tscale,
                    NET,
                );
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
                    // Over a surface coloured by offsets: smaller and fainter.
                    let (radius, alpha) = if local.is_some() {
                        (0.6 * radius, 0.45)
                    } else {
                        (radius, 1.0)
                    };
                    draw_disc(&mut canvas, at(r, c), radius, colour, tol, alpha);
                }
            }
        }
        // The worst points: rings and labels on top of everything.
        if let Some(c) = &colouring {
            let panel = (0.0, k as f64 * panel_h, panel_w, panel_h);
            let radius = 6.0 * tscale as f64;
            let rings = marks(&c.marked, c.relative, &opts.remarks, radius);
            let mut placed = ring_boxes(&cam, &rings);
            for m in &rings {
                let p = cam.project(m.at);
                let hidden = hidden_by(&screen, &mesh.triangles, p, tol);
                draw_ring(&mut canvas, (p.0, p.1), m.radius, ss as f64, m.ring, hidden);
                let text = m.label(hidden);
                let (x, y) = place_label(p, m.radius, &text, tscale as f64, panel, &mut placed);
                draw_boxed_text(&mut canvas, x as i64, y as i64, &text, tscale);
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
    if let Some(c) = &colouring {
        let bottom = h as f64 - caption_h - 0.06 * h as f64;
        let top = (0.06 * h as f64 + 24.0 * tscale as f64).min(bottom - 20.0);
        draw_colour_bar(
            &mut canvas,
            (panel_w + 2.0 * tscale as f64) as i64,
            top as i64,
            bottom as i64,
            c,
            tscale,
        );
        for (n, line) in caption.iter().enumerate() {
            let y = h as f64 - caption_h + (2 + 10 * n as i64) as f64 * tscale as f64;
            draw_text(&mut canvas, 4 * tscale, y as i64, line, tscale, NET);
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

#[cfg(test)]
mod tests {
    use super::super::offset_map::lightness;
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
        // Offsets: large near (u, v) = (1, 1), small elsewhere; no sections.
        let offsets: Vec<OffsetPoint> = (0..=20)
            .flat_map(|i| (0..=20).map(move |j| (i as f64 / 20.0, j as f64 / 20.0)))
            .map(|(u, v)| OffsetPoint {
                uv: [u, v],
                offset: if u > 0.8 && v > 0.8 { 1e-2 } else { 1e-4 },
                position: DVec3::new(u, v, 0.0),
                section: None,
            })
            .collect();
        let mesh = SurfaceMesh::from_grid(&grid, 16).unwrap();
        let tuples: Vec<([f64; 2], f64)> = offsets.iter().map(|p| (p.uv, p.offset)).collect();
        let local = local_offsets(&mesh, &tuples).unwrap();
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
        if let Ok(dir) = std::env::var("BEZCHAIN_PICTURES") {
            std::fs::write(format!("{dir}/square.png"), img.to_png().unwrap()).unwrap();
        }
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
        // The large offsets are drawn dark purple (shaded) where x and y are large (image y
        // grows downwards), the small ones light yellow; the bar is right of the surface, the
        // caption under it (from y = 166).
        let is_dark = |c: Rgb| lightness(c) < 35.0 && c[2] > c[1] + 20 && c[0] > c[1];
        let is_light = |c: Rgb| lightness(c) > 70.0 && c[2] < 120;
        let surface_dark: Vec<_> = pixels
            .iter()
            .filter(|p| p.0 < 330 && p.1 < 166 && is_dark(p.2))
            .collect();
        assert!(!surface_dark.is_empty(), "the worst corner is dark");
        assert!(
            surface_dark.iter().all(|p| p.1 < 100),
            "and it is the upper corner: {:?}",
            surface_dark
                .iter()
                .filter(|p| p.1 >= 100)
                .take(5)
                .collect::<Vec<_>>()
        );
        assert!(
            pixels.iter().any(|p| p.0 < 330 && is_light(p.2)),
            "the rest is light"
        );
        assert!(
            pixels.iter().any(|p| p.0 > 330 && near(p.2, worst, 2)),
            "the bar's top"
        );
        assert!(
            pixels.iter().any(|p| p.0 > 330 && near(p.2, best, 2)),
            "the bar's bottom"
        );
    }

    /// A unit square seen from above, fitted to 21 sections of 21 points along x (chord 1,
    /// except the last three: 0.5), offsets large near (u, v) = (1, 1).
    fn sectioned_square() -> (PatchGrid<DVec3>, RenderOptions) {
        let layout = GridLayout::uniform((1, 1), (1, 1), Continuity::C0).unwrap();
        let design = vec![DVec3::ZERO, DVec3::Y, DVec3::X, DVec3::new(1.0, 1.0, 0.0)];
        let grid = PatchGrid::new(layout, design).unwrap();
        let sections = Grid {
            sections: 21,
            per_section: 21,
        };
        let uv: Vec<[f64; 2]> = (0..21)
            .flat_map(|j| (0..21).map(move |i| [f64::from(i) / 20.0, f64::from(j) / 20.0]))
            .map(|[u, v]| if v > 0.85 { [0.5 * u, v] } else { [u, v] })
            .collect();
        let points: Vec<DVec3> = uv.iter().map(|&[u, v]| DVec3::new(u, v, 0.0)).collect();
        let mut opts = RenderOptions::of_surface(&grid, &uv, DVec3::Y, &points, Some(sections), 600, 300);
        opts.views = vec![View {
            eye: DVec3::Z,
            right: DVec3::Y,
        }];
        // The points lie on the surface: give them offsets, largest at the 0.5 chords.
        for p in &mut opts.offsets {
            p.offset = if p.uv[0] > 0.4 && p.uv[1] > 0.85 {
                4e-3
            } else {
                1e-4 + 1e-3 * p.uv[0] * p.uv[1]
            };
        }
        (grid, opts)
    }

    #[test]
    fn the_svg_has_a_bar_of_two_scales_rings_and_stations() {
        let (grid, opts) = sectioned_square();
        assert_eq!(opts.stations.len(), 21);
        assert_eq!(opts.stations[20].chord, 0.5);
        let svg = render_svg(&grid, &opts).unwrap();
        assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
        let bar = &svg[svg.find(r#"<g id="colour-bar""#).expect("a colour bar")..];
        assert_eq!(
            bar.matches(r#"class="percent-of-local-chord""#).count(),
            5,
            "% of local chord"
        );
        assert_eq!(bar.matches(r#"class="data-units""#).count(), 5, "data units");
        // The top ticks: 0.4 % of the 0.5 chord, 4e-3 / 0.5 x the largest chord 1.
        assert!(
            bar.contains(">0.800%</text>") && bar.contains(">8.00e-3</text>"),
            "{bar}"
        );
        assert!(bar.contains("offset / local chord") && bar.contains("at largest chord 1.00e0"));
        assert!(bar.contains("linearGradient"));
        // The worst relative to the local chord is on a half-chord section, section 17 to 20.
        let ring = &svg[svg.find(r#"<g class="worst-point""#).expect("a worst-point ring")..];
        assert!(
            ring.contains("worst 0.800% of local chord: 4.00e-3, section"),
            "{}",
            &ring[..600]
        );
        assert_eq!(svg.matches(r#"class="worst-point""#).count(), 1);
        // The largest offset in data units is the same point: one ring only.
        assert_eq!(svg.matches(r#"class="largest-offset""#).count(), 0);
        assert!(
            svg.matches(r#"class="station""#).count() >= 21 * 20,
            "station lines"
        );
        assert!(svg.contains(r#"class="station-numbers""#) && svg.contains(">20</text>"));
        assert!(svg.contains("lines: the data's stations"));
    }

    #[test]
    fn a_remark_is_ringed_dotted_labelled_and_captioned() {
        let (grid, mut opts) = sectioned_square();
        let plain = render(&grid, &opts).unwrap();
        opts.remarks = vec![Remark {
            position: grid.eval(1.0, 0.3),
            label: "end 1 doubles back 1.73e-2 (3.00 tol), span 0.30".into(),
        }];
        let svg = render_svg(&grid, &opts).unwrap();
        assert_eq!(
            svg.matches(r#"<g class="section-end""#).count(),
            opts.views.len(),
            "one dotted ring a view"
        );
        let ring = &svg[svg.find(r#"<g class="section-end""#).unwrap()..];
        assert!(ring.contains(r#"stroke-dasharray="1,3""#) && ring.contains("end 1 doubles back 1.73e-2"));
        assert!(svg.contains("dotted ring: where a section's end doubles back"));
        // The PNG draws it: some pixels change, and the caption grows by a line.
        let marked = render(&grid, &opts).unwrap();
        assert_ne!(plain.to_png().unwrap(), marked.to_png().unwrap());
        let c = Colouring::new(&opts.offsets, &opts.stations).unwrap();
        assert_eq!(caption(&c, &opts).len(), c.caption(true).len() + 1);
    }

    #[test]
    fn the_png_of_a_sectioned_fit_writes() {
        let (grid, mut opts) = sectioned_square();
        // A larger offset in data units on a full chord: two rings.
        opts.offsets[3 * 21 + 10].offset = 5e-3;
        let c = Colouring::new(&opts.offsets, &opts.stations).unwrap();
        assert_eq!(c.marked.len(), 2);
        assert!(c.relative && c.marked[1].index == 3 * 21 + 10);
        let img = render(&grid, &opts).unwrap();
        if let Ok(dir) = std::env::var("BEZCHAIN_PICTURES") {
            std::fs::write(format!("{dir}/sectioned.png"), img.to_png().unwrap()).unwrap();
            std::fs::write(format!("{dir}/sectioned.svg"), render_svg(&grid, &opts).unwrap()).unwrap();
        }
        assert_eq!((img.width, img.height), (600, 300));
        let png = img.to_png().unwrap();
        assert!(png.starts_with(b"\x89PNG\r\n\x1a\n"));
        let svg = render_svg(&grid, &opts).unwrap();
        assert_eq!(svg.matches(r#"class="largest-offset""#).count(), 1);
        assert!(svg.contains("max 5.00e-3 (0.500% of local chord), section 3"));
        // The picture shows the worst colour on the surface and black rings.
        let pixels: Vec<Rgb> = (0..300)
            .flat_map(|y| (0..600).map(move |x| (x, y)))
            .map(|(x, y)| img.pixel(x, y))
            .collect();
        assert!(
            pixels.iter().any(|&p| p == [0, 0, 0] || lightness(p) < 5.0),
            "a ring"
        );
        assert_eq!(
            station_ticks(&[0.0, 1.0, 2.0, 30.0, 31.0], 10.0),
            [true, false, false, false, true]
        );
        assert_eq!(station_ticks(&[0.0, 5.0], 10.0), [true, true]);
    }
}
