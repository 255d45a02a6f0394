//! What the surface pictures colour by, and how they say it: the colour map, the quantity
//! (offset relative to the local chord, or in data units), its colour bar's two scales, the
//! worst points, the stations and the captions. [`render`](super::render) draws it all, in the
//! PNG and in the SVG alike.
//!
//! **The quantity.** A blade engineer asks where the surface is worst relative to the shape it
//! should follow: a millimetre is nothing on a 5 m root section and a lot on a 0.3 m tip. So
//! when the cloud has sections, the colour is each point's offset divided by its *local chord*
//! (the chord of the point's section, [`Grid::chords`], the measure whose largest `--relative`
//! tolerances are fractions of). The colour bar's left scale reads that in % of the local
//! chord; its right scale reads the same colours in data units *at the largest chord*, labelled
//! as such, since that is the only chord at which one colour is one offset in data units (and
//! it is the scale of a `--relative` tolerance). A section whose chord is below
//! [`CHORD_FLOOR`] of the largest (a tip closing to a point) is related to that floor instead:
//! no shape is left there to scale by. Two points are ringed: the worst relative to its local
//! chord, and, when it is another point, the largest offset in data units (the one the report's
//! maximum names), each labelled with its offset, its % of local chord and its section. Without
//! sections (an unordered cloud) no chord is known: the colour is the offset in data units, the
//! bar has that one scale, and the caption says why.
//!
//! **The colour map** is viridis (perceptually uniform, readable by the colour-blind), from its
//! published colours at eleven even steps, linearly interpolated; it runs *reversed*, light
//! yellow for 0 to dark purple for the worst, so that the shading of a mostly good surface
//! reads, and its lightness falls steadily, so that a grey print still orders the colours.

use crate::geometry::Grid;
use glam::DVec3;

/// An RGB colour.
pub type Rgb = [u8; 3];

/// The local chord below which a section is related to this fraction of the largest chord.
pub const CHORD_FLOOR: f64 = 0.05;

/// Viridis at 0, 0.1, ..., 1 (dark purple to yellow), the published control colours.
const VIRIDIS: [[f32; 3]; 11] = [
    [68.0, 1.0, 84.0],
    [72.0, 36.0, 117.0],
    [65.0, 68.0, 135.0],
    [53.0, 95.0, 141.0],
    [42.0, 120.0, 142.0],
    [33.0, 145.0, 140.0],
    [34.0, 168.0, 132.0],
    [68.0, 191.0, 112.0],
    [122.0, 209.0, 81.0],
    [189.0, 223.0, 38.0],
    [253.0, 231.0, 37.0],
];

/// The colour of `t ∈ [0, 1]` (0 the best, 1 the worst): reversed viridis, light yellow for
/// 0, dark purple for 1, its lightness falling all the way (a grey print keeps the order).
#[must_use]
pub fn offset_colour(t: f64) -> Rgb {
    map_exact(t).map(|c| c.round() as u8)
}

/// [`offset_colour`] before rounding to 8 bits: 0 to 255 a channel.
fn map_exact(t: f64) -> [f64; 3] {
    let t = if t.is_finite() { t.clamp(0.0, 1.0) } else { 0.0 };
    let x = (1.0 - t) * (VIRIDIS.len() - 1) as f64;
    let k = (x.floor() as usize).min(VIRIDIS.len() - 2);
    let f = x - k as f64;
    let (a, b) = (VIRIDIS[k], VIRIDIS[k + 1]);
    [0, 1, 2].map(|c| f64::from(a[c]) + f64::from(b[c] - a[c]) * f)
}

/// CIE L* (0 black to 100 white) of an sRGB colour: the lightness a grey print shows.
#[must_use]
pub fn lightness(c: Rgb) -> f64 {
    lightness_of(c.map(f64::from))
}

/// [`lightness`] of channels 0 to 255, not rounded.
fn lightness_of(c: [f64; 3]) -> f64 {
    let lin = |v: f64| {
        let v = v / 255.0;
        if v <= 0.040_45 {
            v / 12.92
        } else {
            ((v + 0.055) / 1.055).powf(2.4)
        }
    };
    let y = 0.2126 * lin(c[0]) + 0.7152 * lin(c[1]) + 0.0722 * lin(c[2]);
    if y > 216.0 / 24389.0 {
        116.0 * y.cbrt() - 16.0
    } else {
        y * 24389.0 / 27.0
    }
}

