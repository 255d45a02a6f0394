//! `ChainLayout`: degree, breaks and continuity of a chain, and its extraction map.

use super::map::ExtractionMap;
use crate::error::{Error, Result};
use serde::{Deserialize, Serialize};
use std::fmt;
use std::str::FromStr;

/// Continuity across the joins of a chain.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Continuity {
    /// Position only: joins are shared points.
    C0,
    /// Tangent (first derivative with respect to the global parameter).
    C1,
    /// Curvature (second derivative); needs degree 3 or more.
    C2,
}

impl Continuity {
    /// The order `k` of `Ck`.
    #[must_use]
    pub fn order(self) -> usize {
        match self {
            Continuity::C0 => 0,
            Continuity::C1 => 1,
            Continuity::C2 => 2,
        }
    }
}

impl fmt::Display for Continuity {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "C{}", self.order())
    }
}

impl FromStr for Continuity {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        match s.to_ascii_lowercase().as_str() {
            "c0" => Ok(Continuity::C0),
            "c1" => Ok(Continuity::C1),
            "c2" => Ok(Continuity::C2),
            _ => Err(Error::invalid(format!(
                "unknown continuity '{s}' (expected c0, c1 or c2)"
            ))),
        }
    }
}

/// The shape of a chain: degree `d`, `s` segments over breaks `0 = t0 < ... < ts = 1`, and
/// continuity `Ck` at the joins, with its extraction map built once.
#[derive(Clone, Debug, PartialEq)]
pub struct ChainLayout {
    degree: usize,
    breaks: Vec<f64>,
    continuity: Continuity,
    map: ExtractionMap,
}

impl ChainLayout {
    /// A layout with `segments` equal segments.
    pub fn uniform(degree: usize, segments: usize, continuity: Continuity) -> Result<Self> {
        if segments == 0 {
            return Err(Error::invalid("segments must be at least 1"));
        }
        let breaks = (0..=segments).map(|k| k as f64 / segments as f64).collect();
        Self::with_breaks(degree, breaks, continuity)
    }

    /// A layout with the given breaks: strictly increasing, from 0 to 1, at least two.
    pub fn with_breaks(degree: usize, breaks: Vec<f64>, continuity: Continuity) -> Result<Self> {
        if degree == 0 {
            return Err(Error::invalid("degree must be at least 1"));
        }
        if degree > 16 {
            return Err(Error::invalid(format!(
                "degree {degree} is above the supported maximum of 16"
            )));
        }
        if continuity.order() >= degree {
            return Err(Error::invalid(format!(
                "{continuity} continuity needs degree {} or more (got {degree})",
                continuity.order() + 1
            )));
        }
        if breaks.len() < 2 {
            return Err(Error::invalid("a chain needs at least two breaks (one segment)"));
        }
        if breaks.iter().any(|b| !b.is_finite()) {
            return Err(Error::invalid("breaks must be finite numbers"));
        }
        if breaks[0] != 0.0 || *breaks.last().unwrap_or(&0.0) != 1.0 {
            return Err(Error::invalid("breaks must start at 0 and end at 1"));
        }
        if breaks.windows(2).any(|w| w[1] <= w[0]) {
            return Err(Error::invalid("breaks must be strictly increasing"));
        }
        let map = ExtractionMap::for_chain(degree, &breaks, continuity);
        Ok(ChainLayout {
            degree,
            breaks,
            continuity,
            map,
        })
    }

    /// Polynomial degree of every segment.
    #[must_use]
    pub fn degree(&self) -> usize {
        self.degree
    }

    /// Number of segments `s`.
    #[must_use]
    pub fn segments(&self) -> usize {
        self.breaks.len() - 1
    }

    /// The breaks `t0 = 0 < ... < ts = 1`.
    #[must_use]
    pub fn breaks(&self) -> &[f64] {
        &self.breaks
    }

    /// Continuity at the joins.
    #[must_use]
    pub fn continuity(&self) -> Continuity {
        self.continuity
    }

