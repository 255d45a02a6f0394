//! The inviscid linear-vorticity panel method (XFOIL's formulation; Drela 1989, Katz &
//! Plotkin ch. 11), the f64 reference.
//!
//! The contour is `N` nodes in counterclockwise order (upper trailing edge, upper surface,
//! leading edge, lower surface, lower trailing edge). The vortex sheet strength `γ` is linear
//! on each of the `N - 1` panels between nodes, and equals the surface speed (the flow inside
//! the body is at rest). The unknowns are the `N` node values `γ_i` and the stream function
//! `Ψ₀` of the body's surface; the equations are `Ψ(node i) = Ψ₀` at every node and the Kutta
//! condition `γ₁ + γ_N = 0`.
//!
//! **Trailing edge.** A blunt trailing edge (gap ≥ 10⁻⁴ chord) is closed by a panel from the
//! last node to the first carrying a uniform source `σ = ½ (γ₁ − γ_N) |t̂ × ĝ|` and vortex
//! `γ = −½ (γ₁ − γ_N) (t̂ · ĝ)`, with `ĝ` the gap's direction and `t̂` the bisector of the two
//! end tangents (XFOIL's `TECALC`). At a sharp trailing edge the last node's equation is
//! replaced by zero velocity along the bisector at a point 0.1 of the smaller end panel ahead
//! of the trailing edge, inside the body.
//!
//! **Two unit solutions.** The system is solved once with two right-hand sides, the free
//! streams at α = 0° and 90°; `γ(α) = cos α γ₀ + sin α γ₉₀` gives every angle of attack.
//!
//! **Coefficients.** `Cp = 1 − γ²`; CL and CM come from integrating `Cp` panel by panel
//! (trapezoidal, with the exact moment of the linear pressure), trailing-edge panel included,
//! in wind axes (α measured from the x axis). They are per unit chord: the chord runs from the
//! leading edge, the node farthest from the trailing-edge midpoint (refined by a parabola
//! through it and its neighbours), to that midpoint, and CM is taken about the point a quarter
//! of the way along it. XFOIL divides by nothing and takes CM about `(0.25, 0)`: the two agree
//! on unit-chord sections with the leading edge at the origin.
//!
//! The solve runs in coordinates centred on the mid-chord and scaled to unit chord: `γ` does not
//! depend on either, and the stream-function equations keep the same conditioning for every
//! model unit.

use crate::error::{Error, Result};
use crate::numeric::atan2;
use glam::DVec2;
use nalgebra::{DMatrix, Dyn, LU};
use std::f64::consts::PI;

/// `1 / 4π`.
const QOPI: f64 = 0.25 / PI;
/// `1 / 2π`.
pub(crate) const HOPI: f64 = 0.5 / PI;
/// A trailing edge with a gap below this fraction of the chord is sharp (XFOIL's rule).
pub const SHARP_GAP: f64 = 1e-4;
/// The sharp-edge control point lies this fraction of the smaller end panel ahead of the
/// trailing edge (XFOIL's `BWT`).
pub const BISECTOR_OFFSET: f64 = 0.1;
/// Fewest nodes the method accepts.
pub const MIN_NODES: usize = 8;
/// The most nodes the f64 panel method takes: its dense system grows as their square.
pub const MAX_NODES: usize = 4000;

/// The chord of a contour given by its nodes: leading edge, trailing-edge midpoint, length.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Chord {
    /// The leading edge (farthest from the trailing-edge midpoint).
    pub le: DVec2,
    /// The trailing-edge midpoint.
    pub te: DVec2,
    /// Index of the node farthest from the trailing-edge midpoint.
    pub le_node: usize,
    /// Whether the leading edge (the parabola's vertex) lies after that node in node order:
    /// node `le_node` then belongs to the first (upper) surface.
    pub le_after: bool,
    /// `|te − le|`, model units.
    pub length: f64,
}

impl Chord {
    /// The chord of `nodes`: the leading edge is the vertex of the parabola through the node
    /// farthest from the trailing-edge midpoint and its two neighbours (distance against
    /// arclength; its position interpolated on the same parabola).
    #[must_use]
    pub fn of(nodes: &[DVec2]) -> Chord {
        let n = nodes.len();
        let te = 0.5 * (nodes[0] + nodes[n - 1]);
        let dist = |p: DVec2| (p - te).length();
        let k = (1..n - 1)
            .max_by(|&a, &b| dist(nodes[a]).total_cmp(&dist(nodes[b])))
            .unwrap_or(n / 2);
        let (a, b, c) = (nodes[k - 1], nodes[k], nodes[k + 1]);
        let (h0, h1) = ((b - a).length(), (c - b).length());
        let (d0, d1, d2) = (dist(a), dist(b), dist(c));
        // The parabola through (−h0, d0), (0, d1), (h1, d2), and its vertex s*.
        let denom = h0 * h1 * (h0 + h1);
        let curv = if denom > 0.0 {
            2.0 * (h0 * (d2 - d1) - h1 * (d1 - d0)) / denom
        } else {
            0.0
        };
        let slope = if denom > 0.0 {
            (h0 * h0 * (d2 - d1) + h1 * h1 * (d1 - d0)) / denom
        } else {
            0.0
        };
        let s = if curv < 0.0 {
            (-slope / curv).clamp(-h0, h1)
        } else {
            0.0
        };
        // Quadratic (Lagrange) interpolation of the position at s.
        let le = if denom > 0.0 {
            let la = s * (s - h1) / (h0 * (h0 + h1));
            let lb = (s + h0) * (h1 - s) / (h0 * h1);
            let lc = s * (s + h0) / (h1 * (h0 + h1));
            la * a + lb * b + lc * c
        } else {
            b
        };
        Chord {
            le,
            te,
            le_node: k,
            le_after: s > 0.0,
            length: (te - le).length(),
        }
    }

    /// Whether node `k` lies on the first (upper) surface: before the leading edge.
    #[must_use]
    pub fn upper(&self, k: usize) -> bool {
        k < self.le_node || (k == self.le_node && self.le_after)
    }

    /// The moment reference: a quarter of the chord behind the leading edge.
    #[must_use]
    pub fn quarter(&self) -> DVec2 {
        self.le + 0.25 * (self.te - self.le)
    }
}

