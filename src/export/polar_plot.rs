//! SVG pictures of viscous polars: CL against α, CL against CD (the drag polar) and CM against
//! α side by side, one colour per aerofoil; points that did not converge are left out.

use super::cp_plot::PALETTE;
use super::svg::{draw_legend, plot_err};
use crate::aero::ViscousPoint;
use crate::error::Result;
use plotters::prelude::*;

/// What to draw: a title and one labelled polar per aerofoil.
#[derive(Clone, Debug, PartialEq)]
pub struct PolarPlot {
    /// Title line.
    pub title: String,
    /// `(legend, points)` per aerofoil (colours in order).
    pub polars: Vec<(String, Vec<ViscousPoint>)>,
}

/// A converged point's `(α, CL, CD, CM)`.
type Coeffs = (f64, f64, f64, f64);
/// One panel: axis names, ranges and what it plots of a point.
type Panel = (
    &'static str,
    &'static str,
    (f64, f64),
    (f64, f64),
    fn(&Coeffs) -> (f64, f64),
);

const PANEL_W: u32 = 420;
const HEIGHT: u32 = 460;

/// The range of `v` padded by 5 % (a unit range around a single value).
fn range(v: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = v.fold((f64::MAX, f64::MIN), |(a, b), x| (a.min(x), b.max(x)));
    if hi.partial_cmp(&lo).is_none_or(|o| o.is_lt()) {
        return (0.0, 1.0);
    }
    let pad = if hi > lo { 0.05 * (hi - lo) } else { 0.5 };
    (lo - pad, hi + pad)
}

impl PolarPlot {
    /// Render as an SVG document.
    pub fn to_svg(&self) -> Result<String> {
        let mut out = String::new();
        {
            let root = SVGBackend::with_string(&mut out, (3 * PANEL_W, HEIGHT)).into_drawing_area();
            self.draw(&root)?;
            root.present().map_err(plot_err)?;
        }
        Ok(out)
    }

    /// The plot of [`to_svg`](Self::to_svg) as a PNG picture of the same size.
    pub fn to_png(&self) -> Result<Vec<u8>> {
        super::plot_png(3 * PANEL_W, HEIGHT, |root| self.draw(root))
    }

    /// Draw the three panels on `root`.
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, plotters::coord::Shift>) -> Result<()> {
        // Only converged points carry numbers.
        let conv: Vec<(&str, Vec<Coeffs>)> = self
            .polars
            .iter()
            .map(|(label, pts)| {
                let v = pts
                    .iter()
                    .filter_map(|p| Some((p.alpha, p.cl?, p.cd?, p.cm?)))
                    .collect();
                (label.as_str(), v)
            })
            .collect();
        let all = || conv.iter().flat_map(|(_, v)| v.iter().copied());
        let ra = range(all().map(|p| p.0));
        let rcl = range(all().map(|p| p.1));
        let rcd = range(all().map(|p| p.2));
        let rcd = (rcd.0.max(0.0), rcd.1);
        let rcm = range(all().map(|p| p.3));
        root.fill(&WHITE).map_err(plot_err)?;
        let root = root.titled(&self.title, ("sans-serif", 20)).map_err(plot_err)?;
        let panels = root.split_evenly((1, 3));
        let specs: [Panel; 3] = [
            ("α (°)", "CL", ra, rcl, |p| (p.0, p.1)),
            ("CD", "CL", rcd, rcl, |p| (p.2, p.1)),
            ("α (°)", "CM", ra, rcm, |p| (p.0, p.3)),
        ];
        for (area, (xd, yd, rx, ry, pick)) in panels.iter().zip(specs) {
            let mut chart = ChartBuilder::on(area)
                .margin(12)
                .x_label_area_size(35)
                .y_label_area_size(55)
                .build_cartesian_2d(rx.0..rx.1, ry.0..ry.1)
                .map_err(plot_err)?;
            chart
                .configure_mesh()
                .x_desc(xd)
                .y_desc(yd)
                .light_line_style(RGBColor(235, 235, 235))
                .draw()
                .map_err(plot_err)?;
            for (k, (label, pts)) in conv.iter().enumerate() {
                let colour = PALETTE[k % PALETTE.len()];
                let xy: Vec<(f64, f64)> = pts.iter().map(pick).collect();
                chart
                    .draw_series(LineSeries::new(xy.iter().copied(), colour.stroke_width(2)))
                    .map_err(plot_err)?
                    .label(label.to_string())
                    .legend(move |(x, y)| {
                        PathElement::new(vec![(x, y), (x + 18, y)], colour.stroke_width(2))
                    });
                chart
                    .draw_series(xy.iter().map(|&p| Circle::new(p, 3, colour.filled())))
                    .map_err(plot_err)?;
            }
            if xd == "CD" {
                draw_legend(&mut chart, SeriesLabelPosition::LowerRight)?;
            }
        }
        Ok(())
    }
}
