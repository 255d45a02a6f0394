//! The chord rule of `adapt_surface`: the 2D aerofoil rule carried into 3D for sectioned
//! blade clouds with planar sections.
//!
//! Design column `j` (a span station of the design net) stores its own frame in the section
//! plane: the leading edge `O_j`, the chord angle `θ_j` and the chord length `c_j`, and for
//! every design row `i` one thickness-direction offset `y_ij` (model units). The chordwise
//! coordinate of row `i` follows the 2D aerofoil rule, `x_i`, the same for every column: the
//! B-spline coefficient of `X(u) = t²`, `t = 2u - 1` (0 at the leading edge `u = 1/2`, 1 at
//! both trailing-edge ends `u = 0, 1`):
//!
//! `P_ij = O_j + c_j x_i d_j + y_ij n_j`, with `d_j = (cos θ_j, sin θ_j)` and
//! `n_j = (-sin θ_j, cos θ_j)` in the two in-plane axes (in axis order),
//!
//! and the span coordinate follows the span rule. Every section of the design net is thus an
//! aerofoil-rule net in its own frame: x runs monotonically from the trailing edge to the
//! leading edge and back whatever the stored numbers, so the chordwise net cannot fold back
//! on itself, and the thickness direction is the only free one (as for the 2D chains, where x
//! follows the rule and only y is stored). With the trailing-edge term the law
//! `X + b_j W` is monotone on each half for `0 ≤ b_j ≤ 1`; `b_j > 1` peaks before the end on
//! purpose (a bulging end), so there the search's fold check, not the law, rules out folds.
//!
//! **The trailing-edge term.** `X = t²` is tangent to the section at the leading edge only.
//! At a round trailing edge (a cylinder root, a blunt thick section) `y(u)` keeps a
//! square-root singularity at `u = 0, 1`, and the greedy search crowds its u-breaks there
//! (17 of 33 within 2.3 % of the ends on the IEA 15 MW blade at 1e-3 of the chord). A fixed
//! quartic `X = 1 - (1 - t²)²`, tangent at both ends, was measured worse (the paper's blade
//! stalled at 5.0e-3: at a sharp trailing edge the surface's u-derivative vanishes). The
//! trailing-edge families therefore fit each column's own weight `b_j` of
//! `W = t² (1 - t²)` ([`Chordwise`]): 0 at a sharp end, 1 at a round one, above 1 where a
//! round end bulges past its end points, with each section's initial parameters following
//! its own weight ([`section_params`], [`te_weight`]).
//!
//! **Fitting.** Given each column's chord direction `d_j` and the thickness-direction
//! component of its leading edge (both from the sections' own leading and trailing edges,
//! interpolated to the column's Greville abscissa), the design is linear in the leading
//! edge's chordwise shift `α_j`, the chord length `c_j` and the thickness offsets `s_ij`:
//! `P_ij = O⁰_j + (α_j + x_i c_j) d_j + s_ij d_j⊥`. The remaining two numbers of each frame are
//! a gauge (a rotation or a thickness-direction shift of the frame is absorbed by the `y`),
//! so fixing them from the data loses nothing. The one least-squares solver fits it as a
//! coupled linear constraint ([`crate::problem::Constraint::coupled`]). The stored numbers are
//! `O_j = O⁰_j + α_j d_j`, `θ_j`, `c_j` and `y_ij = s_ij`. A section collapsed to a point (a
//! blade tip) is a column of zero chord and zero thickness, which this form represents.

use super::engine::rule_rows;
use crate::chain::ChainLayout;
use crate::problem::Constraint;
use glam::{DVec2, DVec3};

/// A section's leading-edge frame, in the two in-plane axes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct SectionFrame {
    /// The leading edge: the point of the section farthest from the trailing edge.
    pub le: DVec2,
    /// The chord vector: trailing edge (the mid-point of the section's first and last
    /// points) minus leading edge, projected on the normal of a blunt trailing edge's gap.
    pub chord: DVec2,
    /// The index of the leading-edge point.
    pub le_index: usize,
    /// The weight `b` of the trailing-edge term in the chordwise law the section's initial
    /// parameters follow in the trailing-edge families ([`te_weight`]).
    pub te: f64,
}