/// Lift and moment coefficients at one angle of attack.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Coefficients {
    /// Angle of attack, degrees.
    pub alpha: f64,
    /// Lift coefficient (per unit chord).
    pub cl: f64,
    /// Pitching-moment coefficient about the quarter chord, nose up positive.
    pub cm: f64,
}

/// The solved panel method of one contour: its nodes and the two unit vorticity distributions.
#[derive(Clone, Debug, PartialEq)]
pub struct PanelSolution {
    nodes: Vec<DVec2>,
    chord: Chord,
    sharp: bool,
    gamma0: Vec<f64>,
    gamma90: Vec<f64>,
}

/// The trailing edge: gap, its source and vortex weights, the end tangents' bisector.
#[derive(Clone, Copy, Debug)]
pub(crate) struct TrailingEdge {
    /// `|t̂ × ĝ|`-like weight of the source (1 when sharp).
    scs: f64,
    /// `t̂ · ĝ`-like weight of the vortex (0 when sharp).
    sds: f64,
    /// Whether the first and last nodes coincide (no trailing-edge panel at all).
    closed: bool,
    pub(crate) sharp: bool,
    /// Unit bisector of the end tangents, pointing downstream.
    pub(crate) bisector: DVec2,
}

/// The unit tangent at the end of a polyline `p0, p1, p2` at `p0`, pointing away from `p1`:
/// the derivative at `p0` of the parabola through the three points (chord-length spacing).
pub(crate) fn end_tangent(p0: DVec2, p1: DVec2, p2: DVec2) -> DVec2 {
    let (h1, h2) = ((p1 - p0).length(), (p2 - p1).length());
    if h1 <= 0.0 || h2 <= 0.0 {
        return (p0 - p1).normalize_or_zero();
    }
    // d/ds at s = 0 of the interpolant through s = 0, h1, h1 + h2, reversed.
    let d = (p1 - p0) * ((h1 + h2) / (h1 * h2)) - (p2 - p0) * (h1 / (h2 * (h1 + h2)));
    (-d).normalize_or_zero()
}

impl TrailingEdge {
    /// The trailing edge of `nodes` (chord `chord`).
    pub(crate) fn of(nodes: &[DVec2], chord: f64) -> TrailingEdge {
        let n = nodes.len();
        let gap = nodes[0] - nodes[n - 1];
        let aft_first = end_tangent(nodes[0], nodes[1], nodes[2]);
        let aft_last = end_tangent(nodes[n - 1], nodes[n - 2], nodes[n - 3]);
        let mean = 0.5 * (aft_first + aft_last);
        let dste = gap.length();
        let sharp = dste < SHARP_GAP * chord;
        let (scs, sds) = if sharp {
            (1.0, 0.0)
        } else {
            (mean.perp_dot(gap) / dste, mean.dot(gap) / dste)
        };
        TrailingEdge {
            scs,
            sds,
            closed: dste == 0.0,
            sharp,
            bisector: mean.normalize_or_zero(),
        }
    }
}

/// The stream-function integrals of one straight panel seen from a field point, with their
/// derivatives along a direction when asked.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct PanelTerms {
    /// `½∫ ln r² dξ` over the panel: the uniform-vortex stream function times 2π.
    psis: f64,
    /// The linear part's integral (`γ` difference weight).
    psid: f64,
    /// `−∫ θ dξ` in panel axes: the uniform-source stream function times 2π.
    pub(crate) psig: f64,
    /// Derivatives of the three along the direction `n` given to [`panel_terms`].
    #[cfg(test)]
    d_psis: f64,
    #[cfg(test)]
    d_psid: f64,
    #[cfg(test)]
    pub(crate) d_psig: f64,
}

/// The three integrals' gradients at the field point, in the panel's axes: the derivative of
/// each along `n` is `c[0] (s · n) + c[1] (s × n)` with `s` the panel's unit direction.
#[derive(Clone, Copy, Debug)]
struct Gradients {
    s: DVec2,
    psis: [f64; 2],
    psid: [f64; 2],
    psig: [f64; 2],
}

impl Gradients {
    /// The derivatives of `(psis, psid, psig)` along `n`.
    fn along(&self, n: DVec2) -> [f64; 3] {
        let (xn, yn) = (self.s.dot(n), self.s.perp_dot(n));
        [
            self.psis[0] * xn + self.psis[1] * yn,
            self.psid[0] * xn + self.psid[1] * yn,
            self.psig[0] * xn + self.psig[1] * yn,
        ]
    }
}

/// `ln r²`, with 0 for a field point on the node itself (its factors vanish there).
#[inline]
pub(crate) fn log_r2(r2: f64) -> f64 {
    if r2 > 0.0 {
        r2.ln()
    } else {
        0.0
    }
}

/// The integrals of the panel `a → b` at field point `f` (and their derivatives along `n`
/// when `n` is non-zero). The subtended angle is `atan2(r₁ × r₂, r₁ · r₂)`, which has no
/// branch cut on the body; the source's own angles (used for the trailing-edge panel only)
/// are measured from the panel's inward normal, so their cut runs downstream; the source's
/// velocity (`d_psig`) is taken without the cut, so that it holds in the wake behind a blunt
/// trailing edge too.
#[cfg(test)]
pub(crate) fn panel_terms(f: DVec2, a: DVec2, b: DVec2, n: DVec2) -> PanelTerms {
    let (mut terms, grad) = panel_terms_grad(f, a, b, n != DVec2::ZERO);
    if let Some(g) = grad {
        [terms.d_psis, terms.d_psid, terms.d_psig] = g.along(n);
    }
    terms
}

/// A field point seen from a panel `a → b`, in the panel's axes (`s` along it): `x` along it
/// from each end to the point, `yy` off it (positive on the left), the squared distances and
/// their logarithms ([`log_r2`]), the angles `atan2(x, yy)` from the normal to each end (0 at
/// the end itself) and the angle the panel subtends.
pub(crate) struct Seen {
    s: DVec2,
    x1: f64,
    x2: f64,
    yy: f64,
    rs1: f64,
    rs2: f64,
    g1: f64,
    g2: f64,
    t1: f64,
    t2: f64,
    subtended: f64,
}

