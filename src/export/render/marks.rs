//! The rings a coloured picture draws around its marked points (the worst offsets) and its
//! remarks (a section end that doubles back), and where their labels go.

use super::{Camera, Canvas, Marked, Remark, BACKGROUND};
use glam::DVec3;

/// How a ring is drawn: solid for the worst point, dashed for the largest offset in data
/// units, dotted for a remark ([`Remark`]).
#[derive(Clone, Copy, PartialEq, Eq)]
pub(super) enum Ring {
    Solid,
    Dashed,
    Dotted,
}

impl Ring {
    pub(super) fn of(m: &Marked) -> Ring {
        if m.primary {
            Ring::Solid
        } else {
            Ring::Dashed
        }
    }

    /// Whether the arc at angle `a` is left out.
    fn gap(self, a: f64) -> bool {
        let pi = std::f64::consts::PI;
        match self {
            Ring::Solid => false,
            Ring::Dashed => (a / (pi / 8.0)) as usize % 2 == 1,
            Ring::Dotted => !((a / (pi / 24.0)) as usize).is_multiple_of(3),
        }
    }

    /// The SVG group's class.
    pub(super) fn class(self) -> &'static str {
        match self {
            Ring::Solid => "worst-point",
            Ring::Dashed => "largest-offset",
            Ring::Dotted => "section-end",
        }
    }

    /// The SVG stroke's width and dash pattern.
    pub(super) fn svg(self) -> (f64, &'static str) {
        match self {
            Ring::Solid => (1.4, ""),
            Ring::Dashed => (0.9, r#" stroke-dasharray="3,3""#),
            Ring::Dotted => (1.4, r#" stroke-dasharray="1,3""#),
        }
    }
}

/// A ring around a marked point, black with a white halo ([`Ring`]); half as opaque where the
/// surface hides the point.
pub(super) fn draw_ring(
    canvas: &mut Canvas,
    at: (f64, f64),
    radius: f64,
    scale: f64,
    ring: Ring,
    hidden: bool,
) {
    let alpha = if hidden { 0.5 } else { 1.0 };
    let steps = (2.0 * std::f64::consts::PI * radius * 2.0).ceil().max(16.0) as usize;
    let (halo, line) = if ring == Ring::Dashed {
        (0.9 * scale, 0.4 * scale)
    } else {
        (1.4 * scale, 0.7 * scale)
    };
    for (width, colour) in [(halo, BACKGROUND), (line, [0, 0, 0])] {
        for s in 0..steps {
            let a = 2.0 * std::f64::consts::PI * s as f64 / steps as f64;
            if ring.gap(a) {
                continue;
            }
            let (x, y) = (at.0 + radius * a.cos(), at.1 + radius * a.sin());
            let r = width.ceil() as i64;
            for dy in -r..=r {
                for dx in -r..=r {
                    let (px, py) = (x.round() as i64 + dx, y.round() as i64 + dy);
                    let d = ((px as f64 - x).powi(2) + (py as f64 - y).powi(2)).sqrt();
                    if d <= width {
                        canvas.blend(px, py, colour, alpha);
                    }
                }
            }
        }
    }
}

/// A ring to draw with its label: a marked point's ([`Marked`]) or a remark's ([`Remark`]).
pub(super) struct Mark {
    pub(super) at: DVec3,
    pub(super) ring: Ring,
    pub(super) radius: f64,
    text: String,
}

impl Mark {
    fn of(m: &Marked, relative: bool, radius: f64) -> Mark {
        Mark {
            at: m.position,
            ring: Ring::of(m),
            radius,
            text: m.label(relative),
        }
    }

    fn remark(r: &Remark, radius: f64) -> Mark {
        Mark {
            at: r.position,
            ring: Ring::Dotted,
            radius: REMARK_RING * radius,
            text: r.label.clone(),
        }
    }

    /// The label, noting when the surface hides the point in this view.
    pub(super) fn label(&self, hidden: bool) -> String {
        if hidden {
            format!("{} (far side)", self.text)
        } else {
            self.text.clone()
        }
    }
}

/// The top-left corner of a label beside a ring at `p` of `radius`: right of it, or left of it
/// when that runs out of the panel, kept in the panel, and below the labels `placed` before it
/// (their boxes) when it would overlap one.
pub(super) fn place_label(
    p: (f64, f64, f64),
    radius: f64,
    text: &str,
    scale: f64,
    panel: (f64, f64, f64, f64),
    placed: &mut Vec<(f64, f64, f64, f64)>,
) -> (f64, f64) {
    let (px, py, pw, ph) = panel;
    let (bw, bh) = (text.chars().count() as f64 * 6.0 * scale, 10.0 * scale);
    let gap = radius + 2.0 * scale;
    let (mut x, mut y) = (p.0 + gap, p.1 - 3.5 * scale);
    if x + bw > px + pw {
        x = p.0 - gap - bw;
    }
    if x < px {
        // Neither side has room: centred under the ring (over it near the panel's bottom).
        x = p.0 - 0.5 * bw;
        y = if p.1 + gap + bh < py + ph {
            p.1 + gap
        } else {
            p.1 - gap - bh
        };
    }
    x = x.clamp(px + scale, (px + pw - bw - scale).max(px + scale));
    y = y.clamp(py + scale, (py + ph - bh).max(py + scale));
    while placed
        .iter()
        .any(|&(ox, oy, ow, oh)| x < ox + ow && ox < x + bw && y < oy + oh && oy < y + bh)
    {
        y += bh;
    }
    placed.push((x, y, bw, bh));
    (x, y)
}

/// The rings of a picture: around the colouring's marked points (`radius`, `relative` as
/// [`Marked::label`] takes it), then around the remarks ([`REMARK_RING`] times larger).
pub(super) fn marks(marked: &[Marked], relative: bool, remarks: &[Remark], radius: f64) -> Vec<Mark> {
    marked
        .iter()
        .map(|m| Mark::of(m, relative, radius))
        .chain(remarks.iter().map(|r| Mark::remark(r, radius)))
        .collect()
}

/// The boxes of the rings `marks` in `cam`'s view, which labels keep clear of.
pub(super) fn ring_boxes(cam: &Camera, marks: &[Mark]) -> Vec<(f64, f64, f64, f64)> {
    marks
        .iter()
        .map(|m| {
            let p = cam.project(m.at);
            (p.0 - m.radius, p.1 - m.radius, 2.0 * m.radius, 2.0 * m.radius)
        })
        .collect()
}

/// A remark's ring's radius over a marked point's.
const REMARK_RING: f64 = 1.6;
