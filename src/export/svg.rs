//! SVG plots of a fitted chain like the paper's Figs. 9–11, with the offsets in a second panel.

use crate::chain::CurveChain;
use crate::error::{Error, Result};
use glam::DVec2;
use plotters::prelude::*;

/// Plot bounds `(x0, x1, y0, y1)`.
type Bounds = (f64, f64, f64, f64);

/// What to draw: the data, the fitted chain and each data point's offset.
pub struct CurvePlot<'a> {
    /// Title line (e.g. `NACA 4413 — degree 3, 5 segments, C1, lsq`).
    pub title: String,
    /// The data points.
    pub data: &'a [DVec2],
    /// The fitted chain.
    pub chain: &'a CurveChain<DVec2>,
    /// Offset of each data point (same order as `data`), model units.
    pub offsets: &'a [f64],
}

const WIDTH: u32 = 1200;
const BOTTOM_HEIGHT: u32 = 300;
/// Room taken by the caption, labels and margins of the top panel, in pixels.
const TOP_FRAME: (u32, u32) = (90, 110);

/// A plotters error as the library's output error (every SVG plot of the crate uses it).
pub(crate) fn plot_err<E: std::fmt::Debug>(e: E) -> Error {
    Error::Output(format!("svg plot: {e:?}"))
}

/// A plot's chart over f64 axes, as every plot of the crate draws on.
pub(crate) type Chart<'a, DB> = ChartContext<
    'a,
    DB,
    Cartesian2d<plotters::coord::types::RangedCoordf64, plotters::coord::types::RangedCoordf64>,
>;

/// The legend of a chart: its series' labels at `position`, on a light box with a grey
/// border (every plot of the crate draws it so).
pub(crate) fn draw_legend<'a, DB: DrawingBackend + 'a>(
    chart: &mut Chart<'a, DB>,
    position: SeriesLabelPosition,
) -> Result<()> {
    chart
        .configure_series_labels()
        .position(position)
        .background_style(WHITE.mix(0.85))
        .border_style(RGBColor(150, 150, 150))
        .draw()
        .map_err(plot_err)
}

/// The axes and grid of a shape plot: x and y labelled, the minor lines white.
pub(crate) fn draw_xy_mesh<DB: DrawingBackend>(chart: &mut Chart<'_, DB>) -> Result<()> {
    chart
        .configure_mesh()
        .x_desc("x")
        .y_desc("y")
        .light_line_style(WHITE)
        .draw()
        .map_err(plot_err)
}