pub(crate) fn seen(f: DVec2, a: DVec2, b: DVec2) -> Seen {
    let d = b - a;
    let s = d / d.length();
    let (r1, r2) = (f - a, f - b);
    let (x1, x2, yy) = (s.dot(r1), s.dot(r2), s.perp_dot(r1));
    let (rs1, rs2) = (r1.length_squared(), r2.length_squared());
    Seen {
        s,
        x1,
        x2,
        yy,
        rs1,
        rs2,
        g1: log_r2(rs1),
        g2: log_r2(rs2),
        t1: if rs1 > 0.0 { atan2(x1, yy) } else { 0.0 },
        t2: if rs2 > 0.0 { atan2(x2, yy) } else { 0.0 },
        subtended: atan2(r1.perp_dot(r2), r1.dot(r2)),
    }
}

/// [`panel_terms`] without a direction: the integrals, and with `grad` their gradients.
fn panel_terms_grad(f: DVec2, a: DVec2, b: DVec2, grad: bool) -> (PanelTerms, Option<Gradients>) {
    terms_of(&seen(f, a, b), grad)
}

/// [`panel_terms_grad`] from the panel's view of the point.
fn terms_of(v: &Seen, grad: bool) -> (PanelTerms, Option<Gradients>) {
    let (s, x1, x2, yy) = (v.s, v.x1, v.x2, v.yy);
    let (rs1, rs2, g1, g2) = (v.rs1, v.rs2, v.g1, v.g2);
    let (t1, t2, subtended) = (v.t1, v.t2, v.subtended);
    let psis = 0.5 * x1 * g1 - 0.5 * x2 * g2 + x2 - x1 + yy * subtended;
    let dx = x1 - x2;
    let psid = ((x1 + x2) * psis + 0.5 * (rs2 * g2 - rs1 * g1 + x1 * x1 - x2 * x2)) / dx;
    let psig = 0.5 * yy * (g1 - g2) + x2 * t2 - x1 * t1;
    let terms = PanelTerms {
        psis,
        psid,
        psig,
        #[cfg(test)]
        d_psis: 0.0,
        #[cfg(test)]
        d_psid: 0.0,
        #[cfg(test)]
        d_psig: 0.0,
    };
    if !grad {
        return (terms, None);
    }
    // Field-point motion along n moves x1 and x2 alike.
    let (psx1, psx2, psyy) = (0.5 * g1, -0.5 * g2, subtended);
    let pdx1 = ((x1 + x2) * psx1 + psis - x1 * g1 - psid) / dx;
    let pdx2 = ((x1 + x2) * psx2 + psis + x2 * g2 + psid) / dx;
    let pdyy = ((x1 + x2) * psyy - yy * (g1 - g2)) / dx;
    // The source's normal velocity is the angle the panel subtends, single-valued off the
    // panel: in the strip on the panel's right, where the stream function's cut lies,
    // `t2 − t1` is 2π short of it (on the panel itself it is −π, the left side's limit, as
    // the stream function gives it).
    let dt = if t2 - t1 < -PI {
        t2 - t1 + 2.0 * PI
    } else {
        t2 - t1
    };
    let grads = Gradients {
        s,
        psis: [psx1 + psx2, psyy],
        psid: [pdx1 + pdx2, pdyy],
        psig: [dt, 0.5 * (g1 - g2)],
    };
    (terms, Some(grads))
}

/// The source unknowns of a line of `n` nodes, a body's or a wake's (XFOIL's, in `PSILIN` and
/// `PSWLIN`): the density at each panel's midpoint (`0..n − 1`) and at each node
/// (`n − 1..2n − 1`), varying linearly over each half-panel between them.
pub(crate) fn half_panel_unknowns(n: usize) -> usize {
    2 * n - 1
}

/// Panel `j`'s unknowns among a line's `n` nodes' ([`half_panel_unknowns`]): its first node's,
/// its midpoint's and its second node's, the order [`half_panels`] gives their values in.
pub(crate) fn half_panel_columns(n: usize, j: usize) -> [usize; 3] {
    [n - 1 + j, j, n + j]
}

/// Each unknown of a line of `n` nodes as a difference of the nodes' mass defects:
/// `(unknown, lo, hi)`, its density `(m_hi − m_lo) / (s_hi − s_lo)`; a midpoint's over its
/// panel, a node's over its two panels (an end node's over its one).
pub(crate) fn half_panel_differences(n: usize) -> impl Iterator<Item = (usize, usize, usize)> {
    let mids = (0..n - 1).map(|j| (j, j, j + 1));
    mids.chain((0..n).map(move |j| (n - 1 + j, j.saturating_sub(1), (j + 1).min(n - 1))))
}

/// One end of a linearly varying source segment seen from the field point: `x` along the
/// segment, `r²`, `ln r²` and the angle `atan2(x, yy)`.
#[derive(Clone, Copy)]
struct End {
    x: f64,
    rs: f64,
    g: f64,
    t: f64,
}

/// The stream function (times 4π) of a source on a segment from end `a` to end `b` (`a.x >
/// b.x`), per unit density at `a` and per unit density at `b`, linear between: `−∫ σ θ dξ`,
/// whose uniform part is [`PanelTerms::psig`]'s and whose linear part comes from
/// `∫ x atan(x/y) dx = ½ r² atan(x/y) − ½ x y`.
fn segment_psi(a: End, b: End, yy: f64) -> [f64; 2] {
    let psum = 0.5 * yy * (a.g - b.g) + b.x * b.t - a.x * a.t;
    let pdif = ((a.x + b.x) * psum + a.rs * a.t - b.rs * b.t + (b.x - a.x) * yy) / (a.x - b.x);
    [psum - pdif, psum + pdif]
}

/// The same segment's velocity (times 2π) per unit density at each end, as `(along, off)`
/// components in the segment's axes: `∫ σ (x, y) / r² dx` with `σ = c0 + c1 x`, from the
/// logarithms and the subtended angle `theta`, so single-valued where the stream function has
/// its cut.
fn segment_velocity(a: End, b: End, yy: f64, theta: f64) -> [[f64; 2]; 2] {
    let len = a.x - b.x;
    let lg = 0.5 * (a.g - b.g);
    let v = |c0: f64, c1: f64| [c0 * lg + c1 * (len - yy * theta), c0 * theta + c1 * yy * lg];
    // Unit density at a (x = a.x), none at b; and the reverse.
    [v(-b.x / len, 1.0 / len), v(a.x / len, -1.0 / len)]
}

