//! SVG pictures of pressure distributions: Cp against x (suction up, as aerodynamicists draw
//! it) above the shapes that carry them, drawn to equal scales.

use super::svg::{draw_legend, draw_xy_mesh, plot_err};
use crate::aero::{AeroReport, OptimiseResult, PanelSolution, Study};
use crate::error::Result;
use glam::DVec2;
use plotters::prelude::*;

/// One pressure distribution: a label and `(x, Cp)` along the surface in node order.
#[derive(Clone, Debug, PartialEq)]
pub struct CpCurve {
    /// Legend text.
    pub label: String,
    /// `(x, Cp)` at every node.
    pub points: Vec<(f64, f64)>,
}

/// One outline: a label and the contour's nodes.
#[derive(Clone, Debug, PartialEq)]
pub struct Outline {
    /// Legend text.
    pub label: String,
    /// The nodes, in order.
    pub nodes: Vec<DVec2>,
}

/// What to draw: Cp curves in the top panel, outlines below.
#[derive(Clone, Debug, PartialEq)]
pub struct CpPlot {
    /// Title line.
    pub title: String,
    /// The pressure distributions (colours in order).
    pub curves: Vec<CpCurve>,
    /// The shapes (colours in order).
    pub outlines: Vec<Outline>,
}

const WIDTH: u32 = 1000;
const CP_HEIGHT: u32 = 560;

pub(crate) const PALETTE: [RGBColor; 6] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
    RGBColor(255, 127, 14),
    RGBColor(23, 190, 207),
];

impl CpPlot {
    /// The shapes and pressures of an optimisation's start and `result` (and its target's, when
    /// the objective has one) at its angle of attack.
    pub fn of_optimisation(study: &Study, result: &OptimiseResult) -> Result<CpPlot> {
        let alpha = study.setup.alpha;
        let space = &study.problem.space;
        let start = PanelSolution::solve(&space.map().nodes(space.start()))?;
        let end = PanelSolution::solve(&space.map().nodes(&result.design))?;
        let cp = |s: &PanelSolution| -> Vec<(f64, f64)> {
            s.nodes().iter().zip(s.cp(alpha)).map(|(p, c)| (p.x, c)).collect()
        };
        // A viscous objective draws the coupled analysis's pressures at its first operating
        // point (the angle it was solved at, for a design CL), where it converges; the panel
        // method's otherwise, and the labels say which.
        let viscous = |name: &str, delta: &[f64], s: &PanelSolution| -> Option<CpCurve> {
            let p = study.problem.first_viscous_point(delta)?;
            let points = s
                .nodes()
                .iter()
                .zip(p.cp(s.nodes().len()))
                .map(|(q, c)| (q.x, c))
                .collect();
            Some(CpCurve {
                label: format!("{name}: viscous CL {:.4} at α {:.2}°", p.cl, p.alpha),
                points,
            })
        };
        let is_viscous = study.problem.viscous.is_some();
        let curve = |name: &str, delta: &[f64], s: &PanelSolution| {
            let inviscid = |note: &str| CpCurve {
                label: format!("{name}: {note}CL {:.4}", s.coefficients(alpha).cl),
                points: cp(s),
            };
            if !is_viscous {
                return inviscid("");
            }
            viscous(name, delta, s).unwrap_or_else(|| inviscid("viscous unconverged; inviscid "))
        };
        let mut curves = vec![
            curve("start", space.start(), &start),
            curve("result", &result.design, &end),
        ];
        let mut outlines = vec![
            Outline {
                label: format!("start ({})", study.setup.start.display()),
                nodes: start.nodes().to_vec(),
            },
            Outline {
                label: "result".into(),
                nodes: end.nodes().to_vec(),
            },
        ];
        if let Some(t) = &study.target {
            let s = &t.analysis.solution;
            curves.push(CpCurve {
                label: format!("target {}: CL {:.4}", t.path.display(), s.coefficients(alpha).cl),
                points: cp(s),
            });
            outlines.push(Outline {
                label: format!("target ({})", t.path.display()),
                nodes: s.nodes().to_vec(),
            });
        }
        Ok(CpPlot {
            title: match (is_viscous, study.setup.re) {
                (false, _) => format!(
                    "bezchain optimise --objective {} at α = {alpha}°",
                    study.setup.spec
                ),
                (true, Some(re)) => format!(
                    "bezchain optimise --objective {} at Re {re:.1e}: viscous Cp",
                    study.setup.spec
                ),
                (true, None) => format!(
                    "bezchain optimise --objective {}: viscous Cp at its first point",
                    study.setup.spec
                ),
            },
            curves,
            outlines,
        })
    }

