//! The frame a population method sees a fitting problem in: the design coordinates measured
//! from the centre of the search box, so f32 populations resolve a shape as finely wherever
//! its data sit.

/// The frame the evolutionary methods see a fitting problem in: its variables are the flat
/// design coordinates less [`origin`](Self::origin), the centre of the bounds' box. An f32
/// coordinate 1000 chords from the origin is good to 6e-5 chords only; measured from the
/// centre, to about 2⁻²⁴ of the box wherever the data sit.
#[derive(Clone, Debug, PartialEq)]
pub struct Frame {
    origin: Vec<f64>,
    start: Vec<f64>,
    bounds: Vec<[f64; 2]>,
}

impl Frame {
    /// The frame of a flat `start` inside the flat `bounds` (the same box repeated for every
    /// design point) of points with `dim` coordinates; without bounds it is not moved.
    pub(crate) fn new(start: &[f64], bounds: &[[f64; 2]], dim: usize) -> Self {
        let origin: Vec<f64> = match bounds.get(..dim) {
            Some(b) => b.iter().map(|[lo, hi]| 0.5 * (lo + hi)).collect(),
            None => vec![0.0; dim],
        };
        let start = start
            .iter()
            .enumerate()
            .map(|(k, x)| x - origin[k % dim])
            .collect();
        let bounds = bounds
            .iter()
            .enumerate()
            .map(|(k, [lo, hi])| [lo - origin[k % dim], hi - origin[k % dim]])
            .collect();
        Frame {
            origin,
            start,
            bounds,
        }
    }

    /// The start, flat, in the frame.
    #[must_use]
    pub fn start(&self) -> &[f64] {
        &self.start
    }

    /// The bounds, flat, in the frame.
    #[must_use]
    pub fn bounds(&self) -> &[[f64; 2]] {
        &self.bounds
    }

    /// The centre, one value per coordinate.
    #[must_use]
    pub fn origin(&self) -> &[f64] {
        &self.origin
    }

    /// `x` (flat, in the frame) in model coordinates.
    #[must_use]
    pub fn absolute(&self, x: &[f64]) -> Vec<f64> {
        let dim = self.origin.len();
        x.iter()
            .enumerate()
            .map(|(k, v)| v + self.origin[k % dim])
            .collect()
    }
}