/// The largest trailing-edge gap of a section the chord rule takes, as a fraction of its
/// chord. The flatback root sections of recent blades open wide: the IEA 22 MW's FB70 and FB80
/// by 0.34–0.39 of their chord, which a quarter refused, leaving that blade to the plain
/// families, none of which met 1e-3 of its largest chord; at half, the trailing-edge families
/// meet it.
pub(crate) const MAX_TE_GAP: f64 = 0.5;

/// The section's frame, when it looks like an aerofoil section that starts and ends at its
/// trailing edge: the leading edge at least two points from either end, and a trailing-edge
/// gap of at most [`MAX_TE_GAP`] of the chord.
pub(crate) fn section_frame(points: &[DVec2]) -> Option<SectionFrame> {
    let n = points.len();
    if n < 7 {
        return None;
    }
    let te = 0.5 * (points[0] + points[n - 1]);
    let le_index = (0..n).max_by(|&a, &b| {
        (points[a] - te)
            .length_squared()
            .total_cmp(&(points[b] - te).length_squared())
    })?;
    let mut chord = te - points[le_index];
    let c = chord.length();
    if le_index < 2 || le_index + 3 > n || !(c > 0.0) || (points[0] - points[n - 1]).length() > MAX_TE_GAP * c
    {
        return None;
    }
    // A blunt trailing edge: the chord at right angles to its gap (when that turns it by
    // under 5°), so that both end points have the chordwise coordinate the law gives both
    // ends. From the mid-point the two ends of the IEA 3.4 MW root sections' 6-9 cm gaps lie
    // up to 9.8e-4 m apart along the chord: half of that stayed as an offset of the anchored
    // ends, over 1e-4 of the chord.
    let gap = points[0] - points[n - 1];
    if gap.length() > 1e-3 * c {
        let normal = gap.perp().normalize();
        let along = chord.dot(normal);
        if along.abs() > c * 5f64.to_radians().cos() {
            chord = along * normal;
        }
    }
    let mut f = SectionFrame {
        le: points[le_index],
        chord,
        le_index,
        te: 0.0,
    };
    f.te = te_weight(points, &f);
    Some(f)
}

/// The chord rule's parameters of a section's points in its own frame: the `u` with
/// `X(u) = ξ`, `1/2 ∓ √ξ / 2` with `ξ` the chordwise coordinate (0 at the leading edge, 1 at
/// the trailing edge), minus before the leading edge. With `te` (the trailing-edge families)
/// the law is `t² + b t² (1 - t²)` with the section's weight `b` ([`te_weight`]); a bulging
/// end's points past the law's peak take its descending branch, and within [`END`] of the
/// chord from a trailing edge that does not bulge the points run by arc length (there the
/// chordwise coordinate no longer orders a round end's points). Both ends sit at `u = 0, 1`.
pub(crate) fn section_params(points: &[DVec2], f: &SectionFrame, te: bool) -> Vec<f64> {
    let c2 = f.chord.length_squared();
    let n = points.len();
    let b = if te { f.te } else { 0.0 };
    let xi = |k: usize| (points[k] - f.le).dot(f.chord) / c2;
    // A bulging end (b > 1): each half's points between its end and its largest ξ lie on the
    // law's descending branch, past its peak.
    let upper_peak = (0..=f.le_index)
        .max_by(|&a, &c| xi(a).total_cmp(&xi(c)))
        .unwrap_or(0);
    let lower_peak = (f.le_index..n)
        .max_by(|&a, &c| xi(a).total_cmp(&xi(c)))
        .unwrap_or(n - 1);
    let mut u: Vec<f64> = (0..n)
        .map(|k| {
            let x = xi(k).clamp(0.0, if b > 1.0 { f64::INFINITY } else { 1.0 });
            let sign = if k <= f.le_index { -1.0 } else { 1.0 };
            let past = b > 1.0 && (k < upper_peak || k > lower_peak);
            // t² = s with s + b s (1 - s) = ξ.
            let s = if b > 1e-9 {
                let root = ((1.0 + b).powi(2) - 4.0 * b * x).max(0.0).sqrt();
                ((1.0 + b) + if past { root } else { -root }) / (2.0 * b)
            } else {
                x
            };
            (0.5 + sign * 0.5 * s.clamp(0.0, 1.0).sqrt()).clamp(0.0, 1.0)
        })
        .collect();
    if !te {
        return u;
    }
    if b > 1.0 {
        u[0] = 0.0;
        u[n - 1] = 1.0;
        return u;
    }
    // Within END of the chord from the trailing edge the chordwise coordinate no longer
    // orders a round end's points: there u runs by arc length from the end to the first
    // point outside.
    let arc = |a: usize, b: usize| -> f64 { (a..b).map(|k| (points[k + 1] - points[k]).length()).sum() };
    if let Some(k1) = (1..f.le_index).find(|&k| xi(k) < 1.0 - END) {
        let total = arc(0, k1);
        if total > 0.0 {
            for k in 1..k1 {
                u[k] = u[k1] * arc(0, k) / total;
            }
        }
        u[0] = 0.0;
    }
    if let Some(k1) = (f.le_index + 1..n - 1).rev().find(|&k| xi(k) < 1.0 - END) {
        let total = arc(k1, n - 1);
        if total > 0.0 {
            for k in k1 + 1..n - 1 {
                u[k] = 1.0 - (1.0 - u[k1]) * arc(k, n - 1) / total;
            }
        }
        u[n - 1] = 1.0;
    }
    u
}

