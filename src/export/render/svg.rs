//! The surface pictures of [`super::render`] as SVG drawings: iso-parameter curves and the
//! control net, or, with offsets, the surface as coloured triangles with the rings, stations,
//! colour bar and caption of the PNG.

use super::*;

/// The views of [`render`] as an SVG drawing (no supersampling, no hidden-line removal):
/// iso-parameter curves of the surface (eight per patch side, the patch borders darker), the
/// control net, generated and design points, and up to 3,000 of `opts.cloud` as dots.
///
/// With offsets the surface is drawn instead as coloured triangles (painter's order: far ones
/// first, with the patch borders and the station lines among them), under the faint net, with
/// the rings, the station numbers, the colour bar and the caption of [`render`].
pub fn render_svg(grid: &PatchGrid<DVec3>, opts: &RenderOptions) -> Result<String> {
    use std::fmt::Write as _;
    opts.check()?;
    if let Some(c) = Colouring::new(&opts.offsets, &opts.stations) {
        if let Some(svg) = coloured_svg(grid, opts, &c)? {
            return Ok(svg);
        }
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
    let panel_h = h / opts.views.len() as f64;
    for (k, view) in opts.views.iter().enumerate() {
        let cam = Camera::new(view, &everything, (0.0, k as f64 * panel_h, w, panel_h))?;
        let _ = writeln!(svg, r#"<g fill="none" stroke-linejoin="round">"#);
        for (pts, border) in &curves {
            let (colour, width, opacity) = if *border {
                (BORDER, 1.3, 0.9)
            } else {
                (SURFACE, 0.8, 0.9)
            };
            let path: Vec<String> = pts.iter().map(|&p| svg_xy(&cam, p)).collect();
            let _ = writeln!(
                svg,
                r#"<polyline points="{}" stroke="{}" stroke-width="{width}" stroke-opacity="{opacity}"/>"#,
                path.join(" "),
                hex(colour)
            );
        }
        let net_style = format!(
            r#" stroke="{}" stroke-width="0.9" stroke-opacity="0.75""#,
            hex(NET)
        );
        net_lines_svg(&mut svg, &cam, (net, mu, mv), &net_style);
        let _ = writeln!(svg, "</g>");
        let _ = writeln!(svg, r#"<g fill="{}" fill-opacity="0.6">"#, hex(DATA_POINT));
        for p in opts.cloud.iter().step_by(step) {
            let (x, y, _) = cam.project(*p);
            if x.is_finite() && y.is_finite() {
                let _ = writeln!(svg, r#"<circle cx="{x:.1}" cy="{y:.1}" r="0.8"/>"#);
            }
        }
        let _ = writeln!(svg, "</g>");
        net_points_svg(
            &mut svg,
            &cam,
            (l, net, mu, mv),
            [3.0, 2.8],
            r#"stroke="white" stroke-width="0.8""#,
        );
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

/// `p` on the picture, as a polyline's `x,y` point.
fn svg_xy(cam: &Camera, p: DVec3) -> String {
    let (x, y, _) = cam.project(p);
    format!("{x:.1},{y:.1}")
}

/// The control net's rows, then its columns, as SVG polylines, each with the attributes
/// `style` after its points (a leading space; empty for none).
fn net_lines_svg(svg: &mut String, cam: &Camera, (net, mu, mv): (&[DVec3], usize, usize), style: &str) {
    use std::fmt::Write as _;
    let rows = (0..mu).map(|r| (0..mv).map(|c| r * mv + c).collect::<Vec<_>>());
    let cols = (0..mv).map(|c| (0..mu).map(|r| r * mv + c).collect::<Vec<_>>());
    for line in rows.chain(cols) {
        let path: Vec<String> = line.iter().map(|&k| svg_xy(cam, net[k])).collect();
        let _ = writeln!(svg, r#"<polyline points="{}"{style}/>"#, path.join(" "));
    }
}

/// The control net's points in SVG: the generated ones (join points) first, then the design
/// points over them, radii `[design, generated]`, each group with the attributes `style`.
fn net_points_svg(
    svg: &mut String,
    cam: &Camera,
    (l, net, mu, mv): (&GridLayout, &[DVec3], usize, usize),
    radii: [f64; 2],
    style: &str,
) {
    use std::fmt::Write as _;
    for design in [false, true] {
        let (colour, radius) = if design {
            (DESIGN_POINT, radii[0])
        } else {
            (GENERATED_POINT, radii[1])
        };
        let _ = writeln!(svg, r#"<g fill="{}" {style}>"#, hex(colour));
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
}

/// `#rrggbb`.
fn hex(c: Rgb) -> String {
    format!("#{:02x}{:02x}{:02x}", c[0], c[1], c[2])
}

/// Text escaped for SVG.
fn escaped(text: &str) -> String {
    text.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// [`render_svg`] of a surface coloured by `colouring`; `None` when the offsets colour no vertex.
#[allow(clippy::too_many_lines)]
fn coloured_svg(
    grid: &PatchGrid<DVec3>,
    opts: &RenderOptions,
    colouring: &Colouring,
) -> Result<Option<String>> {
    use std::fmt::Write as _;
    // At most about 8,000 triangles and 4,000 border segments a view, whatever the grid.
    let l = grid.layout();
    let patches = (l.u.segments() * l.v.segments()).max(1);
    let per_patch = ((4000.0 / patches as f64).sqrt() as usize).clamp(1, (opts.per_patch / 2).max(2));
    let mesh = SurfaceMesh::from_grid(grid, per_patch)?;
    let Some(local) = local_offsets(&mesh, &value_points(opts, colouring)) else {
        return Ok(None);
    };
    let base: Vec<[f32; 3]> = local
        .iter()
        .map(|&e| offset_colour(colouring.position(e)).map(f32::from))
        .collect();
    let (w, h) = (f64::from(opts.width), f64::from(opts.height));
    let (mu, mv) = l.net_shape();
    let net = grid.net();
    let (bu, bv) = (l.u.breaks(), l.v.breaks());
    let along_n = 4000 / (bu.len() + bv.len()).max(1);
    let along = uniform((24 * l.u.segments().max(l.v.segments())).clamp(2, along_n.max(2)) + 1);
    let (borders, everything, tol) = borders_and_frame(grid, &mesh, &along)?;
    // One font pixel of the PNG's 5 x 7 glyphs: the same layout, in user units.
    let fp = (h / 450.0).max(1.0);
    let font = 8.5 * fp;
    let (bar_room, caption_h, caption) = bar_and_caption(Some(colouring), opts, w, fp);
    let panel_w = w - bar_room;
    let panel_h = (h - caption_h) / opts.views.len() as f64;
    let mut svg = String::new();
    let _ = writeln!(
        svg,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" viewBox="0 0 {w} {h}" font-family="sans-serif">"#
    );
    let _ = writeln!(svg, r#"<rect width="{w}" height="{h}" fill="white"/>"#);
    let _ = writeln!(
        svg,
        "<!-- {} -->",
        escaped(&super::caption(colouring, opts).join(" | "))
    );
    for (k, view) in opts.views.iter().enumerate() {
        let cam = Camera::new(view, &everything, (0.0, k as f64 * panel_h, panel_w, panel_h))?;
        let shade = shading(&mesh, &cam, true);
        let screen: Vec<(f64, f64, f64)> = mesh.positions.iter().map(|p| cam.project(*p)).collect();
        // Hidden-surface removal: a depth buffer of the view at the picture's size keeps only
        // the triangles and line pieces that show (a sample of them in front of the surface);
        // those are then drawn far to near (the painter's order), lines on the surface a
        // little nearer than the triangles they lie on.
        let mut depth = Canvas::new(opts.width as usize, opts.height as usize);
        for t in &mesh.triangles {
            let v = t.map(|i| screen[i as usize]);
            fill_triangle(&mut depth, v, [[0.0; 2]; 3], [[0.0; 3]; 3]);
        }
        let shows = |p: (f64, f64, f64)| depth.overlay_alpha(p.0 as i64, p.1 as i64, p.2, tol) >= 1.0;
        let mut items: Vec<(f64, String)> = Vec::with_capacity(mesh.triangles.len() + 4096);
        for t in &mesh.triangles {
            let [a, b, c] = t.map(|i| i as usize);
            let (pa, pb, pc) = (screen[a], screen[b], screen[c]);
            let centre = (
                (pa.0 + pb.0 + pc.0) / 3.0,
                (pa.1 + pb.1 + pc.1) / 3.0,
                (pa.2 + pb.2 + pc.2) / 3.0,
            );
            let toward = |q: (f64, f64, f64)| {
                (
                    centre.0 + 0.8 * (q.0 - centre.0),
                    centre.1 + 0.8 * (q.1 - centre.1),
                    centre.2 + 0.8 * (q.2 - centre.2),
                )
            };
            if ![centre, toward(pa), toward(pb), toward(pc)]
                .into_iter()
                .any(shows)
            {
                continue;
            }
            let colour = [0, 1, 2].map(|ch| {
                let base = (base[a][ch] + base[b][ch] + base[c][ch]) / 3.0;
                let d = (shade[a][0] + shade[b][0] + shade[c][0]) / 3.0;
                let s = (shade[a][1] + shade[b][1] + shade[c][1]) / 3.0;
                (base * d + 255.0 * s).clamp(0.0, 255.0).round() as u8
            });
            let fill = hex(colour);
            items.push((
                (pa.2 + pb.2 + pc.2) / 3.0,
                format!(
                    r#"<path d="M{:.1},{:.1}L{:.1},{:.1}L{:.1},{:.1}Z" fill="{fill}" stroke="{fill}" stroke-width="0.5"/>"#,
                    pa.0, pa.1, pb.0, pb.1, pc.0, pc.1
                ),
            ));
        }
        let mut segments = |line: &[DVec3], style: &str| {
            for s in line.windows(2) {
                let (a, b) = (cam.project(s[0]), cam.project(s[1]));
                if !shows((0.5 * (a.0 + b.0), 0.5 * (a.1 + b.1), 0.5 * (a.2 + b.2))) {
                    continue;
                }
                items.push((
                    0.5 * (a.2 + b.2) + tol,
                    format!(
                        r#"<line x1="{:.1}" y1="{:.1}" x2="{:.1}" y2="{:.1}" {style}/>"#,
                        a.0, a.1, b.0, b.1
                    ),
                ));
            }
        };
        let border_style = format!(
            r#"stroke="{}" stroke-width="1" stroke-opacity="0.35""#,
            hex(BORDER)
        );
        for curve in &borders {
            segments(curve, &border_style);
        }
        let station_style = r##"class="station" stroke="#141414" stroke-width="1.6" stroke-opacity="0.55""##;
        let core_style = r#"stroke="white" stroke-width="0.6" stroke-opacity="0.8""#;
        for st in &opts.stations {
            segments(&st.points, station_style);
            segments(&st.points, core_style);
        }
        items.sort_by(|a, b| a.0.total_cmp(&b.0));
        let _ = writeln!(svg, r#"<g stroke-linecap="round" stroke-linejoin="round">"#);
        for (_, item) in &items {
            svg.push_str(item);
            svg.push('\n');
        }
        let _ = writeln!(svg, "</g>");
        // The control net, faint over the colours, and its points.
        let _ = writeln!(
            svg,
            r#"<g fill="none" stroke="{}" stroke-width="0.9" stroke-opacity="0.3">"#,
            hex(NET)
        );
        net_lines_svg(&mut svg, &cam, (net, mu, mv), "");
        let _ = writeln!(svg, "</g>");
        net_points_svg(
            &mut svg,
            &cam,
            (l, net, mu, mv),
            [1.8, 1.7],
            r#"fill-opacity="0.45" stroke="white" stroke-width="0.5" stroke-opacity="0.45""#,
        );
        // The stations' numbers under the panel.
        let panel_bottom = (k + 1) as f64 * panel_h;
        let xs: Vec<f64> = opts.stations.iter().map(|st| station_x(&cam, st)).collect();
        let _ = writeln!(
            svg,
            r#"<g class="station-numbers" font-size="{font:.1}" text-anchor="middle" fill="{}">"#,
            hex(NET)
        );
        for (n, shown) in station_ticks(&xs, 24.0 * fp).into_iter().enumerate() {
            let x = xs[n];
            if !(x.is_finite() && x < panel_w) {
                continue;
            }
            let (y0, len) = (panel_bottom - 12.0 * fp, if shown { 3.0 } else { 2.0 } * fp);
            let _ = writeln!(
                svg,
                r#"<line x1="{x:.1}" y1="{y0:.1}" x2="{x:.1}" y2="{:.1}" stroke="{}"/>"#,
                y0 + len,
                hex(NET)
            );
            if shown {
                let _ = writeln!(
                    svg,
                    r#"<text x="{x:.1}" y="{:.1}">{n}</text>"#,
                    panel_bottom - 1.5 * fp
                );
            }
        }
        let _ = writeln!(svg, "</g>");
        // The rings and their labels.
        let panel = (0.0, k as f64 * panel_h, panel_w, panel_h);
        let radius = 6.0 * fp;
        let rings = marks(&colouring.marked, colouring.relative, &opts.remarks, radius);
        let mut placed = ring_boxes(&cam, &rings);
        for m in &rings {
            let p = cam.project(m.at);
            let hidden = hidden_by(&screen, &mesh.triangles, p, tol);
            let text = m.label(hidden);
            let radius = m.radius;
            let (x, y) = place_label(p, radius, &text, fp, panel, &mut placed);
            let (class, (width, dash)) = (m.ring.class(), m.ring.svg());
            let opacity = if hidden { 0.5 } else { 1.0 };
            let _ = writeln!(svg, r#"<g class="{class}" opacity="{opacity}">"#);
            let _ = writeln!(
                svg,
                r#"<circle cx="{:.1}" cy="{:.1}" r="{radius:.1}" fill="none" stroke="white" stroke-width="{:.1}"{dash}/>"#,
                p.0,
                p.1,
                2.0 * width + 1.0
            );
            let _ = writeln!(
                svg,
                r#"<circle cx="{:.1}" cy="{:.1}" r="{radius:.1}" fill="none" stroke="black" stroke-width="{width}"{dash}/>"#,
                p.0, p.1
            );
            let _ = writeln!(
                svg,
                r#"<rect x="{:.1}" y="{:.1}" width="{:.1}" height="{:.1}" fill="white" fill-opacity="0.8"/>"#,
                x - fp,
                y - fp,
                text.chars().count() as f64 * 6.0 * fp + 2.0 * fp,
                9.0 * fp
            );
            let _ = writeln!(
                svg,
                r#"<text x="{x:.1}" y="{:.1}" font-size="{font:.1}" fill="{}" textLength="{:.1}" lengthAdjust="spacingAndGlyphs">{}</text>"#,
                y + 7.0 * fp,
                hex(NET),
                text.chars().count() as f64 * 6.0 * fp - fp,
                escaped(&text)
            );
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
    // The colour bar: a gradient of the map, its ticks, both scales and their names.
    let bottom = h - caption_h - 0.06 * h;
    let top = (0.06 * h + 24.0 * fp).min(bottom - 20.0);
    let x = panel_w + 2.0 * fp;
    let left_room = if colouring.relative { 44.0 * fp } else { 0.0 };
    let (bx, bw) = (x + left_room, 8.0 * fp);
    let _ = writeln!(
        svg,
        r#"<g id="colour-bar" font-size="{font:.1}" fill="{}">"#,
        hex(NET)
    );
    let _ = writeln!(
        svg,
        r#"<defs><linearGradient id="offset-map" x1="0" y1="1" x2="0" y2="0">"#
    );
    for q in 0..=20 {
        let t = f64::from(q) / 20.0;
        let _ = writeln!(
            svg,
            r#"<stop offset="{t}" stop-color="{}"/>"#,
            hex(offset_colour(t))
        );
    }
    let _ = writeln!(svg, "</linearGradient></defs>");
    let _ = writeln!(
        svg,
        r#"<rect x="{bx:.1}" y="{top:.1}" width="{bw:.1}" height="{:.1}" fill="url(#offset-map)" stroke="{}" stroke-width="0.5"/>"#,
        bottom - top,
        hex(NET)
    );
    for (q, (left, right)) in colouring.ticks().into_iter().enumerate() {
        let y = bottom - (bottom - top) * q as f64 / 4.0;
        let _ = writeln!(
            svg,
            r#"<line x1="{:.1}" y1="{y:.1}" x2="{:.1}" y2="{y:.1}" stroke="{}"/>"#,
            bx + bw,
            bx + bw + 2.0 * fp,
            hex(NET)
        );
        let _ = writeln!(
            svg,
            r#"<text class="data-units" x="{:.1}" y="{:.1}">{right}</text>"#,
            bx + bw + 3.0 * fp,
            y + 3.0 * fp
        );
        if let Some(left) = left {
            let _ = writeln!(
                svg,
                r#"<line x1="{:.1}" y1="{y:.1}" x2="{bx:.1}" y2="{y:.1}" stroke="{}"/>"#,
                bx - 2.0 * fp,
                hex(NET)
            );
            let _ = writeln!(
                svg,
                r#"<text class="percent-of-local-chord" x="{:.1}" y="{:.1}" text-anchor="end">{left}</text>"#,
                bx - 3.0 * fp,
                y + 3.0 * fp
            );
        }
    }
    let _ = writeln!(
        svg,
        r#"<text x="{x:.1}" y="{:.1}">{}</text>"#,
        top - 19.0 * fp,
        escaped(colouring.title())
    );
    if colouring.relative {
        let _ = writeln!(
            svg,
            r#"<text x="{x:.1}" y="{:.1}">% of local chord</text>"#,
            top - 8.0 * fp
        );
        let _ = writeln!(
            svg,
            r#"<text x="{x:.1}" y="{:.1}">at largest chord {}</text>"#,
            bottom + 10.0 * fp,
            offset_label(colouring.reference)
        );
    }
    let _ = writeln!(svg, "</g>");
    let _ = writeln!(
        svg,
        r#"<g class="caption" font-size="{font:.1}" fill="{}">"#,
        hex(NET)
    );
    for (n, line) in caption.iter().enumerate() {
        let y = h - caption_h + (9 + 10 * n) as f64 * fp;
        let _ = writeln!(
            svg,
            r#"<text x="{:.1}" y="{y:.1}">{}</text>"#,
            4.0 * fp,
            escaped(line)
        );
    }
    let _ = writeln!(svg, "</g>");
    svg.push_str("</svg>\n");
    Ok(Some(svg))
}