impl CurvePlot<'_> {
    /// Render the plot as an SVG document.
    ///
    /// Top: data points, fitted chain (sampled at 60 points per segment), control polygon
    /// (dashed), design points (filled squares) and generated join points (open circles), with
    /// equal axis scales. Bottom: offset of each data point along the contour, log scale.
    pub fn to_svg(&self) -> Result<String> {
        let mut out = String::new();
        {
            let root = SVGBackend::with_string(&mut out, self.size()).into_drawing_area();
            self.draw(&root)?;
            root.present().map_err(plot_err)?;
        }
        Ok(out)
    }

    /// The plot of [`to_svg`](Self::to_svg) as a PNG picture of the same size.
    pub fn to_png(&self) -> Result<Vec<u8>> {
        let (w, h) = self.size();
        super::plot_png(w, h, |root| self.draw(root))
    }

    /// The top panel's height: as tall as equal axis scales need, within limits.
    fn top_height(bounds: Bounds) -> u32 {
        let plot_w = (WIDTH - TOP_FRAME.0) as f64;
        let aspect = (bounds.3 - bounds.2) / (bounds.1 - bounds.0).max(1e-12);
        ((plot_w * aspect * 1.15) as u32 + TOP_FRAME.1).clamp(320, 900)
    }

    /// The plot's size in pixels.
    fn size(&self) -> (u32, u32) {
        (WIDTH, Self::top_height(self.sampled().1) + BOTTOM_HEIGHT)
    }

    /// Draw both panels on `root`.
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, plotters::coord::Shift>) -> Result<()> {
        let (curve, bounds) = self.sampled();
        let top_height = Self::top_height(bounds);
        root.fill(&WHITE).map_err(plot_err)?;
        let (top, bottom) = root.split_vertically(top_height);
        self.draw_shape(&top, curve, bounds, top_height)?;
        self.draw_offsets(&bottom)
    }

    /// The chain sampled at 60 points per segment, and the bounds `(x0, x1, y0, y1)` of
    /// everything drawn in the top panel.
    fn sampled(&self) -> (Vec<(f64, f64)>, Bounds) {
        let chain = self.chain;
        let l = chain.layout();
        let curve: Vec<(f64, f64)> = (0..l.segments())
            .flat_map(|k| {
                let seg = chain.segment(k);
                (0..=60).map(move |i| {
                    let p = seg.eval(i as f64 / 60.0);
                    (p.x, p.y)
                })
            })
            .collect();
        let all = self
            .data
            .iter()
            .chain(chain.ctrl())
            .map(|p| (p.x, p.y))
            .chain(curve.iter().copied());
        let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
        for (x, y) in all {
            (x0, x1, y0, y1) = (x0.min(x), x1.max(x), y0.min(y), y1.max(y));
        }
        // Room below the shape for the legend.
        (curve, (x0, x1, y0 - 0.5 * (y1 - y0), y1))
    }

    fn draw_shape<DB: DrawingBackend>(
        &self,
        area: &DrawingArea<DB, plotters::coord::Shift>,
        curve: Vec<(f64, f64)>,
        (x0, x1, y0, y1): Bounds,
        height: u32,
    ) -> Result<()> {
        let chain = self.chain;
        let l = chain.layout();
        let d = l.degree();
        let ctrl: Vec<(f64, f64)> = chain.ctrl().iter().map(|p| (p.x, p.y)).collect();
        // Design points are drawn as they are; expanded points that are not copies of a design
        // point are the generated ones (the joins for C1, more for C2).
        let design: Vec<(f64, f64)> = chain.design().iter().map(|p| (p.x, p.y)).collect();
        let generated: Vec<(f64, f64)> = ctrl
            .iter()
            .enumerate()
            .filter(|(r, _)| !l.map().is_copy(*r))
            .map(|(_, &p)| p)
            .collect();
        // Equal scales: widen the narrower range to the plot area's aspect ratio.
        let plot_w = (WIDTH - TOP_FRAME.0) as f64;
        let plot_h = (height - TOP_FRAME.1) as f64;
        let (cx, cy) = ((x0 + x1) / 2.0, (y0 + y1) / 2.0);
        let span = ((x1 - x0) / plot_w).max((y1 - y0) / plot_h).max(1e-12) * 1.05;
        let (x0, x1) = (cx - span * plot_w / 2.0, cx + span * plot_w / 2.0);
        let (y0, y1) = (cy - span * plot_h / 2.0, cy + span * plot_h / 2.0);

        let mut chart = ChartBuilder::on(area)
            .caption(&self.title, ("sans-serif", 20))
            .margin(12)
            .x_label_area_size(35)
            .y_label_area_size(55)
            .build_cartesian_2d(x0..x1, y0..y1)
            .map_err(plot_err)?;
        draw_xy_mesh(&mut chart)?;
        let grey = RGBColor(150, 150, 150);
        chart
            .draw_series(DashedLineSeries::new(
                ctrl.iter().copied(),
                5,
                4,
                grey.stroke_width(1),
            ))
            .map_err(plot_err)?
            .label("control polygon")
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], grey));
        let blue = RGBColor(31, 119, 180);
        chart
            .draw_series(LineSeries::new(curve, blue.stroke_width(2)))
            .map_err(plot_err)?
            .label(format!("fitted chain ({} segments, degree {d})", l.segments()))
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], blue.stroke_width(2)));
        chart
            .draw_series(
                self.data
                    .iter()
                    .map(|p| Circle::new((p.x, p.y), 2, BLACK.filled())),
            )
            .map_err(plot_err)?
            .label(format!("data ({} points)", self.data.len()))
            .legend(|(x, y)| Circle::new((x + 9, y), 2, BLACK.filled()));
        let red = RGBColor(214, 39, 40);
        chart
            .draw_series(
                design.iter().map(|&(x, y)| {
                    EmptyElement::at((x, y)) + Rectangle::new([(-4, -4), (4, 4)], red.filled())
                }),
            )
            .map_err(plot_err)?
            .label(format!("design points ({})", design.len()))
            .legend(move |(x, y)| Rectangle::new([(x + 5, y - 4), (x + 13, y + 4)], red.filled()));
        let green = RGBColor(44, 160, 44);
        chart
            .draw_series(
                generated
                    .iter()
                    .map(|&(x, y)| Circle::new((x, y), 5, green.stroke_width(2))),
            )
            .map_err(plot_err)?
            .label(format!("generated join points ({})", generated.len()))
            .legend(move |(x, y)| Circle::new((x + 9, y), 5, green.stroke_width(2)));
        draw_legend(&mut chart, SeriesLabelPosition::LowerRight)
    }

    fn draw_offsets<DB: DrawingBackend>(&self, area: &DrawingArea<DB, plotters::coord::Shift>) -> Result<()> {
        let n = self.offsets.len().max(1);
        let max = self.offsets.iter().copied().fold(0.0, f64::max);
        let top = if max > 0.0 { max * 3.0 } else { 1.0 };
        let floor = top * 1e-5;
        let mut chart = ChartBuilder::on(area)
            .caption(
                format!("offset of each data point (max {max:.3e})"),
                ("sans-serif", 16),
            )
            .margin(12)
            .x_label_area_size(35)
            .y_label_area_size(70)
            .build_cartesian_2d(0f64..(n - 1).max(1) as f64, (floor..top).log_scale())
            .map_err(plot_err)?;
        chart
            .configure_mesh()
            .x_desc("data point (contour order)")
            .y_desc("offset")
            .y_label_formatter(&|v| format!("{v:.0e}"))
            .draw()
            .map_err(plot_err)?;
        let blue = RGBColor(31, 119, 180);
        chart
            .draw_series(self.offsets.iter().enumerate().map(|(i, &e)| {
                PathElement::new(
                    vec![(i as f64, floor), (i as f64, e.max(floor))],
                    blue.stroke_width(2),
                )
            }))
            .map_err(plot_err)?;
        chart
            .draw_series(
                self.offsets
                    .iter()
                    .enumerate()
                    .map(|(i, &e)| Circle::new((i as f64, e.max(floor)), 2, blue.filled())),
            )
            .map_err(plot_err)?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::chain::{ChainLayout, Continuity};

    #[test]
    fn the_plot_holds_every_marker() {
        let layout = ChainLayout::uniform(3, 5, Continuity::C1).unwrap();
        let design: Vec<DVec2> = (0..12)
            .map(|i| DVec2::new(i as f64 / 11.0, 0.1 * (i as f64).sin()))
            .collect();
        let chain = CurveChain::new(layout, design).unwrap();
        let data: Vec<DVec2> = (0..40)
            .map(|i| chain.eval(i as f64 / 39.0) + DVec2::new(0.0, 1e-4))
            .collect();
        let offsets: Vec<f64> = (0..40).map(|i| 1e-5 * (1.0 + i as f64)).collect();
        let svg = CurvePlot {
            title: "test".into(),
            data: &data,
            chain: &chain,
            offsets: &offsets,
        }
        .to_svg()
        .unwrap();
        assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
        assert!(svg.contains("design points (12)"));
        assert!(svg.contains("generated join points (4)"));
        assert!(svg.contains("data (40 points)"));
        // 40 data dots + 40 offset dots + 5 legend/markers at least.
        assert!(svg.matches("<circle").count() >= 80 + 4);
    }
}