/// The fraction of the chord at each trailing-edge end where [`section_params`] orders the
/// points by arc length.
const END: f64 = 0.01;

/// A section bulges past its end points when some point's chordwise coordinate exceeds the
/// end points' by more than this fraction of the chord (less is rounding, or a blunt trailing
/// edge's corner slightly past the mid-point of its gap).
const BULGE: f64 = 2e-4;

pub(crate) fn te_weight(points: &[DVec2], f: &SectionFrame) -> f64 {
    let n = points.len();
    let c = f.chord.normalize_or_zero();
    let ang = |t: DVec2| {
        let t = t.normalize_or_zero();
        t.dot(c).abs().clamp(0.0, 1.0).acos().to_degrees()
    };
    let a = 0.5 * (ang(points[1] - points[0]) + ang(points[n - 1] - points[n - 2]));
    let c2 = f.chord.length_squared();
    let peak = points
        .iter()
        .fold(1.0_f64, |m, p| m.max((*p - f.le).dot(f.chord) / c2));
    let bulge = if peak > 1.0 + BULGE {
        2.0 * peak - 1.0 + 2.0 * (peak * peak - peak).sqrt()
    } else {
        0.0
    };
    ((a - 20.0) / 50.0).clamp(0.0, 1.0).max(bulge)
}

/// The least degree around that reproduces the rule's parabola.
pub(crate) const MIN_DEGREE: usize = 2;

/// The rule's chordwise law on a u layout: the coefficients of every design row of the
/// quadratic `X(u) = t²`, `t = 2u - 1` (`x`), and in the trailing-edge families (degree
/// [`TE_DEGREE`] or more around) of the trailing-edge term `W(u) = t² (1 - t²)` (`w`, empty
/// otherwise). Column `j`'s chordwise coordinate is `α_j + c_j (X(u) + b_j W(u))`.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Chordwise {
    pub x: Vec<f64>,
    pub w: Vec<f64>,
}

/// The least degree around that carries the trailing-edge term.
pub(crate) const TE_DEGREE: usize = 4;

/// The span fairness of the bulk families (the chord rule's trailing-edge families, and the
/// plain bulk families on their two free coordinates): `ε` of [`Constraint::with_fairness`]
/// on the second differences of every column unknown along the span. On the IEA 15 MW cloud at
/// 1e-3 of the chord (one design column per section and two more) 1e-8 already removes the
/// root's folds that the unregularised fit leaves between its first sections; 1e-6 moves
/// the fit's largest offset by less than 1 %.
pub(crate) const SPAN_FAIRNESS: f64 = 1e-6;

/// The second differences along the span of `rows` unknowns a column over `nv` columns,
/// unknown `(k, j)` (row `k`, column `j`) at index `at(k, j)`: the rows of a span fairness
/// ([`crate::problem::Constraint::with_fairness`]).
pub(crate) fn span_differences(
    rows: usize,
    nv: usize,
    at: impl Fn(usize, usize) -> usize,
) -> Vec<Vec<(usize, f64)>> {
    (1..nv.saturating_sub(1))
        .flat_map(|j| (0..rows).map(move |k| (k, j)))
        .map(|(k, j)| vec![(at(k, j - 1), 1.0), (at(k, j), -2.0), (at(k, j + 1), 1.0)])
        .collect()
}