/// A panel's two half-panel sources (a body's or a wake's) at the point `v` sees: per unit
/// density at its first
/// node, its midpoint and its second node, the stream function (`n` zero) or its derivative
/// along `n` (as [`panel_terms`]' `d_psig`), both times 2π as [`PanelTerms::psig`] is taken.
pub(crate) fn half_panels(v: &Seen, n: DVec2) -> [f64; 3] {
    let x0 = 0.5 * (v.x1 + v.x2);
    let rs0 = x0 * x0 + v.yy * v.yy;
    let e1 = End {
        x: v.x1,
        rs: v.rs1,
        g: v.g1,
        t: v.t1,
    };
    let e2 = End {
        x: v.x2,
        rs: v.rs2,
        g: v.g2,
        t: v.t2,
    };
    let mut e0 = End {
        x: x0,
        rs: rs0,
        g: log_r2(rs0),
        t: 0.0,
    };
    if n == DVec2::ZERO {
        e0.t = atan2(x0, v.yy);
        let [p1, p0] = segment_psi(e1, e0, v.yy);
        let [q0, q2] = segment_psi(e0, e2, v.yy);
        return [0.5 * p1, 0.5 * (p0 + q0), 0.5 * q2];
    }
    let th1 = atan2(v.yy * (v.x1 - x0), v.x1 * x0 + v.yy * v.yy);
    let [u1, u0] = segment_velocity(e1, e0, v.yy, th1);
    let [w0, w2] = segment_velocity(e0, e2, v.yy, v.subtended - th1);
    // ∂ψ/∂n is the velocity along n turned a quarter clockwise: (along)(s × n) − (off)(s · n).
    let (xn, yn) = (v.s.dot(n), v.s.perp_dot(n));
    let d = |c: [f64; 2]| c[0] * yn - c[1] * xn;
    [d(u1), d(u0) + d(w0), d(w2)]
}

/// One equation of the system: the coefficients of the node `γ`s, of `Ψ₀`, and the free
/// stream's part at α = 0° and 90° (moved to the right-hand side).
struct Row {
    gamma: Vec<f64>,
    sigma: Vec<f64>,
    psi0: f64,
    rhs: [f64; 2],
}

/// The stream function (times 2π) at `f` of the half-panel sources on a line of wake nodes
/// `pts`, per unit of each source unknown (the midpoints' densities, then the nodes', as
/// [`half_panel_columns`]), the angles' cut running along each panel's own line
/// downstream of its ends (XFOIL's `PSWLIN`), so that no body point lies across it.
pub(crate) fn wake_half_panels_psi(f: DVec2, pts: &[DVec2], out: &mut [f64]) {
    let nw = pts.len();
    // ln r² at each wake node, shared by the two panels that end there.
    let mut g_prev = log_r2((f - pts[0]).length_squared());
    for j in 0..nw - 1 {
        let (a, b) = (pts[j], pts[j + 1]);
        let s = (b - a).normalize();
        let (r1, r2) = (f - a, f - b);
        let (x1, x2, yy) = (s.dot(r1), s.dot(r2), s.perp_dot(r1));
        let (rs1, rs2) = (r1.length_squared(), r2.length_squared());
        let g2 = log_r2(rs2);
        let x0 = 0.5 * (x1 + x2);
        let rs0 = x0 * x0 + yy * yy;
        let angle = |x: f64, rs: f64| {
            if rs == 0.0 {
                0.0
            } else if yy >= 0.0 {
                atan2(x, yy)
            } else {
                atan2(-x, -yy) - PI
            }
        };
        let e1 = End {
            x: x1,
            rs: rs1,
            g: g_prev,
            t: angle(x1, rs1),
        };
        let e0 = End {
            x: x0,
            rs: rs0,
            g: log_r2(rs0),
            t: angle(x0, rs0),
        };
        let e2 = End {
            x: x2,
            rs: rs2,
            g: g2,
            t: angle(x2, rs2),
        };
        let [p1, p0] = segment_psi(e1, e0, yy);
        let [q0, q2] = segment_psi(e0, e2, yy);
        let [c1, c0, c2] = half_panel_columns(nw, j);
        out[c1] += 0.5 * p1;
        out[c0] += 0.5 * (p0 + q0);
        out[c2] += 0.5 * q2;
        g_prev = g2;
    }
}

/// What the body's sheets give at a field point per unit strength.
pub(crate) struct Influence {
    /// Per node `γ` (the vortex sheet, the trailing-edge panel's share included).
    pub gamma: Vec<f64>,
    /// Per body source unknown ([`half_panel_unknowns`]; empty unless asked for), times 2π.
    pub sigma: Vec<f64>,
}

/// `Ψ` (or, with a direction `n` non-zero, `∂Ψ/∂n`) at `f` as rows, along several directions
/// at once (each panel's integrals taken once): vortex panels between consecutive nodes, then
/// the trailing-edge panel from the last node to the first; with `sources`, the body's
/// sources' too.
pub(crate) fn influences<const K: usize>(
    nodes: &[DVec2],
    te: &TrailingEdge,
    f: DVec2,
    dirs: [DVec2; K],
    sources: bool,
) -> [Influence; K] {
    let m = nodes.len();
    let grad = dirs.iter().any(|&n| n != DVec2::ZERO);
    let mut out: [Influence; K] = std::array::from_fn(|_| Influence {
        gamma: vec![0.0; m],
        sigma: if sources {
            vec![0.0; half_panel_unknowns(m)]
        } else {
            Vec::new()
        },
    });
    // (psis, psid, psig) or their derivatives along direction k.
    let pick = |t: &PanelTerms, g: &Option<Gradients>, n: DVec2| match g {
        Some(g) if n != DVec2::ZERO => g.along(n),
        _ => [t.psis, t.psid, t.psig],
    };
    for j in 0..m - 1 {
        if nodes[j] == nodes[j + 1] {
            continue;
        }
        let v = seen(f, nodes[j], nodes[j + 1]);
        let (t, g) = terms_of(&v, grad);
        for (o, &n) in out.iter_mut().zip(&dirs) {
            let [s, d, _] = pick(&t, &g, n);
            o.gamma[j] += QOPI * (s - d);
            o.gamma[j + 1] += QOPI * (s + d);
            if sources {
                for (c, x) in half_panel_columns(m, j).into_iter().zip(half_panels(&v, n)) {
                    o.sigma[c] += x;
                }
            }
        }
    }
    if !te.closed {
        let (t, g) = panel_terms_grad(f, nodes[m - 1], nodes[0], grad);
        for (o, &n) in out.iter_mut().zip(&dirs) {
            let [gam, _, sig] = pick(&t, &g, n);
            // σ = ½ scs (γ_first − γ_last), γ_te = −½ sds (γ_first − γ_last).
            let w = HOPI * (0.5 * te.scs * sig - 0.5 * te.sds * gam);
            o.gamma[0] += w;
            o.gamma[m - 1] -= w;
        }
    }
    out
}