    /// Render as an SVG document.
    pub fn to_svg(&self) -> Result<String> {
        let frame = self.frame();
        let mut out = String::new();
        {
            let root = SVGBackend::with_string(&mut out, frame.size()).into_drawing_area();
            self.draw(&root, &frame)?;
            root.present().map_err(plot_err)?;
        }
        Ok(out)
    }

    /// The plot of [`to_svg`](Self::to_svg) as a PNG picture of the same size.
    pub fn to_png(&self) -> Result<Vec<u8>> {
        let frame = self.frame();
        let (w, h) = frame.size();
        super::plot_png(w, h, |root| self.draw(root, &frame))
    }

    /// The ranges and the shape panel's height.
    fn frame(&self) -> Frame {
        let xs = self
            .curves
            .iter()
            .flat_map(|c| c.points.iter().map(|p| p.0))
            .chain(self.outlines.iter().flat_map(|o| o.nodes.iter().map(|p| p.x)));
        let (x0, x1) = xs.fold((f64::MAX, f64::MIN), |(a, b), x| (a.min(x), b.max(x)));
        let (x0, x1) = if x1 > x0 { (x0, x1) } else { (0.0, 1.0) };
        let pad = 0.03 * (x1 - x0);
        let (x0, x1) = (x0 - pad, x1 + pad);
        let (ylo, yhi) = self
            .outlines
            .iter()
            .flat_map(|o| o.nodes.iter())
            .fold((f64::MAX, f64::MIN), |(a, b), p| (a.min(p.y), b.max(p.y)));
        let (ylo, yhi) = if yhi > ylo { (ylo, yhi) } else { (-0.1, 0.1) };
        // The shape panel is as tall as equal scales need (with room for the legend).
        let plot_w = f64::from(WIDTH - 100);
        let shape_h = ((yhi - ylo) / (x1 - x0) * plot_w * 1.6) as u32 + 110;
        let shape_h = shape_h.clamp(180, 600);
        let cps = self.curves.iter().flat_map(|c| c.points.iter().map(|p| p.1));
        let (cmin, cmax) = cps.fold((f64::MAX, f64::MIN), |(a, b), c| (a.min(c), b.max(c)));
        let (cmin, cmax) = if cmax > cmin { (cmin, cmax) } else { (-1.0, 1.0) };
        let cpad = 0.05 * (cmax - cmin);
        Frame {
            x: (x0, x1),
            y: (ylo, yhi),
            cp: (cmin, cmax, cpad),
            plot_w,
            shape_h,
        }
    }