impl Chordwise {
    /// The law on `lu`; `te` carries the trailing-edge term (from [`TE_DEGREE`] around).
    pub fn new(lu: &ChainLayout, te: bool) -> Self {
        let x = rule_rows(lu).iter().map(|r| r[1] + r[2]).collect();
        let w = if Self::carries(lu.degree(), te) {
            te_rows(lu)
        } else {
            Vec::new()
        };
        Chordwise { x, w }
    }

    /// True when a law of degree `degree` around carries the trailing-edge term.
    pub fn carries(degree: usize, te: bool) -> bool {
        te && degree >= TE_DEGREE
    }

    /// Stored numbers of a column's frame on a layout of degree `degree` around (see
    /// [`Chordwise::frame_len`]), without building the law.
    pub fn frame_len_for(degree: usize, te: bool) -> usize {
        4 + usize::from(Self::carries(degree, te))
    }

    /// True when the law carries the trailing-edge term.
    pub fn has_te(&self) -> bool {
        !self.w.is_empty()
    }

    /// Stored numbers of a column's frame: leading edge (2), chord angle, chord length, and
    /// the trailing-edge weight `b_j` when the law carries the term.
    pub fn frame_len(&self) -> usize {
        4 + usize::from(self.has_te())
    }

    /// Linear unknowns of a column: `α`, `c`, (`e = c b`,) then one offset a row.
    fn per_column(&self) -> usize {
        self.x.len() + 2 + usize::from(self.has_te())
    }
}

/// The B-spline coefficients of the trailing-edge term `W(u) = t² (1 - t²)`, `t = 2u - 1`, on
/// `lu` (degree [`TE_DEGREE`] or more), by blossoming as [`rule_rows`] does for `t²`: with
/// `t_a = 2τ_a - 1` over the knots `τ_{i+1} … τ_{i+d}` and `e_k` their elementary symmetric
/// polynomials, `w_i = e₂ / C(d, 2) - e₄ / C(d, 4)`.
fn te_rows(lu: &ChainLayout) -> Vec<f64> {
    let d = lu.degree();
    let knots = lu.knots();
    let choose = |r: usize| (0..r).fold(1.0, |c, i| c * (d - i) as f64 / (i + 1) as f64);
    (0..lu.design_count())
        .map(|i| {
            let mut e = [1.0, 0.0, 0.0, 0.0, 0.0];
            for tau in &knots[i + 1..=i + d] {
                for r in (1..5).rev() {
                    e[r] += (2.0 * tau - 1.0) * e[r - 1];
                }
            }
            e[2] / choose(2) - e[4] / choose(4)
        })
        .collect()
}

/// The fixed part of each design column's frame: the reference leading edge `O⁰_j` and the
/// unit chord direction `d_j`, from the sections' frames interpolated linearly (the chord
/// angle unwrapped) at the column's Greville abscissa.
pub(crate) struct ColumnFrames {
    pub origin: Vec<DVec2>,
    pub angle: Vec<f64>,
    pub dir: Vec<DVec2>,
}

impl ColumnFrames {
    /// The frames of the columns of `lv` from the sections' frames at span parameters `v`
    /// (increasing or decreasing).
    pub fn new(lv: &ChainLayout, v: &[f64], sections: &[SectionFrame]) -> Self {
        let mut order: Vec<usize> = (0..v.len()).collect();
        order.sort_by(|&a, &b| v[a].total_cmp(&v[b]));
        // A section collapsed to a point (a blade tip) has no chord angle: it takes the
        // nearest section's.
        let own: Vec<Option<f64>> = order
            .iter()
            .map(|&k| {
                let c = sections[k].chord;
                (c != DVec2::ZERO).then(|| c.y.atan2(c.x))
            })
            .collect();
        let mut angle: Vec<f64> = (0..own.len())
            .map(|k| {
                (0..own.len())
                    .filter_map(|o| own[o].map(|a| (o.abs_diff(k), a)))
                    .min_by_key(|&(d, _)| d)
                    .map_or(0.0, |(_, a)| a)
            })
            .collect();
        for k in 1..angle.len() {
            let tau = std::f64::consts::TAU;
            angle[k] -= tau * ((angle[k] - angle[k - 1]) / tau).round();
        }
        let vs: Vec<f64> = order.iter().map(|&k| v[k]).collect();
        let le: Vec<DVec2> = order.iter().map(|&k| sections[k].le).collect();
        let at = |g: f64| -> (usize, f64) {
            let i = vs.partition_point(|&x| x <= g).clamp(1, vs.len() - 1);
            let w = if vs[i] > vs[i - 1] {
                ((g - vs[i - 1]) / (vs[i] - vs[i - 1])).clamp(0.0, 1.0)
            } else {
                0.0
            };
            (i, w)
        };
        let (mut origin, mut th, mut dir) = (Vec::new(), Vec::new(), Vec::new());
        for g in lv.greville() {
            let (i, w) = at(g);
            origin.push(le[i - 1] * (1.0 - w) + le[i] * w);
            let a = angle[i - 1] * (1.0 - w) + angle[i] * w;
            th.push(a);
            dir.push(DVec2::from_angle(a));
        }
        ColumnFrames {
            origin,
            angle: th,
            dir,
        }
    }