/// The panel system on `local` nodes (unit chord): the matrix over the node `γ`s and `Ψ₀`
/// (the last row the Kutta condition), the right-hand sides at α = 0° and 90°, and with
/// `sources` the stream function (the bisector row: the velocity) per unit of each body source
/// unknown ([`half_panel_unknowns`]; the Kutta row zero), else an empty matrix.
pub(crate) fn system(
    local: &[DVec2],
    te: &TrailingEdge,
    sources: bool,
) -> (DMatrix<f64>, DMatrix<f64>, DMatrix<f64>) {
    let m = local.len();
    let row = |f: DVec2, n: DVec2, psi0: f64, rhs: [f64; 2]| {
        let [Influence { gamma, sigma }] = influences(local, te, f, [n], sources);
        Row {
            gamma,
            sigma,
            psi0,
            rhs,
        }
    };
    let sharp = sharp_control(local, te);
    let rows: Vec<Row> = local
        .iter()
        .enumerate()
        .map(|(i, &p)| match sharp {
            // Zero velocity along the bisector just inside the trailing edge.
            Some((f, n)) if i == m - 1 => row(f, n, 0.0, [-te.bisector.x, -te.bisector.y]),
            _ => row(p, DVec2::ZERO, -1.0, [-p.y, p.x]),
        })
        .collect();
    let mut a = DMatrix::<f64>::zeros(m + 1, m + 1);
    let mut b = DMatrix::<f64>::zeros(m + 1, 2);
    let mut src = DMatrix::<f64>::zeros(if sources { m + 1 } else { 0 }, rows[0].sigma.len());
    for (i, r) in rows.iter().enumerate() {
        for j in 0..m {
            a[(i, j)] = r.gamma[j];
        }
        a[(i, m)] = r.psi0;
        b[(i, 0)] = r.rhs[0];
        b[(i, 1)] = r.rhs[1];
        for (p, v) in r.sigma.iter().enumerate() {
            src[(i, p)] = HOPI * v;
        }
    }
    // Kutta: γ_first + γ_last = 0.
    a[(m, 0)] = 1.0;
    a[(m, m - 1)] = 1.0;
    (a, b, src)
}

/// The control point and its direction of the sharp trailing edge's row (the last node's),
/// `None` when the edge is blunt.
pub(crate) fn sharp_control(local: &[DVec2], te: &TrailingEdge) -> Option<(DVec2, DVec2)> {
    if !te.sharp {
        return None;
    }
    let m = local.len();
    let ds = (local[0] - local[1])
        .length()
        .min((local[m - 1] - local[m - 2]).length());
    let tip = 0.5 * (local[0] + local[m - 1]);
    Some((tip - BISECTOR_OFFSET * ds * te.bisector, te.bisector.perp()))
}

/// A contour's panel system in unit-chord coordinates centred on the mid-chord, factored and
/// solved for the two reference flows: what the inviscid analysis and the viscous coupling both
/// start from.
pub(crate) struct UnitSystem {
    /// The chord of the nodes as given.
    pub chord: Chord,
    /// The nodes in unit-chord coordinates.
    pub local: Vec<DVec2>,
    pub te: TrailingEdge,
    /// The factored system, for further right-hand sides.
    pub lu: LU<f64, Dyn, Dyn>,
    /// Node speeds (per unit free stream) at α = 0° and 90°.
    pub gamma: [Vec<f64>; 2],
    /// The body sources' right-hand sides ([`system`]'s third matrix; empty unless asked for).
    pub sources: DMatrix<f64>,
}

impl UnitSystem {
    /// Scale `nodes` (counterclockwise from the upper trailing edge, any units) to unit chord,
    /// build and factor the system, and solve it for α = 0° and 90°; with `sources`, keep the
    /// body sources' right-hand sides.
    pub(crate) fn solve(nodes: &[DVec2], sources: bool) -> Result<UnitSystem> {
        let chord = Chord::of(nodes);
        if !(chord.length > 0.0) {
            return Err(Error::invalid("the contour has no chord (all nodes coincide)"));
        }
        if let Some(k) = (0..nodes.len() - 1).find(|&k| nodes[k] == nodes[k + 1]) {
            return Err(Error::invalid(format!(
                "panel nodes {k} and {} coincide (a zero-length panel)",
                k + 1
            )));
        }
        let centre = 0.5 * (chord.le + chord.te);
        let local: Vec<DVec2> = nodes.iter().map(|&p| (p - centre) / chord.length).collect();
        let te = TrailingEdge::of(&local, 1.0);
        let (a, b, sources) = system(&local, &te, sources);
        let lu = a.lu();
        let x = lu
            .solve(&b)
            .ok_or_else(|| Error::Numerical("the panel system is singular".into()))?;
        if x.iter().any(|v| !v.is_finite()) {
            return Err(Error::Numerical("the panel solution is not finite".into()));
        }
        let column = |c: usize| -> Vec<f64> { (0..local.len()).map(|i| x[(i, c)]).collect() };
        let gamma = [column(0), column(1)];
        Ok(UnitSystem {
            chord,
            local,
            te,
            lu,
            gamma,
            sources,
        })
    }
}

