//! What an adapted patch grid stores: its layout integers, breaks and design numbers, how
//! they are counted, and the grid regenerated from them.

use super::super::blade::Chordwise;
use super::super::encoding::Breaks;
use super::SpanRule;
use crate::chain::{ChainLayout, GridLayout, PatchGrid};
use crate::error::{Error, Result};
use glam::DVec3;
use serde::{Deserialize, Serialize};

/// Exactly the numbers an adapted patch grid stores, and the layout integers.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SurfaceEncoding {
    /// Degrees `[du, dv]`.
    pub degree: [usize; 2],
    /// Continuity order of every interior join around the sections.
    pub joins_u: Vec<usize>,
    /// Continuity order of every interior join along the span.
    pub joins_v: Vec<usize>,
    /// Breaks around the sections.
    pub breaks_u: Breaks,
    /// Breaks along the span.
    pub breaks_v: Breaks,
    /// The span rule, when used.
    pub span_rule: Option<SpanRule>,
    /// The chord rule (`adaptive::blade`), when used (it needs the span rule).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub chord_rule: bool,
    /// The chord rule's trailing-edge term (degree 4 or more around): every column frame
    /// stores a fifth number, the weight `b_j` of `W(u) = t² (1 - t²)` in its chordwise law.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub te_term: bool,
    /// The stored numbers of the design net. Without the chord rule: row-major (rows along
    /// u), for every design point its coordinates in axis order, the span rule's axis left
    /// out when it is used. With it: for every design column `j` its frame `[O_j, θ_j, c_j]`
    /// (the leading edge in the two axes besides the span axis, in axis order, the chord
    /// angle in radians in that plane and the chord length), then the thickness-direction
    /// offset `y_ij` of every design point, row-major; design point `(i, j)` is
    /// `O_j + c_j x_i d_j + y_ij n_j` in those two axes (`d_j = (cos θ_j, sin θ_j)`,
    /// `n_j = (-sin θ_j, cos θ_j)`, `x_i` the B-spline coefficient of `(2u - 1)²` on the
    /// u layout), its span coordinate the span rule's.
    pub coords: Vec<f64>,
}

/// The stored scalars of a [`SurfaceEncoding`], by kind.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct SurfaceCount {
    /// Stored design coordinates (with the chord rule: the thickness-direction numbers).
    pub coords: usize,
    /// Numbers of the chord rule's column frames (4 a design column, or 0 without it).
    #[serde(default)]
    pub frames: usize,
    /// Numbers of the span rule (2 or 0).
    pub rule: usize,
    /// Stored breaks, both directions.
    pub breaks: usize,
    /// The sum.
    pub total: usize,
}

fn break_list(b: &Breaks) -> Result<Vec<f64>> {
    let list = match b {
        Breaks::Uniform { segments } => {
            let s = (*segments).max(1);
            (0..=s).map(|k| k as f64 / s as f64).collect()
        }
        Breaks::Stored(inner) => {
            let mut v = vec![0.0];
            v.extend(inner.iter().copied());
            v.push(1.0);
            v
        }
        Breaks::UniformPerSide { .. } => {
            return Err(Error::invalid("surface encoding: per-side breaks are for curves"))
        }
    };
    if list.windows(2).any(|w| !(w[1] > w[0])) {
        return Err(Error::invalid(
            "surface encoding: breaks are not strictly increasing",
        ));
    }
    Ok(list)
}

fn stored_breaks(b: &Breaks) -> usize {
    match b {
        Breaks::Stored(inner) => inner.len(),
        _ => 0,
    }
}

impl SurfaceEncoding {
    /// The two spline layouts.
    pub fn layouts(&self) -> Result<(ChainLayout, ChainLayout)> {
        Ok((
            ChainLayout::with_orders(self.degree[0], break_list(&self.breaks_u)?, self.joins_u.clone())?,
            ChainLayout::with_orders(self.degree[1], break_list(&self.breaks_v)?, self.joins_v.clone())?,
        ))
    }