    /// Draw both panels on `root`.
    fn draw<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, plotters::coord::Shift>,
        f: &Frame,
    ) -> Result<()> {
        let Frame {
            x: (x0, x1),
            y: (ylo, yhi),
            cp: (cmin, cmax, cpad),
            plot_w,
            shape_h,
        } = *f;
        root.fill(&WHITE).map_err(plot_err)?;
        let (top, bottom) = root.split_vertically(CP_HEIGHT);
        // Suction up: the axis runs from the largest Cp at the bottom to the smallest on top.
        let mut chart = ChartBuilder::on(&top)
            .caption(&self.title, ("sans-serif", 20))
            .margin(12)
            .x_label_area_size(35)
            .y_label_area_size(60)
            .build_cartesian_2d(x0..x1, (cmax + cpad)..(cmin - cpad))
            .map_err(plot_err)?;
        chart
            .configure_mesh()
            .x_desc("x")
            .y_desc("Cp")
            .light_line_style(RGBColor(235, 235, 235))
            .draw()
            .map_err(plot_err)?;
        for (k, c) in self.curves.iter().enumerate() {
            let colour = PALETTE[k % PALETTE.len()];
            chart
                .draw_series(LineSeries::new(c.points.iter().copied(), colour.stroke_width(2)))
                .map_err(plot_err)?
                .label(c.label.clone())
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], colour.stroke_width(2)));
        }
        draw_legend(&mut chart, SeriesLabelPosition::UpperRight)?;
        // Equal scales below.
        let plot_h = f64::from(shape_h - 80);
        let span = ((x1 - x0) / plot_w).max((yhi - ylo) / plot_h);
        let cy = 0.5 * (ylo + yhi);
        let (y0, y1) = (cy - 0.5 * span * plot_h, cy + 0.5 * span * plot_h);
        let mut shape = ChartBuilder::on(&bottom)
            .margin(12)
            .x_label_area_size(35)
            .y_label_area_size(60)
            .build_cartesian_2d(x0..x0 + span * plot_w, y0..y1)
            .map_err(plot_err)?;
        draw_xy_mesh(&mut shape)?;
        for (k, o) in self.outlines.iter().enumerate() {
            let colour = PALETTE[k % PALETTE.len()];
            let mut pts: Vec<(f64, f64)> = o.nodes.iter().map(|p| (p.x, p.y)).collect();
            if let Some(&first) = pts.first() {
                pts.push(first);
            }
            shape
                .draw_series(LineSeries::new(pts, colour.stroke_width(2)))
                .map_err(plot_err)?
                .label(o.label.clone())
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], colour.stroke_width(2)));
        }
        draw_legend(&mut shape, SeriesLabelPosition::LowerRight)?;
        Ok(())
    }
}

/// The ranges of a [`CpPlot`]: x, the outlines' y, Cp (with its padding), the plot width and
/// the shape panel's height.
#[derive(Clone, Copy)]
struct Frame {
    x: (f64, f64),
    y: (f64, f64),
    cp: (f64, f64, f64),
    plot_w: f64,
    shape_h: u32,
}

impl Frame {
    /// The picture's size in pixels.
    fn size(&self) -> (u32, u32) {
        (WIDTH, CP_HEIGHT + self.shape_h)
    }
}

impl CpPlot {
    /// The picture: Cp against x at every angle above the shape.
    #[must_use]
    pub fn of_report(report: &AeroReport, title: &str) -> CpPlot {
        let nodes: Vec<DVec2> = report.node_points.iter().map(|&p| DVec2::from_array(p)).collect();
        CpPlot {
            title: title.into(),
            curves: report
                .pressure
                .iter()
                .zip(&report.polar)
                .map(|(p, c)| CpCurve {
                    label: format!("α = {}°: CL {:.4}, CM {:.4}", p.alpha, c.cl, c.cm),
                    points: nodes.iter().zip(&p.cp).map(|(n, &cp)| (n.x, cp)).collect(),
                })
                .collect(),
            outlines: vec![Outline {
                label: format!("{} ({} nodes)", report.input.path, report.nodes),
                nodes,
            }],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_plot_holds_every_curve_and_outline() {
        let nodes: Vec<DVec2> = (0..50)
            .map(|k| {
                let a = std::f64::consts::TAU * k as f64 / 49.0;
                DVec2::new(0.5 + 0.5 * a.cos(), 0.06 * a.sin())
            })
            .collect();
        let curve = |label: &str, s: f64| CpCurve {
            label: label.into(),
            points: nodes.iter().map(|p| (p.x, s * (1.0 - 4.0 * p.y.abs()))).collect(),
        };
        let svg = CpPlot {
            title: "test".into(),
            curves: vec![curve("α = 0°", 1.0), curve("α = 4°", -1.0)],
            outlines: vec![Outline {
                label: "shape".into(),
                nodes: nodes.clone(),
            }],
        }
        .to_svg()
        .unwrap();
        assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
        assert!(svg.contains("α = 0°") && svg.contains("α = 4°") && svg.contains("shape"));
    }
}