impl PanelSolution {
    /// Solve the panel method on `nodes` (counterclockwise, first and last at the trailing
    /// edge, at least [`MIN_NODES`]).
    pub fn solve(nodes: &[DVec2]) -> Result<Self> {
        let m = nodes.len();
        if m < MIN_NODES {
            return Err(Error::invalid(format!(
                "the panel method needs at least {MIN_NODES} nodes, not {m}"
            )));
        }
        if nodes.iter().any(|p| !p.is_finite()) {
            return Err(Error::invalid("panel nodes must be finite"));
        }
        let UnitSystem {
            chord,
            te,
            gamma: [gamma0, gamma90],
            ..
        } = UnitSystem::solve(nodes, false)?;
        Ok(PanelSolution {
            nodes: nodes.to_vec(),
            chord,
            sharp: te.sharp,
            gamma0,
            gamma90,
        })
    }

    /// The nodes, as given.
    #[must_use]
    pub fn nodes(&self) -> &[DVec2] {
        &self.nodes
    }

    /// The chord the coefficients are based on.
    #[must_use]
    pub fn chord(&self) -> Chord {
        self.chord
    }

    /// Whether the trailing edge was treated as sharp.
    #[must_use]
    pub fn sharp(&self) -> bool {
        self.sharp
    }

    /// The two unit solutions: surface speeds (per unit free stream) at α = 0° and 90°.
    #[must_use]
    pub fn unit(&self) -> (&[f64], &[f64]) {
        (&self.gamma0, &self.gamma90)
    }

    /// The surface speed at every node at `alpha` degrees, positive along the node order.
    #[must_use]
    pub fn gamma(&self, alpha: f64) -> Vec<f64> {
        let (s, c) = alpha.to_radians().sin_cos();
        self.gamma0
            .iter()
            .zip(&self.gamma90)
            .map(|(g0, g90)| c * g0 + s * g90)
            .collect()
    }

    /// The pressure coefficient `1 − γ²` at every node at `alpha` degrees.
    #[must_use]
    pub fn cp(&self, alpha: f64) -> Vec<f64> {
        self.gamma(alpha).iter().map(|g| 1.0 - g * g).collect()
    }

    /// CL and CM at `alpha` degrees.
    #[must_use]
    pub fn coefficients(&self, alpha: f64) -> Coefficients {
        let (cl, cm) = integrate(&self.nodes, &self.cp(alpha), alpha, &self.chord);
        Coefficients { alpha, cl, cm }
    }
}

/// `Ok` when the closed contour through `nodes` does not cross itself ([`crossing`]); else the
/// input error naming the crossing panels and where they are. A figure-eight or a folded chain
/// has no inside: neither the panel method nor a boundary layer means anything on it.
pub fn check_simple(nodes: &[DVec2]) -> Result<()> {
    match crossing(nodes) {
        None => Ok(()),
        Some((i, j)) => Err(Error::invalid(format!(
            "the contour crosses itself (panel nodes {i}–{} and {j}–{}, near ({:.4}, {:.4})): \
             a panel method needs a contour without crossings",
            i + 1,
            j + 1,
            nodes[i].x,
            nodes[i].y
        ))),
    }
}

/// Where the first and the last panel of `nodes` cross: a contour whose two trailing-edge ends
/// overlap, as a chain fitted to a closed trailing edge can within its tolerance (the upper
/// surface ending 5e-5 below the lower one's end). Returns the crossing point and its
/// fractions along the first panel and along the last; `None` where they do not cross.
#[must_use]
pub fn trailing_edge_crossing(nodes: &[DVec2]) -> Option<(DVec2, f64, f64)> {
    let m = nodes.len();
    if m < 4 {
        return None;
    }
    let (a, b) = (nodes[0], nodes[1]);
    let (c, d) = (nodes[m - 2], nodes[m - 1]);
    let (r, q) = (b - a, d - c);
    let den = r.perp_dot(q);
    if den == 0.0 || !den.is_finite() {
        return None;
    }
    let s = (c - a).perp_dot(q) / den;
    let u = (c - a).perp_dot(r) / den;
    (s > 0.0 && s < 1.0 && u > 0.0 && u < 1.0).then(|| (a + s * r, s, u))
}

/// Close a trailing edge whose two ends overlap ([`trailing_edge_crossing`]): the first and
/// last nodes move to where the contour's two ends cross, found by Newton on the parameters
/// from the panels' crossing (`point` is the contour at a parameter; the panels' crossing
/// itself where Newton does not settle inside the two end panels), and their parameters with
/// them. Returns how far the farther end moved, or `None` when the ends do not cross (nothing
/// changed).
pub fn close_crossed_trailing_edge(
    nodes: &mut [DVec2],
    params: &mut [f64],
    point: &dyn Fn(f64) -> DVec2,
) -> Option<f64> {
    let (x, s, u) = trailing_edge_crossing(nodes)?;
    let m = nodes.len();
    let (lo_a, hi_a) = (params[0], params[1]);
    let (lo_b, hi_b) = (params[m - 2], params[m - 1]);
    let (mut a, mut b) = (lo_a + s * (hi_a - lo_a), lo_b + u * (hi_b - lo_b));
    let h = 1e-7 * (hi_a - lo_a).abs().max(hi_b - lo_b).max(1e-12);
    let d = |t: f64| (point(t + h) - point(t - h)) / (2.0 * h);
    for _ in 0..20 {
        let r = point(a) - point(b);
        let (da, db) = (d(a), -d(b));
        let det = da.perp_dot(db);
        if !(det.abs() > 0.0) {
            break;
        }
        // [da db] [Δa Δb]ᵀ = −r by Cramer's rule.
        let (step_a, step_b) = (-r.perp_dot(db) / det, -da.perp_dot(r) / det);
        a += step_a;
        b += step_b;
        if step_a.abs().max(step_b.abs()) <= 1e-14 * (1.0 + a.abs().max(b.abs())) {
            break;
        }
    }
    let inside = |t: f64, lo: f64, hi: f64| t >= lo.min(hi) && t <= lo.max(hi);
    let exact = inside(a, lo_a, hi_a)
        && inside(b, lo_b, hi_b)
        && point(a).distance(point(b)) <= 1e-12 * (1.0 + point(a).length());
    let (pa, at) = if exact {
        (point(a), (a, b))
    } else {
        (x, (lo_a + s * (hi_a - lo_a), lo_b + u * (hi_b - lo_b)))
    };
    let moved = nodes[0].distance(pa).max(nodes[m - 1].distance(pa));
    (params[0], params[m - 1]) = at;
    nodes[0] = pa;
    nodes[m - 1] = pa;
    Some(moved)
}