    /// The stored scalars.
    #[must_use]
    pub fn count(&self) -> SurfaceCount {
        let rule = if self.span_rule.is_some() { 2 } else { 0 };
        let breaks = stored_breaks(&self.breaks_u) + stored_breaks(&self.breaks_v);
        let frames = if self.chord_rule {
            self.layouts()
                .map_or(0, |(lu, lv)| {
                    Chordwise::frame_len_for(lu.degree(), self.te_term) * lv.design_count()
                })
                .min(self.coords.len())
        } else {
            0
        };
        SurfaceCount {
            coords: self.coords.len() - frames,
            frames,
            rule,
            breaks,
            total: self.coords.len() + rule + breaks,
        }
    }

    /// The design net (B-spline coefficients, row-major, rows along u) from the stored numbers.
    pub fn design(&self) -> Result<Vec<DVec3>> {
        let (lu, lv) = self.layouts()?;
        let (nu, nv) = (lu.design_count(), lv.design_count());
        if self.chord_rule {
            return self.chord_design(&lu, &lv);
        }
        let per = if self.span_rule.is_some() { 2 } else { 3 };
        if self.coords.len() != nu * nv * per {
            return Err(Error::invalid(format!(
                "surface encoding: {} stored coordinates for a {nu} x {nv} net",
                self.coords.len()
            )));
        }
        let g = lv.greville();
        let mut out = Vec::with_capacity(nu * nv);
        for i in 0..nu {
            for j in 0..nv {
                let c = &self.coords[(i * nv + j) * per..(i * nv + j + 1) * per];
                let p = match self.span_rule {
                    Some(r) => {
                        if r.axis > 2 {
                            return Err(Error::invalid("surface encoding: span axis beyond z"));
                        }
                        let mut a = [0.0; 3];
                        let mut it = c.iter();
                        for (ax, slot) in a.iter_mut().enumerate() {
                            *slot = if ax == r.axis {
                                r.ends[0] + g[j] * (r.ends[1] - r.ends[0])
                            } else {
                                *it.next().unwrap_or(&0.0)
                            };
                        }
                        DVec3::from_array(a)
                    }
                    None => DVec3::new(c[0], c[1], c[2]),
                };
                out.push(p);
            }
        }
        Ok(out)
    }

    /// The design net of the chord rule ([`SurfaceEncoding::coords`]).
    fn chord_design(&self, lu: &ChainLayout, lv: &ChainLayout) -> Result<Vec<DVec3>> {
        let (nu, nv) = (lu.design_count(), lv.design_count());
        let Some(r) = self.span_rule.filter(|r| r.axis <= 2) else {
            return Err(Error::invalid(
                "surface encoding: the chord rule needs the span rule",
            ));
        };
        let law = Chordwise::new(lu, self.te_term);
        let fl = law.frame_len();
        if lu.degree() < super::super::blade::MIN_DEGREE || self.coords.len() != nv * (nu + fl) {
            return Err(Error::invalid(format!(
                "surface encoding: {} stored numbers for a {nu} x {nv} chord-rule net of degree {} around (4 a column and one a design point, degree 2 or more)",
                self.coords.len(),
                lu.degree()
            )));
        }
        let axes: Vec<usize> = (0..3).filter(|&a| a != r.axis).collect();
        let g = lv.greville();
        let mut out = Vec::with_capacity(nu * nv);
        for i in 0..nu {
            for j in 0..nv {
                let q = super::super::blade::regenerate(&law, &self.coords, nv, i, j);
                let mut a = [0.0; 3];
                a[axes[0]] = q.x;
                a[axes[1]] = q.y;
                a[r.axis] = r.ends[0] + g[j] * (r.ends[1] - r.ends[0]);
                out.push(DVec3::from_array(a));
            }
        }
        Ok(out)
    }

    /// The patch grid, from the stored numbers alone, as a C1 grid (joins smoother than C1
    /// are generated points too; the expanded control net is the same).
    pub fn grid(&self) -> Result<PatchGrid<DVec3>> {
        let (lu, lv) = self.layouts()?;
        PatchGrid::new(GridLayout::new(lu, lv), self.design()?)?.to_c1()
    }
}