/// A data point the picture colours by: its closest-point parameters on the surface, its
/// offset (model units), where it is, and the index of its section when the cloud has them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OffsetPoint {
    /// Closest-point parameters `(u, v)` on the surface.
    pub uv: [f64; 2],
    /// Distance to the surface, model units.
    pub offset: f64,
    /// The data point.
    pub position: DVec3,
    /// Its section (0-based, the cloud's order), `None` in an unordered cloud.
    pub section: Option<usize>,
}

/// A data section: its points in order, drawn as a line across the surface, and its chord.
#[derive(Clone, Debug, PartialEq)]
pub struct Station {
    /// The section's points, in the cloud's order.
    pub points: Vec<DVec3>,
    /// Its chord ([`Grid::chords`]).
    pub chord: f64,
}

/// The stations of a sectioned cloud (section-major, `grid`'s shape).
#[must_use]
pub fn stations(points: &[DVec3], grid: Grid) -> Vec<Station> {
    grid.chords(points)
        .into_iter()
        .zip(points.chunks(grid.per_section.max(1)))
        .map(|(chord, s)| Station {
            points: s.to_vec(),
            chord,
        })
        .collect()
}

/// A point the picture rings for a reason of its own, not an offset (a section's end that
/// doubles back, [`crate::adaptive::surface::SectionEnds`]): where, and the label beside it.
#[derive(Clone, Debug, PartialEq)]
pub struct Remark {
    /// The point, model units.
    pub position: DVec3,
    /// The label beside its ring.
    pub label: String,
}

/// A ringed point: which data point, its offset, its % of local chord (when known), its
/// section, and whether it is the worst relative to its local chord or in data units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Marked {
    /// Index into the offsets.
    pub index: usize,
    /// The data point.
    pub position: DVec3,
    /// Its offset, model units.
    pub offset: f64,
    /// Its offset in % of its local chord, when the cloud has sections.
    pub percent: Option<f64>,
    /// Its section.
    pub section: Option<usize>,
    /// True for the worst relative to the local chord (or the only worst without sections).
    pub primary: bool,
}

impl Marked {
    /// The label beside its ring: `worst 0.150% c: 6.80e-3, section 3` (relative) or
    /// `max 7.20e-3 (0.050% c), section 12` (data units).
    #[must_use]
    pub fn label(&self, relative: bool) -> String {
        let section = self.section.map_or(String::new(), |s| format!(", section {s}"));
        match (relative && self.primary, self.percent) {
            (true, Some(p)) => format!(
                "worst {} of local chord: {}{section}",
                percent_label(p),
                offset_label(self.offset)
            ),
            (_, Some(p)) => format!(
                "max {} ({} of local chord){section}",
                offset_label(self.offset),
                percent_label(p)
            ),
            (_, None) => format!("max {}{section}", offset_label(self.offset)),
        }
    }
}

/// The colouring of a picture: a value per data point, mapped from 0 to `largest`.
#[derive(Clone, Debug, PartialEq)]
pub struct Colouring {
    /// Per data point: offset / local chord when `relative`, else the offset (model units).
    pub values: Vec<f64>,
    /// True when the values are relative to the local chord.
    pub relative: bool,
    /// The largest value: the top of the colour bar.
    pub largest: f64,
    /// The largest chord (the right scale's reference), 0 without sections.
    pub reference: f64,
    /// The ringed points, the primary one first.
    pub marked: Vec<Marked>,
}

impl Colouring {
    /// The colouring of `offsets` on `stations` (relative when every point has a station with
    /// a positive largest chord), `None` without offsets.
    #[must_use]
    pub fn new(offsets: &[OffsetPoint], stations: &[Station]) -> Option<Colouring> {
        if offsets.is_empty() {
            return None;
        }
        let reference = stations.iter().map(|s| s.chord).fold(0.0, f64::max);
        let chord_of = |p: &OffsetPoint| {
            p.section
                .and_then(|s| stations.get(s))
                .map(|s| s.chord.max(CHORD_FLOOR * reference))
        };
        let relative = reference > 0.0
            && reference.is_finite()
            && offsets.iter().all(|p| chord_of(p).is_some_and(|c| c > 0.0));
        let values: Vec<f64> = offsets
            .iter()
            .map(|p| match (relative, chord_of(p)) {
                (true, Some(c)) => p.offset / c,
                _ => p.offset,
            })
            .collect();
        let argmax = |v: &dyn Fn(usize) -> f64| {
            (0..offsets.len())
                .filter(|&k| v(k).is_finite())
                .max_by(|&a, &b| v(a).total_cmp(&v(b)))
        };
        let worst = argmax(&|k| values[k]);
        let largest = worst.map_or(0.0, |k| values[k].max(0.0));
        let mark = |k: usize, primary: bool| Marked {
            index: k,
            position: offsets[k].position,
            offset: offsets[k].offset,
            percent: chord_of(&offsets[k])
                .filter(|_| relative)
                .map(|c| 100.0 * offsets[k].offset / c),
            section: offsets[k].section,
            primary,
        };
        let mut marked: Vec<Marked> = worst.map(|k| mark(k, true)).into_iter().collect();
        if relative {
            if let Some(k) = argmax(&|k| offsets[k].offset).filter(|&k| Some(k) != worst) {
                marked.push(mark(k, false));
            }
        }
        Some(Colouring {
            values,
            relative,
            largest,
            reference: if relative { reference } else { 0.0 },
            marked,
        })
    }