    /// The chord rule as a coupled constraint on the `nu x nv` design net (row-major, rows
    /// along u): unknowns of column `j` at `j (nu + 2)`: `α_j`, `c_j`, then `s_ij`; the span
    /// coordinate (axis `span`) of column `j` fixed at `span_at[j]`.
    pub fn constraint(&self, law: &Chordwise, axes: [usize; 2], span: usize, span_at: &[f64]) -> Constraint {
        let (nu, nv) = (law.x.len(), self.dir.len());
        let per = law.per_column();
        let te = law.has_te();
        let first_y = 2 + usize::from(te);
        let mut rows = vec![Vec::new(); nu * nv * 3];
        let mut offset = vec![0.0; nu * nv * 3];
        for i in 0..nu {
            for j in 0..nv {
                let base = j * per;
                let (d, n, o) = (self.dir[j], self.dir[j].perp(), self.origin[j]);
                for (c, &ax) in axes.iter().enumerate() {
                    let r = (i * nv + j) * 3 + ax;
                    let mut row = vec![(base, d[c]), (base + 1, law.x[i] * d[c])];
                    if te {
                        row.push((base + 2, law.w[i] * d[c]));
                    }
                    row.push((base + first_y + i, n[c]));
                    rows[r] = row;
                    offset[r] = o[c];
                }
                offset[(i * nv + j) * 3 + span] = span_at[j];
            }
        }
        let con = Constraint::coupled(rows, offset, nv * per);
        if !te {
            return con;
        }
        // Every column unknown against its two neighbours along the span.
        con.with_fairness(span_differences(per, nv, |k, j| j * per + k), SPAN_FAIRNESS)
    }

    /// The stored numbers of a design net that follows the rule: every column's frame
    /// `[O_j, θ_j, c_j]` (4 numbers, `O_j` in the in-plane axes in order), then `y_ij`
    /// row-major. `None` when the rows do not determine the frame.
    pub fn store(&self, law: &Chordwise, axes: [usize; 2], design: &[DVec3]) -> Option<Vec<f64>> {
        let (nu, nv) = (law.x.len(), self.dir.len());
        let te = law.has_te();
        let k = 2 + usize::from(te);
        let flat = |p: DVec3| DVec2::new(p[axes[0]], p[axes[1]]);
        let mut frames = Vec::with_capacity(law.frame_len() * nv);
        let mut chords = Vec::with_capacity(nv);
        for j in 0..nv {
            // t_i = α + c x_i (+ e w_i): least squares over the rows (exact for a net that
            // follows the rule).
            let (d, o) = (self.dir[j], self.origin[j]);
            let mut a = nalgebra::DMatrix::<f64>::zeros(k, k);
            let mut b = nalgebra::DVector::<f64>::zeros(k);
            for i in 0..nu {
                let t = (flat(design[i * nv + j]) - o).dot(d);
                let f = [1.0, law.x[i], if te { law.w[i] } else { 0.0 }];
                for r in 0..k {
                    b[r] += f[r] * t;
                    for c in 0..k {
                        a[(r, c)] += f[r] * f[c];
                    }
                }
            }
            let z = a.cholesky()?.solve(&b);
            let weight = if te { z[2] / z[1] } else { 0.0 };
            if z.iter().any(|v| !v.is_finite()) || !weight.is_finite() {
                return None;
            }
            let origin = o + z[0] * d;
            frames.extend([origin.x, origin.y, self.angle[j], z[1]]);
            if te {
                frames.push(weight);
            }
            chords.push(origin);
        }
        let mut y = Vec::with_capacity(nu * nv);
        for i in 0..nu {
            for j in 0..nv {
                y.push((flat(design[i * nv + j]) - chords[j]).dot(self.dir[j].perp()));
            }
        }
        frames.extend(y);
        Some(frames)
    }
}