/// The first two panels between consecutive `nodes` that cross each other (neighbours, which
/// share a node, aside; touching is not crossing), or `None` for a contour that does not cross
/// itself. A fitted chain can fold back over its data in a small loop; its offsets stay small,
/// but no boundary layer runs along such a surface.
#[must_use]
pub fn crossing(nodes: &[DVec2]) -> Option<(usize, usize)> {
    let m = nodes.len();
    let side = |o: DVec2, p: DVec2, q: DVec2| (p - o).perp_dot(q - o);
    for i in 0..m.saturating_sub(1) {
        let (a, b) = (nodes[i], nodes[i + 1]);
        let (lo, hi) = (a.min(b), a.max(b));
        for j in i + 2..m - 1 {
            let (c, d) = (nodes[j], nodes[j + 1]);
            if c.max(d).cmplt(lo).any() || c.min(d).cmpgt(hi).any() {
                continue;
            }
            if side(c, d, a) * side(c, d, b) < 0.0 && side(a, b, c) * side(a, b, d) < 0.0 {
                return Some((i, j));
            }
        }
    }
    None
}

/// CL and CM from node pressures: trapezoidal `Cp` on every panel, the trailing-edge panel
/// (last node to first) included, in wind axes, per unit chord, CM about the quarter chord.
#[must_use]
pub fn integrate(nodes: &[DVec2], cp: &[f64], alpha: f64, chord: &Chord) -> (f64, f64) {
    let (sa, ca) = alpha.to_radians().sin_cos();
    let r = chord.quarter();
    let m = nodes.len();
    let (mut cl, mut cm) = (0.0, 0.0);
    for i in 0..m {
        let j = (i + 1) % m;
        let d = nodes[j] - nodes[i];
        let mid = 0.5 * (nodes[j] + nodes[i]) - r;
        let dx = d.x * ca + d.y * sa;
        let dy = d.y * ca - d.x * sa;
        let ax = mid.x * ca + mid.y * sa;
        let ay = mid.y * ca - mid.x * sa;
        let ag = 0.5 * (cp[i] + cp[j]);
        let dg = cp[j] - cp[i];
        cl += dx * ag;
        cm -= dx * (ag * ax + dg * dx / 12.0) + dy * (ag * ay + dg * dy / 12.0);
    }
    (cl / chord.length, cm / (chord.length * chord.length))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A panel's half-panel sources against many uniform ones whose strengths follow them: the
    /// stream function off the panel's cut, and the velocity everywhere off the panel, the
    /// strip under it (where the stream function's cut lies) included.
    #[test]
    fn half_panel_sources_are_sums_of_uniform_ones() {
        let (a, b) = (DVec2::new(0.2, -0.1), DVec2::new(0.9, 0.3));
        let k = 4000;
        let parts = |f: DVec2, n: DVec2| {
            let mut out = [0.0; 3];
            for j in 0..k {
                let (w0, w1) = (j as f64 / k as f64, (j + 1) as f64 / k as f64);
                let t = panel_terms(f, a.lerp(b, w0), a.lerp(b, w1), n);
                let v = if n == DVec2::ZERO { t.psig } else { t.d_psig };
                // The first node's, the midpoint's and the second node's densities there.
                let w = 0.5 * (w0 + w1);
                let tent = [
                    (1.0 - 2.0 * w).max(0.0),
                    1.0 - (2.0 * w - 1.0).abs(),
                    (2.0 * w - 1.0).max(0.0),
                ];
                for (o, t) in out.iter_mut().zip(tent) {
                    *o += t * v;
                }
            }
            out
        };
        let n = DVec2::new(0.6, -0.8);
        // Left of the panel, beyond its ends, and in the strip on its right.
        for f in [
            DVec2::new(0.5, 0.4),
            DVec2::new(1.4, 0.2),
            DVec2::new(-0.3, -0.5),
            DVec2::new(0.7, -0.2),
        ] {
            let got = half_panels(&seen(f, a, b), n);
            let want = parts(f, n);
            for (g, w) in got.iter().zip(want) {
                assert!((g - w).abs() < 1e-6, "velocity at {f}: {got:?} against {want:?}");
            }
        }
        for f in [
            DVec2::new(0.5, 0.4),
            DVec2::new(0.1, 0.6),
            DVec2::new(-0.3, -0.5),
            a,
            b,
        ] {
            let got = half_panels(&seen(f, a, b), DVec2::ZERO);
            let want = parts(f, DVec2::ZERO);
            for (g, w) in got.iter().zip(want) {
                assert!(
                    (g - w).abs() < 1e-6,
                    "stream function at {f}: {got:?} against {want:?}"
                );
            }
        }
        // A unit density everywhere is the uniform source.
        let f = DVec2::new(0.3, 0.5);
        let sum: f64 = half_panels(&seen(f, a, b), DVec2::ZERO).iter().sum();
        assert!((sum - panel_terms(f, a, b, DVec2::ZERO).psig).abs() < 1e-13);
    }

    /// A line of wake panels: its stream function differs between two points by the flux of
    /// its velocity through the segment joining them, for points below the wake's start and
    /// either side of it (a blunt edge's lower node and its neighbour, the wake leaving
    /// downwards), each source unknown on its own.
    #[test]
    fn a_wake_line_stream_function_is_the_flux_between_body_points() {
        let pts = [
            DVec2::new(1.0, 0.0),
            DVec2::new(1.013, -0.0018),
            DVec2::new(1.04, -0.004),
        ];
        let nw = pts.len();
        for (p, q) in [
            (DVec2::new(1.0, -0.021), DVec2::new(0.986, -0.020)),
            (DVec2::new(1.004, -0.03), DVec2::new(0.95, 0.01)),
            (DVec2::new(1.0, 0.021), DVec2::new(0.986, -0.020)),
        ] {
            let (mut pp, mut pq) = (vec![0.0; 2 * nw - 1], vec![0.0; 2 * nw - 1]);
            wake_half_panels_psi(p, &pts, &mut pp);
            wake_half_panels_psi(q, &pts, &mut pq);
            let k = 4000;
            let d = (p - q) / k as f64;
            let e = d.normalize();
            let mut flux = vec![0.0; 2 * nw - 1];
            for j in 0..k {
                let f = q + (j as f64 + 0.5) * d;
                for w in 0..nw - 1 {
                    let [first, mid, second] = half_panels(&seen(f, pts[w], pts[w + 1]), e);
                    flux[nw - 1 + w] += first * d.length();
                    flux[w] += mid * d.length();
                    flux[nw + w] += second * d.length();
                }
            }
            for u in 0..2 * nw - 1 {
                let dpsi = pp[u] - pq[u];
                assert!(
                    (dpsi - flux[u]).abs() < 1e-6,
                    "{p} {q} unknown {u}: {dpsi} vs {}",
                    flux[u]
                );
            }
        }
    }

    /// The panel integrals against brute-force quadrature of `ln r²` and the source angle.
    #[test]
    fn panel_integrals_match_quadrature() {
        let (a, b) = (DVec2::new(0.2, -0.1), DVec2::new(0.9, 0.3));
        let s = (b - a).normalize();
        let len = (b - a).length();
        for f in [
            DVec2::new(0.5, 0.6),
            DVec2::new(-0.4, -0.3),
            DVec2::new(1.3, 0.1),
            // Just off the panel on its inner side (the side a closed body's nodes see).
            DVec2::new(0.55, 0.12),
        ] {
            let t = panel_terms(f, a, b, DVec2::ZERO);
            let k = 200_000;
            let (mut i0, mut i1, mut ia) = (0.0, 0.0, 0.0);
            for q in 0..k {
                let xi = (q as f64 + 0.5) / k as f64 * len;
                let r = f - (a + xi * s);
                let g = r.length_squared().ln();
                i0 += g;
                i1 += g * (xi / len - 0.5);
                // Angle from the panel's inward normal, as the source term measures it.
                ia += s.dot(r).atan2(s.perp_dot(r));
            }
            let h = len / k as f64;
            assert!((2.0 * t.psis - i0 * h).abs() < 1e-8, "psis at {f}");
            assert!((t.psid - i1 * h).abs() < 1e-8, "psid at {f}");
            assert!((t.psig + ia * h).abs() < 1e-8, "psig at {f}");
        }
    }

    /// The derivatives along a direction against central differences.
    #[test]
    fn panel_derivatives_match_differences() {
        let (a, b) = (DVec2::new(0.0, 0.0), DVec2::new(0.3, 0.05));
        let f = DVec2::new(0.1, 0.2);
        let n = DVec2::new(0.6, -0.8);
        let t = panel_terms(f, a, b, n);
        let h = 1e-6;
        let p = panel_terms(f + h * n, a, b, DVec2::ZERO);
        let q = panel_terms(f - h * n, a, b, DVec2::ZERO);
        assert!((t.d_psis - (p.psis - q.psis) / (2.0 * h)).abs() < 1e-7);
        assert!((t.d_psid - (p.psid - q.psid) / (2.0 * h)).abs() < 1e-7);
        assert!((t.d_psig - (p.psig - q.psig) / (2.0 * h)).abs() < 1e-7);
    }

    /// A circle in uniform flow: speed `2 sin θ` (no lift: the "trailing edge" is a cusp-free
    /// point, so use an ellipse-like node set and check symmetry instead of the Kutta lift).
    #[test]
    fn a_symmetric_section_has_no_lift_at_zero_incidence() {
        let n = 121;
        let nodes: Vec<DVec2> = (0..n)
            .map(|k| {
                let th = 2.0 * PI * k as f64 / (n - 1) as f64;
                let x = 0.5 * (1.0 + th.cos());
                let y = 0.06 * th.sin() * (1.0 - 0.8 * (1.0 + th.cos()) / 2.0);
                DVec2::new(x, y)
            })
            .collect();
        let s = PanelSolution::solve(&nodes).unwrap();
        assert!(s.sharp());
        let c = s.coefficients(0.0);
        assert!(c.cl.abs() < 1e-10 && c.cm.abs() < 1e-10, "{c:?}");
        let c4 = s.coefficients(4.0);
        assert!(c4.cl > 0.4 && c4.cl < 0.6, "{c4:?}");
        let cm4 = s.coefficients(-4.0);
        assert!((c4.cl + cm4.cl).abs() < 1e-10);
    }

    #[test]
    fn results_do_not_depend_on_units_or_origin() {
        let nodes: Vec<DVec2> = (0..81)
            .map(|k| {
                let th = 2.0 * PI * k as f64 / 80.0;
                DVec2::new(
                    0.5 * (1.0 + th.cos()),
                    0.05 * th.sin() + 0.02 * (PI * 0.5 * (1.0 + th.cos())).sin(),
                )
            })
            .collect();
        let a = PanelSolution::solve(&nodes).unwrap().coefficients(5.0);
        let moved: Vec<DVec2> = nodes.iter().map(|&p| p * 250.0 + DVec2::new(1e4, -3e3)).collect();
        let b = PanelSolution::solve(&moved).unwrap().coefficients(5.0);
        assert!(
            (a.cl - b.cl).abs() < 1e-10 && (a.cm - b.cm).abs() < 1e-10,
            "{a:?} {b:?}"
        );
    }

    #[test]
    fn bad_nodes_are_refused() {
        assert!(PanelSolution::solve(&[DVec2::ZERO; 5]).is_err());
        let mut nodes: Vec<DVec2> = (0..20).map(|k| DVec2::new(k as f64, (k % 3) as f64)).collect();
        nodes[4] = nodes[3];
        assert!(PanelSolution::solve(&nodes).is_err());
        nodes[4] = DVec2::new(f64::NAN, 0.0);
        assert!(PanelSolution::solve(&nodes).is_err());
    }
}