    /// Where `value` sits on the colour map and the bar, 0 to 1: the square root of its
    /// fraction of the largest, so that values well below the worst (a tip many times worse
    /// than the rest) still show in colour; the bar's ticks are labelled accordingly.
    #[must_use]
    pub fn position(&self, value: f64) -> f64 {
        if self.largest > 0.0 && value > 0.0 {
            (value / self.largest).min(1.0).sqrt()
        } else {
            0.0
        }
    }

    /// The colour bar's ticks from the bottom, evenly spaced along the bar (at 0, 1/4, ...,
    /// 1 of its height, so at 0, 1/16, 1/4, 9/16 and all of the largest value): the left
    /// label (% of local chord, relative colourings only) and the right one (data units; at
    /// the largest chord for a relative colouring).
    #[must_use]
    pub fn ticks(&self) -> Vec<(Option<String>, String)> {
        (0..=4)
            .map(|q| {
                let v = self.largest * (f64::from(q) / 4.0).powi(2);
                if self.relative {
                    (Some(percent_label(100.0 * v)), offset_label(v * self.reference))
                } else {
                    (None, offset_label(v))
                }
            })
            .collect()
    }

    /// The bar's title above it.
    #[must_use]
    pub fn title(&self) -> &'static str {
        if self.relative {
            "offset / local chord"
        } else {
            "offset"
        }
    }

    /// The caption under the picture: what the colour, the bar's scales, the rings and the
    /// station lines mean, one line each.
    #[must_use]
    pub fn caption(&self, stations: bool) -> Vec<String> {
        let mut lines = Vec::new();
        if self.relative {
            lines.push(
                "colour: offset of each data point / local chord (its section's chord), square-root \
                 scale; light = best, dark = worst"
                    .to_string(),
            );
            lines.push(format!(
                "bar: left % of local chord; right the same in data units at the largest chord \
                 {}",
                offset_label(self.reference)
            ));
        } else {
            lines.push(
                "colour: offset of each data point, data units, square-root scale; light = best, \
                 dark = worst (no sections, so no local chord)"
                    .to_string(),
            );
        }
        let mut rings = String::from("ring: the worst point");
        if self.marked.len() > 1 {
            rings.push_str(" (thin ring: the largest offset in data units)");
        }
        if stations {
            rings.push_str("; lines: the data's stations (sections)");
        }
        lines.push(rings);
        lines
    }
}

/// A label for an offset: three significant digits, exponent form (`1.23e-3`, `4.50e0`).
#[must_use]
pub fn offset_label(x: f64) -> String {
    if x == 0.0 {
        return "0".into();
    }
    let s = format!("{x:.2e}");
    match s.split_once('e') {
        Some((m, e)) => format!("{m}e{}", e.parse::<i32>().unwrap_or(0)),
        None => s,
    }
}