/// The in-plane coordinates of design point `(i, j)` of a chord-rule net from the stored
/// numbers: `O_j + c_j (x_i + b_j w_i) d_j + y_ij n_j` (`b_j` only in the trailing-edge
/// families).
pub(crate) fn regenerate(law: &Chordwise, coords: &[f64], nv: usize, i: usize, j: usize) -> DVec2 {
    let k = law.frame_len();
    let f = &coords[k * j..k * j + k];
    let (o, d) = (DVec2::new(f[0], f[1]), DVec2::from_angle(f[2]));
    let x = law.x[i] + if law.has_te() { f[4] * law.w[i] } else { 0.0 };
    o + f[3] * x * d + coords[k * nv + i * nv + j] * d.perp()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::chain::Continuity;

    #[test]
    fn the_rule_reproduces_the_chordwise_parabola_and_the_trailing_edge_term() {
        let lu = ChainLayout::with_breaks(4, vec![0.0, 0.03, 0.3, 0.5, 0.8, 1.0], Continuity::C2).unwrap();
        let law = Chordwise::new(&lu, true);
        assert_eq!(law.frame_len(), 5);
        assert_eq!(Chordwise::new(&lu, false).frame_len(), 4);
        let at = |c: &[f64], u: f64| {
            let b = lu.basis(u, 0);
            (0..=4).map(|a| b.value[a] * c[b.first + a]).sum::<f64>()
        };
        for k in 0..=50 {
            let u = k as f64 / 50.0;
            let t2 = (2.0 * u - 1.0).powi(2);
            assert!((at(&law.x, u) - t2).abs() < 1e-13, "x({u})");
            assert!((at(&law.w, u) - t2 * (1.0 - t2)).abs() < 1e-12, "w({u})");
        }
        // Below degree 4 the term is not carried.
        let l3 = ChainLayout::uniform(3, 4, Continuity::C2).unwrap();
        assert!(!Chordwise::new(&l3, true).has_te());
    }

    #[test]
    fn trailing_edge_parameters_follow_a_round_end_and_keep_the_ends() {
        // A circle from its trailing edge (angle 0) around: the end is reached at 90° to the
        // chord, so b = 1, and the points' u follow the law X(u) = 1 - (1 - t²)² there.
        let n = 81;
        let pts: Vec<DVec2> = (0..n)
            .map(|k| DVec2::from_angle(std::f64::consts::TAU * k as f64 / (n - 1) as f64))
            .collect();
        let f = section_frame(&pts).unwrap();
        assert!((f.te - 1.0).abs() < 1e-12, "b = {}", f.te);
        let u = section_params(&pts, &f, true);
        assert_eq!((u[0], u[n - 1]), (0.0, 1.0));
        assert!(u.windows(2).all(|w| w[1] > w[0]), "increasing");
        for k in 5..n - 5 {
            let t2 = (2.0 * u[k] - 1.0).powi(2);
            let x = 1.0 - (1.0 - t2).powi(2);
            let xi = (pts[k] - f.le).dot(f.chord) / f.chord.length_squared();
            assert!((x - xi).abs() < 1e-9, "point {k}: law {x} data {xi}");
        }
        // Without the term, the quadratic law's parameters.
        let q = section_params(&pts, &f, false);
        let t = 2.0 * q[20] - 1.0;
        let xi = (pts[20] - f.le).dot(f.chord) / f.chord.length_squared();
        assert!((t * t - xi).abs() < 1e-12);
    }

    #[test]
    fn a_blunt_trailing_edge_gets_the_chord_at_right_angles_to_its_gap() {
        // A thick section (an ellipse's upper and lower halves from x = 1 to 0 and back)
        // whose ends are cut off unevenly: the gap tilts by about 3° from the chord's normal.
        let n = 81;
        let mut pts: Vec<DVec2> = (0..n)
            .map(|k| {
                let a = std::f64::consts::PI * (0.08 + 1.84 * k as f64 / (n - 1) as f64);
                DVec2::new(0.5 + 0.5 * a.cos(), 0.2 * a.sin())
            })
            .collect();
        pts[0].x -= 0.002;
        let f = section_frame(&pts).unwrap();
        let gap = pts[0] - pts[n - 1];
        assert!(
            f.chord.dot(gap).abs() < 1e-12 * f.chord.length(),
            "at right angles to the gap"
        );
        let xi = |p: DVec2| (p - f.le).dot(f.chord) / f.chord.length_squared();
        assert!((xi(pts[0]) - 1.0).abs() < 1e-12 && (xi(pts[n - 1]) - 1.0).abs() < 1e-12);
        // A sharp trailing edge keeps the chord to its mid-point.
        let sharp: Vec<DVec2> = (0..n)
            .map(|k| {
                let a = std::f64::consts::TAU * k as f64 / (n - 1) as f64;
                DVec2::new(0.5 + 0.5 * a.cos(), 0.1 * a.sin() * (1.0 - a.cos()))
            })
            .collect();
        let f = section_frame(&sharp).unwrap();
        assert_eq!(f.chord, 0.5 * (sharp[0] + sharp[n - 1]) - sharp[f.le_index]);
    }

    #[test]
    fn a_flatback_opening_to_half_its_chord_is_an_aerofoil_section() {
        // An ellipse from its trailing edge round the leading edge and back, cut off where the
        // gap between its ends is `gap` of the unit axis (a little more of the chord, which
        // the cut shortens).
        let section = |gap: f64| -> Vec<DVec2> {
            let a0 = (gap / 0.8).asin();
            (0..81)
                .map(|k| {
                    let a = a0 + (std::f64::consts::TAU - 2.0 * a0) * k as f64 / 80.0;
                    DVec2::new(0.5 + 0.5 * a.cos(), 0.4 * a.sin())
                })
                .collect()
        };
        for gap in [0.2, 0.39, 0.45] {
            let pts = section(gap);
            let f = section_frame(&pts).unwrap_or_else(|| panic!("gap {gap} refused"));
            let c = f.chord.length();
            let opened = (pts[0] - pts[80]).length() / c;
            assert!(opened > gap && opened <= MAX_TE_GAP, "gap {opened} of the chord");
            assert_eq!(f.le_index, 40);
        }
        // Wider than half the chord: not an aerofoil section.
        assert!(section_frame(&section(0.7)).is_none());
    }

    #[test]
    fn stored_numbers_regenerate_the_constrained_net() {
        let lu = ChainLayout::uniform(4, 3, Continuity::C2).unwrap();
        let lv = ChainLayout::uniform(2, 2, Continuity::C1).unwrap();
        let sections: Vec<SectionFrame> = (0..4)
            .map(|k| SectionFrame {
                le: DVec2::new(0.1 * k as f64, -0.05 * k as f64),
                chord: DVec2::from_angle(0.2 * k as f64) * (1.0 - 0.1 * k as f64),
                le_index: 5,
                te: 0.0,
            })
            .collect();
        let frames = ColumnFrames::new(&lv, &[0.0, 0.3, 0.7, 1.0], &sections);
        let law = Chordwise::new(&lu, true);
        let (nu, nv) = (law.x.len(), lv.design_count());
        let con = frames.constraint(&law, [0, 1], 2, &vec![0.5; nv]);
        let z: Vec<f64> = (0..nv * (nu + 3))
            .map(|k| 0.3 + (k as f64 * 0.77).sin() * 0.1)
            .collect();
        let design: Vec<DVec3> = con.design(&z);
        let coords = frames.store(&law, [0, 1], &design).unwrap();
        assert_eq!(coords.len(), 5 * nv + nu * nv);
        for i in 0..nu {
            for j in 0..nv {
                let p = regenerate(&law, &coords, nv, i, j);
                let q = design[i * nv + j];
                assert!((p - DVec2::new(q.x, q.y)).length() < 1e-13);
                assert_eq!(q.z, 0.5);
            }
        }
    }
}