    /// The extraction map `expanded = E · design`.
    #[must_use]
    pub fn map(&self) -> &ExtractionMap {
        &self.map
    }

    /// Number of design points (the optimisation variables, per coordinate).
    #[must_use]
    pub fn design_count(&self) -> usize {
        self.map.cols()
    }

    /// Number of expanded Bezier control points, `s * d + 1`.
    #[must_use]
    pub fn expanded_count(&self) -> usize {
        self.segments() * self.degree + 1
    }

    /// Length `h[k] = t[k+1] - t[k]` of segment `k`.
    #[must_use]
    pub fn segment_length(&self, k: usize) -> f64 {
        self.breaks[k + 1] - self.breaks[k]
    }

    /// The segment holding global parameter `t` (clamped to `[0, 1]`) and the local parameter in it.
    #[must_use]
    pub fn locate(&self, t: f64) -> (usize, f64) {
        let t = t.clamp(0.0, 1.0);
        let s = self.segments();
        // partition_point gives the first break > t; the segment is the one before it.
        let k = self.breaks[1..s].partition_point(|&b| b <= t);
        let u = (t - self.breaks[k]) / self.segment_length(k);
        (k, u.clamp(0.0, 1.0))
    }

    /// The global parameter of local parameter `u` in segment `k`.
    #[must_use]
    pub fn global(&self, k: usize, u: f64) -> f64 {
        self.breaks[k] + u * self.segment_length(k)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_papers_counts() {
        for &(d, s, design, expanded) in &[(3, 5, 12, 16), (4, 3, 11, 13), (5, 3, 14, 16)] {
            let l = ChainLayout::uniform(d, s, Continuity::C1).unwrap();
            assert_eq!(
                (l.design_count(), l.expanded_count()),
                (design, expanded),
                "d={d} s={s}"
            );
        }
    }

    #[test]
    fn counts_for_every_continuity() {
        for d in 1..7 {
            for s in 1..6 {
                let c0 = ChainLayout::uniform(d, s, Continuity::C0).unwrap();
                assert_eq!(c0.design_count(), s * d + 1);
                if d >= 2 {
                    assert_eq!(
                        ChainLayout::uniform(d, s, Continuity::C1).unwrap().design_count(),
                        s * (d - 1) + 2
                    );
                }
                if d >= 3 {
                    assert_eq!(
                        ChainLayout::uniform(d, s, Continuity::C2).unwrap().design_count(),
                        s * (d - 2) + 3
                    );
                }
            }
        }
    }

    #[test]
    fn bad_layouts_are_refused() {
        assert!(ChainLayout::uniform(0, 3, Continuity::C0).is_err());
        assert!(ChainLayout::uniform(3, 0, Continuity::C1).is_err());
        assert!(ChainLayout::uniform(1, 3, Continuity::C1).is_err());
        assert!(ChainLayout::uniform(2, 3, Continuity::C2).is_err());
        assert!(ChainLayout::with_breaks(3, vec![0.0, 0.5, 0.5, 1.0], Continuity::C1).is_err());
        assert!(ChainLayout::with_breaks(3, vec![0.0, 0.5, 0.9], Continuity::C1).is_err());
        assert!(ChainLayout::with_breaks(3, vec![0.0, f64::NAN, 1.0], Continuity::C1).is_err());
    }

    #[test]
    fn locate_and_global_are_inverse() {
        let l = ChainLayout::with_breaks(3, vec![0.0, 0.1, 0.45, 1.0], Continuity::C1).unwrap();
        for i in 0..=100 {
            let t = i as f64 / 100.0;
            let (k, u) = l.locate(t);
            assert!((l.global(k, u) - t).abs() < 1e-15);
        }
        assert_eq!(l.locate(0.1), (1, 0.0));
        assert_eq!(l.locate(1.0), (2, 1.0));
        assert_eq!(l.locate(-3.0), (0, 0.0));
    }
}