/// A label for a percentage: three significant digits (`0.150%`, `12.3%`), `0%` for zero.
#[must_use]
pub fn percent_label(p: f64) -> String {
    if p == 0.0 || !p.is_finite() {
        return "0%".into();
    }
    let digits = (2 - p.abs().log10().floor() as i32).clamp(0, 8) as usize;
    format!("{p:.digits$}%")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_map_is_viridis_reversed_and_its_lightness_falls() {
        assert_eq!(offset_colour(0.0), [253, 231, 37]);
        assert_eq!(offset_colour(1.0), [68, 1, 84]);
        assert_eq!(offset_colour(0.5), [33, 145, 140]);
        assert_eq!(offset_colour(f64::NAN), offset_colour(0.0));
        // Readable in grey: the map's lightness falls strictly from best to worst; rounded to
        // 8 bits a channel it may rise by a rounding step (under 0.15 L*), no more.
        let exact: Vec<f64> = (0..=1000)
            .map(|i| lightness_of(map_exact(f64::from(i) / 1000.0)))
            .collect();
        assert!(exact.windows(2).all(|w| w[1] < w[0]), "lightness is monotone");
        let l: Vec<f64> = (0..=1000)
            .map(|i| lightness(offset_colour(f64::from(i) / 1000.0)))
            .collect();
        assert!(l.windows(2).all(|w| w[1] < w[0] + 0.15), "and stays so in 8 bits");
        let stops: Vec<f64> = (0..=10)
            .map(|i| lightness(offset_colour(f64::from(i) / 10.0)))
            .collect();
        assert!(stops.windows(2).all(|w| w[0] - w[1] > 3.0), "{stops:?}");
        assert!(l[0] > 85.0 && l[1000] < 20.0, "{} .. {}", l[0], l[1000]);
    }

    #[test]
    fn the_colour_is_relative_to_the_local_chord_with_both_scales() {
        // Two sections: chord 2 (offsets 0.02) and chord 0.5 (offsets 0.01): the second is
        // worse relative to its chord (2 % against 1 %), the first in data units.
        let grid = Grid {
            sections: 2,
            per_section: 3,
        };
        let points = [
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(2.0, 0.0, 0.0),
            DVec3::new(1.0, 0.1, 0.0),
            DVec3::new(0.0, 0.0, 1.0),
            DVec3::new(0.5, 0.0, 1.0),
            DVec3::new(0.25, 0.05, 1.0),
        ];
        let st = stations(&points, grid);
        assert_eq!(st.iter().map(|s| s.chord).collect::<Vec<_>>(), [2.0, 0.5]);
        let offsets: Vec<OffsetPoint> = points
            .iter()
            .enumerate()
            .map(|(k, &p)| OffsetPoint {
                uv: [0.0, 0.0],
                offset: if k == 1 {
                    0.02
                } else if k == 4 {
                    0.01
                } else {
                    0.001
                },
                position: p,
                section: Some(k / 3),
            })
            .collect();
        let c = Colouring::new(&offsets, &st).unwrap();
        assert!(c.relative);
        assert!((c.largest - 0.02).abs() < 1e-15);
        assert_eq!(c.reference, 2.0);
        assert_eq!((c.marked[0].index, c.marked[1].index), (4, 1));
        assert_eq!(
            c.marked[0].label(true),
            "worst 2.00% of local chord: 1.00e-2, section 1"
        );
        assert_eq!(
            c.marked[1].label(true),
            "max 2.00e-2 (1.00% of local chord), section 0"
        );
        let ticks = c.ticks();
        assert_eq!(ticks[4], (Some("2.00%".into()), "4.00e-2".into()));
        assert_eq!(ticks[0], (Some("0%".into()), "0".into()));
        // A square-root scale: the middle of the bar is a quarter of the largest.
        assert_eq!(ticks[2], (Some("0.500%".into()), "1.00e-2".into()));
        assert!((c.position(0.005) - 0.5).abs() < 1e-12 && c.position(1.0) == 1.0);
        // A tip closed to a point is related to the floor, not to zero.
        let mut tip = points;
        for p in &mut tip[3..] {
            *p = DVec3::new(0.0, 0.0, 1.0);
        }
        let c = Colouring::new(&offsets, &stations(&tip, grid)).unwrap();
        assert!((c.values[4] - 0.01 / (CHORD_FLOOR * 2.0)).abs() < 1e-12);
        // Without sections: data units, one scale, one ring.
        let loose: Vec<OffsetPoint> = offsets
            .iter()
            .map(|&p| OffsetPoint { section: None, ..p })
            .collect();
        let c = Colouring::new(&loose, &[]).unwrap();
        assert!(!c.relative && c.marked.len() == 1 && c.marked[0].index == 1);
        assert_eq!(c.ticks()[4], (None, "2.00e-2".into()));
        assert_eq!(c.marked[0].label(false), "max 2.00e-2");
        assert!(Colouring::new(&[], &st).is_none());
    }

    #[test]
    fn labels() {
        assert_eq!(offset_label(1.234e-3), "1.23e-3");
        assert_eq!(offset_label(0.0), "0");
        assert_eq!(offset_label(4.5), "4.50e0");
        assert_eq!(offset_label(12345.0), "1.23e4");
        assert_eq!(percent_label(0.15), "0.150%");
        assert_eq!(percent_label(12.34), "12.3%");
        assert_eq!(percent_label(0.0), "0%");
    }
}
