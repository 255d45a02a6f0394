//! `Encoding`: exactly the numbers an adapted curve stores, the layout integers beside them,
//! and the regeneration of the expanded control points from them alone.
//!
//! Counted as stored scalars: every design coordinate that is stored (both coordinates of
//! every design point, or only y under the aerofoil rule), the two or three numbers of the
//! aerofoil rule, and every break that is not fixed by the layout integers. Not counted: the layout
//! integers themselves (degree, segment counts, the continuity order of each join), as the
//! peer figures count neither their degree nor their knot counts.

use super::engine::LE_BREAK;
use crate::chain::ChainLayout;
use crate::error::{Error, Result};
use glam::DVec2;
use serde::{Deserialize, Serialize};

/// Where the breaks come from.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Breaks {
    /// `segments` equal segments over `[0, 1]` (no stored numbers).
    Uniform {
        /// Number of segments.
        segments: usize,
    },
    /// The aerofoil rule's halves, `[0, 1/2]` (first surface, trailing edge to leading edge)
    /// and `[1/2, 1]`, each cut into equal segments (no stored numbers).
    UniformPerSide {
        /// Segments on the first half.
        first: usize,
        /// Segments on the second half.
        second: usize,
    },
    /// Stored interior breaks, increasing inside `(0, 1)`; under the aerofoil rule the
    /// leading-edge break `1/2` is implied and not listed.
    Stored(Vec<f64>),
}

/// How the x coordinates are stored.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum XStore {
    /// The x of every design point.
    Free(Vec<f64>),
    /// The aerofoil rule `[x_le, x_te_first, x_te_second]`, or `[x_le, x_te]` when both
    /// surfaces end at the same x: x follows `x_le + (x_te_first - x_le) (1 - 2t)²` on
    /// `[0, 1/2]` and `x_le + (x_te_second - x_le) (2t - 1)²` on `[1/2, 1]`.
    AerofoilRule(Vec<f64>),
}

/// The stored form of an adapted curve.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Encoding {
    /// Degree of every segment (a layout integer).
    pub degree: usize,
    /// Continuity order of every interior break, leading edge included (layout integers).
    pub joins: Vec<usize>,
    /// The breaks.
    pub breaks: Breaks,
    /// The x coordinates.
    pub x: XStore,
    /// The y of every design point (B-spline coefficient).
    pub y: Vec<f64>,
}

/// The stored scalars by kind.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct ScalarCount {
    /// Stored x coordinates.
    pub x: usize,
    /// Stored y coordinates.
    pub y: usize,
    /// Numbers of the aerofoil rule (2 or 3, or 0 without it).
    pub rule: usize,
    /// Stored breaks.
    pub breaks: usize,
    /// The sum: the stored scalars.
    pub total: usize,
}

impl Encoding {
    /// The stored scalars, by kind.
    #[must_use]
    pub fn count(&self) -> ScalarCount {
        let (x, rule) = match &self.x {
            XStore::Free(x) => (x.len(), 0),
            XStore::AerofoilRule(theta) => (0, theta.len()),
        };
        let breaks = match &self.breaks {
            Breaks::Stored(b) => b.len(),
            _ => 0,
        };
        let y = self.y.len();
        ScalarCount {
            x,
            y,
            rule,
            breaks,
            total: x + y + rule + breaks,
        }
    }

    /// The full list of breaks `0 … 1`.
    pub fn break_list(&self) -> Result<Vec<f64>> {
        let aerofoil = matches!(self.x, XStore::AerofoilRule(_));
        let mut b = match &self.breaks {
            Breaks::Uniform { segments } => {
                let s = (*segments).max(1);
                (0..=s).map(|k| k as f64 / s as f64).collect()
            }
            Breaks::UniformPerSide { first, second } => per_side_breaks(*first, *second),
            Breaks::Stored(inner) => {
                let mut b = vec![0.0];
                b.extend(inner.iter().copied());
                if aerofoil {
                    b.push(LE_BREAK);
                }
                b.push(1.0);
                b
            }
        };
        b.sort_by(f64::total_cmp);
        if b.windows(2).any(|w| !(w[1] > w[0])) {
            return Err(Error::invalid("encoding: breaks are not strictly increasing"));
        }
        Ok(b)
    }

    /// The spline layout the encoding describes.
    pub fn layout(&self) -> Result<ChainLayout> {
        ChainLayout::with_orders(self.degree, self.break_list()?, self.joins.clone())
    }

    /// The B-spline coefficients (design points) regenerated from the stored numbers.
    pub fn coeffs(&self) -> Result<Vec<DVec2>> {
        let layout = self.layout()?;
        let n = layout.design_count();
        if self.y.len() != n {
            return Err(Error::invalid(format!(
                "encoding: {} y values for {n} design points",
                self.y.len()
            )));
        }
        let xs: Vec<f64> = match &self.x {
            XStore::Free(x) if x.len() == n => x.clone(),
            XStore::Free(x) => {
                return Err(Error::invalid(format!(
                    "encoding: {} x values for {n} design points",
                    x.len()
                )))
            }
            XStore::AerofoilRule(theta) => {
                if !(2..=3).contains(&theta.len()) {
                    return Err(Error::invalid(format!(
                        "encoding: the aerofoil rule has 2 or 3 numbers, not {}",
                        theta.len()
                    )));
                }
                let model = super::engine::Model::aerofoil(layout.clone(), theta.len() == 2)?;
                let z = model.unknowns_of(&vec![DVec2::ZERO; n], Some(theta));
                model.coeffs(&z).iter().map(|p| p.x).collect()
            }
        };
        Ok(xs
            .into_iter()
            .zip(&self.y)
            .map(|(x, &y)| DVec2::new(x, y))
            .collect())
    }

    /// The expanded Bezier control points (`s d + 1`), from the stored numbers alone.
    pub fn control_points(&self) -> Result<Vec<DVec2>> {
        Ok(self.layout()?.bezier(&self.coeffs()?))
    }
}

/// Breaks of `first` equal segments on `[0, 1/2]` and `second` on `[1/2, 1]`.
pub(crate) fn per_side_breaks(first: usize, second: usize) -> Vec<f64> {
    let (a, b) = (first.max(1), second.max(1));
    let mut v: Vec<f64> = (0..a).map(|k| LE_BREAK * k as f64 / a as f64).collect();
    v.extend((0..b).map(|k| LE_BREAK + (1.0 - LE_BREAK) * k as f64 / b as f64));
    v.push(1.0);
    v
}
