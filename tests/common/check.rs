//! The tests' own check of every offset a report claims, written apart from the library's
//! evaluation and foot-point code: Bezier segments and patches rebuilt from a report's
//! `control_points` or `control_net` alone, evaluated by de Casteljau, and every data point's
//! closest point found by dense sampling and a refinement bracketed by the samples around
//! each candidate. Slow and simple on purpose; nothing here calls the library.
//!
//! Accuracy: a candidate is every sample that is a local minimum of its segment's (patch's)
//! samples and could hold the closest point (its distance less the largest sample step is not
//! above the nearest sample's). The refinement converges to the local minimum inside the
//! bracket of the neighbouring samples (golden-section search to 1e-15 of the parameter along
//! a curve; Gauss-Newton, then a pattern search to steps of 1e-14, on a patch, continued over
//! the whole patch when the minimum sits on the bracket's edge), so a distance is exact to
//! rounding wherever the samples resolve the shape: steps of at most 0.1 % (curves) and 0.4 %
//! (patches) of the control polygon's diameter. `tests/independent_check.rs` holds it to
//! analytic distances.

use glam::{DVec2, DVec3};
use serde_json::Value;

/// Offsets of data points from a shape, as a report states them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Offsets {
    /// `Σ e²`.
    pub sum_sq: f64,
    /// `max e`.
    pub max: f64,
    /// `sqrt(sum_sq / n)`.
    pub rms: f64,
    /// Number of points measured.
    pub n: usize,
}

impl Offsets {
    /// The figures of a list of distances.
    pub fn of(distances: impl IntoIterator<Item = f64>) -> Offsets {
        let (mut sum_sq, mut max, mut n) = (0.0, 0.0_f64, 0);
        for d in distances {
            sum_sq += d * d;
            max = max.max(d);
            n += 1;
        }
        Offsets {
            sum_sq,
            max,
            rms: (sum_sq / n.max(1) as f64).sqrt(),
            n,
        }
    }

    /// Panics unless `sum_sq`, `max` and `rms` of the report's `offset` block agree with these
    /// to `rel` (relative).
    pub fn assert_matches(&self, report: &Value, rel: f64) {
        let off = &report["offset"];
        for (key, ours) in [("sum_sq", self.sum_sq), ("max", self.max), ("rms", self.rms)] {
            let claimed = off[key]
                .as_f64()
                .unwrap_or_else(|| panic!("report has no offset.{key}"));
            assert!(
                (claimed - ours).abs() <= rel * ours.max(f64::MIN_POSITIVE),
                "offset.{key}: report {claimed:e}, independent check {ours:e} (relative {rel:e})"
            );
        }
    }
}

/// A point type de Casteljau can run on.
pub trait Point: Copy {
    /// `a + (b - a) t`.
    fn lerp(self, b: Self, t: f64) -> Self;
    /// Squared Euclidean distance.
    fn dist2(self, b: Self) -> f64;
    /// Coordinate-wise minimum and maximum.
    fn min_max(self, lo: Self, hi: Self) -> (Self, Self);
}

impl Point for DVec2 {
    fn lerp(self, b: Self, t: f64) -> Self {
        self + (b - self) * t
    }
    fn dist2(self, b: Self) -> f64 {
        (b - self).length_squared()
    }
    fn min_max(self, lo: Self, hi: Self) -> (Self, Self) {
        (lo.min(self), hi.max(self))
    }
}

impl Point for DVec3 {
    fn lerp(self, b: Self, t: f64) -> Self {
        self + (b - self) * t
    }
    fn dist2(self, b: Self) -> f64 {
        (b - self).length_squared()
    }
    fn min_max(self, lo: Self, hi: Self) -> (Self, Self) {
        (lo.min(self), hi.max(self))
    }
}

/// de Casteljau's algorithm on one Bezier segment's control points.
pub fn casteljau<P: Point>(ctrl: &[P], t: f64) -> P {
    let mut p = ctrl.to_vec();
    for r in 1..p.len() {
        for i in 0..p.len() - r {
            p[i] = p[i].lerp(p[i + 1], t);
        }
    }
    p[0]
}

/// The diameter of the bounding box of `pts`.
fn diameter<P: Point>(pts: &[P]) -> f64 {
    let (lo, hi) = pts[1..]
        .iter()
        .fold((pts[0], pts[0]), |(lo, hi), p| p.min_max(lo, hi));
    lo.dist2(hi).sqrt()
}

/// Length of a control polygon.
fn polygon<P: Point>(pts: &[P]) -> f64 {
    pts.windows(2).map(|w| w[0].dist2(w[1]).sqrt()).sum()
}

/// One Bezier segment, sampled.
struct Segment<P> {
    ctrl: Vec<P>,
    /// `n + 1` samples at `t = k / n`.
    samples: Vec<P>,
    /// The longest distance between neighbouring samples.
    step: f64,
}

/// A chain of Bezier segments known only by its expanded control points (segment `k` uses
/// `ctrl[k d ..= (k + 1) d]`), sampled once.
pub struct IndependentChain<P> {
    segments: Vec<Segment<P>>,
}

impl<P: Point> IndependentChain<P> {
    /// The chain of degree `degree` with control points `ctrl`; every segment is sampled with
    /// steps along its control polygon of at most 0.1 % of the polygon's diameter (at least 200
    /// per segment).
    pub fn new(ctrl: &[P], degree: usize) -> Self {
        assert!(
            degree >= 1 && ctrl.len() > degree,
            "a chain of degree {degree} needs {} or more control points",
            degree + 1
        );
        assert_eq!(
            (ctrl.len() - 1) % degree,
            0,
            "{} control points for degree {degree}",
            ctrl.len()
        );
        let target = 1e-3 * diameter(ctrl);
        let segments = ctrl
            .windows(degree + 1)
            .step_by(degree)
            .map(|w| {
                let n = ((polygon(w) / target).ceil() as usize).clamp(200, 20_000);
                let samples: Vec<P> = (0..=n).map(|k| casteljau(w, k as f64 / n as f64)).collect();
                let step = samples
                    .windows(2)
                    .map(|s| s[0].dist2(s[1]).sqrt())
                    .fold(0.0, f64::max);
                Segment {
                    ctrl: w.to_vec(),
                    samples,
                    step,
                }
            })
            .collect();
        IndependentChain { segments }
    }

    /// The distance from `q` to the chain.
    pub fn distance(&self, q: P) -> f64 {
        let d2: Vec<Vec<f64>> = self
            .segments
            .iter()
            .map(|s| s.samples.iter().map(|p| p.dist2(q)).collect())
            .collect();
        let nearest = d2.iter().flatten().fold(f64::INFINITY, |m, &d| m.min(d));
        let mut best = nearest;
        for (seg, d) in self.segments.iter().zip(&d2) {
            let n = d.len() - 1;
            for k in 0..=n {
                let lower = (k > 0 && d[k - 1] < d[k]) || (k < n && d[k + 1] < d[k]);
                if lower || d[k].sqrt() - seg.step > nearest.sqrt() {
                    continue;
                }
                // The bracket: the samples on either side.
                let (a, b) = (
                    k.saturating_sub(1) as f64 / n as f64,
                    (k + 1).min(n) as f64 / n as f64,
                );
                best = best.min(golden(|t| casteljau(&seg.ctrl, t).dist2(q), a, b));
            }
        }
        best.sqrt()
    }

    /// The offsets of `points`.
    pub fn offsets(&self, points: &[P]) -> Offsets {
        Offsets::of(points.iter().map(|&q| self.distance(q)))
    }
}

/// The smallest value of `f` on `[a, b]` by golden-section search (`f` unimodal there), the
/// ends included.
fn golden(f: impl Fn(f64) -> f64, mut a: f64, mut b: f64) -> f64 {
    let (fa, fb) = (f(a), f(b));
    let g = (5f64.sqrt() - 1.0) / 2.0;
    let (mut c, mut d) = (b - g * (b - a), a + g * (b - a));
    let (mut fc, mut fd) = (f(c), f(d));
    while b - a > 1e-15 {
        if fc < fd {
            (b, d, fd) = (d, c, fc);
            c = b - g * (b - a);
            fc = f(c);
        } else {
            (a, c, fc) = (c, d, fd);
            d = a + g * (b - a);
            fd = f(d);
        }
    }
    fa.min(fb).min(fc).min(fd)
}

/// Closest-point `(sum_sq, max)` of `points` from the chain with expanded control points
/// `ctrl` of degree `degree` ([`IndependentChain`]).
pub fn independent_offsets(ctrl: &[DVec2], degree: usize, points: &[DVec2]) -> (f64, f64) {
    let o = IndependentChain::new(ctrl, degree).offsets(points);
    (o.sum_sq, o.max)
}

/// A Bezier patch from its `(du + 1) x (dv + 1)` control points, rows along u.
struct Patch {
    rows: Vec<Vec<DVec3>>,
}

impl Patch {
    fn eval(&self, u: f64, v: f64) -> DVec3 {
        let col: Vec<DVec3> = self.rows.iter().map(|r| casteljau(r, v)).collect();
        casteljau(&col, u)
    }
}

/// The patches of a control net (`net[r][c]`, rows along u) of degrees `du x dv`.
fn patches(net: &[Vec<DVec3>], du: usize, dv: usize) -> Vec<Patch> {
    let (pu, pv) = ((net.len() - 1) / du, (net[0].len() - 1) / dv);
    assert_eq!(pu * du + 1, net.len(), "net rows");
    assert!(net.iter().all(|r| r.len() == pv * dv + 1), "net columns");
    let mut out = Vec::new();
    for i in 0..pu {
        for j in 0..pv {
            out.push(Patch {
                rows: (i * du..=(i + 1) * du)
                    .map(|r| net[r][j * dv..=(j + 1) * dv].to_vec())
                    .collect(),
            });
        }
    }
    out
}

/// Squared distance `(d², u, v)` from `q` to one patch, from the start `(u0, v0)` inside the
/// bracket `[u_lo, u_hi] x [v_lo, v_hi]`: Gauss-Newton with partial derivatives by central
/// differences, steps clamped to the bracket and halved until the distance does not grow, then a
/// pattern search along the axes and diagonals (Gauss-Newton stalls on the bracket's edges, where a
/// clamped step need not descend).
fn refine_in_box(
    p: &Patch,
    q: DVec3,
    (u0, v0): (f64, f64),
    [u_lo, u_hi, v_lo, v_hi]: [f64; 4],
) -> (f64, f64, f64) {
    let d2 = |u: f64, v: f64| (p.eval(u, v) - q).length_squared();
    let clamp = |u: f64, v: f64| (u.clamp(u_lo, u_hi), v.clamp(v_lo, v_hi));
    let (mut u, mut v, mut f) = (u0, v0, d2(u0, v0));
    for _ in 0..60 {
        let e = 1e-6;
        let (ua, ub) = ((u - e).max(0.0), (u + e).min(1.0));
        let (va, vb) = ((v - e).max(0.0), (v + e).min(1.0));
        let su = (p.eval(ub, v) - p.eval(ua, v)) / (ub - ua);
        let sv = (p.eval(u, vb) - p.eval(u, va)) / (vb - va);
        let r = p.eval(u, v) - q;
        let (a, b, c) = (su.dot(su), su.dot(sv), sv.dot(sv));
        let (g1, g2) = (su.dot(r), sv.dot(r));
        let det = a * c - b * b;
        if det.abs() <= 1e-300 || det.is_nan() {
            break;
        }
        let (mut du, mut dv) = (-(c * g1 - b * g2) / det, -(a * g2 - b * g1) / det);
        let mut moved = false;
        for _ in 0..40 {
            let (un, vn) = clamp(u + du, v + dv);
            let fn_ = d2(un, vn);
            if fn_ < f {
                moved = (un - u).abs() + (vn - v).abs() > 1e-15;
                (u, v, f) = (un, vn, fn_);
                break;
            }
            du *= 0.5;
            dv *= 0.5;
        }
        if !moved {
            break;
        }
    }
    let mut h = 0.25 * (u_hi - u_lo).max(v_hi - v_lo);
    while h > 1e-14 {
        let mut moved = false;
        for (du, dv) in [
            (h, 0.0),
            (-h, 0.0),
            (0.0, h),
            (0.0, -h),
            (h, h),
            (-h, -h),
            (h, -h),
            (-h, h),
        ] {
            let (un, vn) = clamp(u + du, v + dv);
            let fn_ = d2(un, vn);
            if fn_ < f {
                (u, v, f) = (un, vn, fn_);
                moved = true;
            }
        }
        if !moved {
            h *= 0.5;
        }
    }
    (f, u, v)
}

/// Per patch: samples along u and v, their positions (row-major along u) and longest step.
struct PatchSamples {
    nu: usize,
    nv: usize,
    pts: Vec<DVec3>,
    step: f64,
}

/// A patch grid known only by its control net, sampled once: every patch on a grid whose
/// steps along the control polygon are at most 0.4 % of the net's diameter (at least 8 per
/// side). A distance is refined from every sample that is a local minimum of its patch's
/// samples and could hold the closest point, inside the bracket of its neighbouring samples,
/// and over the whole patch when that minimum sits on the bracket's edge (where the samples
/// do not resolve the surface: a tip collapsing to a point squeezes a patch's parameters).
pub struct IndependentGrid {
    patches: Vec<Patch>,
    samples: Vec<PatchSamples>,
}

impl IndependentGrid {
    /// The grid of control net `net` (rows along u) of degrees `du x dv`.
    pub fn new(net: &[Vec<DVec3>], du: usize, dv: usize) -> IndependentGrid {
        let patches = patches(net, du, dv);
        let all: Vec<DVec3> = net.iter().flatten().copied().collect();
        let target = 0.004 * diameter(&all);
        let samples = patches
            .iter()
            .map(|p| {
                let along_v = p.rows.iter().map(|r| polygon(r)).fold(0.0, f64::max);
                let along_u = (0..p.rows[0].len())
                    .map(|c| polygon(&p.rows.iter().map(|r| r[c]).collect::<Vec<_>>()))
                    .fold(0.0, f64::max);
                let count = |len: f64| ((len / target).ceil() as usize).clamp(8, 400);
                let (nu, nv) = (count(along_u), count(along_v));
                let pts: Vec<DVec3> = (0..=nu)
                    .flat_map(|a| (0..=nv).map(move |b| (a as f64 / nu as f64, b as f64 / nv as f64)))
                    .map(|(u, v)| p.eval(u, v))
                    .collect();
                let mut step: f64 = 0.0;
                for a in 0..=nu {
                    for b in 0..=nv {
                        let k = a * (nv + 1) + b;
                        if a < nu {
                            step = step.max((pts[k + nv + 1] - pts[k]).length());
                        }
                        if b < nv {
                            step = step.max((pts[k + 1] - pts[k]).length());
                        }
                    }
                }
                PatchSamples { nu, nv, pts, step }
            })
            .collect();
        IndependentGrid { patches, samples }
    }

    /// The distance from `q` to the grid.
    pub fn distance(&self, q: DVec3) -> f64 {
        let d2: Vec<Vec<f64>> = self
            .samples
            .iter()
            .map(|s| s.pts.iter().map(|x| (*x - q).length_squared()).collect())
            .collect();
        let nearest = d2.iter().flatten().fold(f64::INFINITY, |m, &d| m.min(d));
        let mut best = nearest;
        for ((p, d), s) in self.patches.iter().zip(&d2).zip(&self.samples) {
            let (nu, nv) = (s.nu, s.nv);
            for a in 0..=nu {
                for b in 0..=nv {
                    let k = a * (nv + 1) + b;
                    if d[k].sqrt() - s.step > nearest.sqrt() {
                        continue;
                    }
                    let (a0, a1) = (a.saturating_sub(1), (a + 1).min(nu));
                    let (b0, b1) = (b.saturating_sub(1), (b + 1).min(nv));
                    let lower = (a0..=a1)
                        .flat_map(|x| (b0..=b1).map(move |y| x * (nv + 1) + y))
                        .any(|m| d[m] < d[k]);
                    if lower {
                        continue;
                    }
                    let (fu, fv) = (|i: usize| i as f64 / nu as f64, |j: usize| j as f64 / nv as f64);
                    let bracket = [fu(a0), fu(a1), fv(b0), fv(b1)];
                    let (mut f, u, v) = refine_in_box(p, q, (fu(a), fv(b)), bracket);
                    // A minimum on the bracket's edge inside the patch: the samples did not
                    // resolve it (near an edge that collapses to a point, as a blade's tip):
                    // go on over the whole patch.
                    let inner_edge =
                        |x: f64, lo: f64, hi: f64| (x == lo && lo > 0.0) || (x == hi && hi < 1.0);
                    if inner_edge(u, bracket[0], bracket[1]) || inner_edge(v, bracket[2], bracket[3]) {
                        f = f.min(refine_in_box(p, q, (u, v), [0.0, 1.0, 0.0, 1.0]).0);
                    }
                    best = best.min(f);
                }
            }
        }
        best.sqrt()
    }

    /// The offsets of `points`.
    pub fn offsets(&self, points: &[DVec3]) -> Offsets {
        Offsets::of(points.iter().map(|&q| self.distance(q)))
    }
}

/// The numbers of a JSON array.
fn numbers(v: &Value, what: &str) -> Vec<f64> {
    v.as_array()
        .unwrap_or_else(|| panic!("report: {what} is not an array"))
        .iter()
        .map(|x| {
            x.as_f64()
                .unwrap_or_else(|| panic!("report: {what} holds a non-number"))
        })
        .collect()
}

/// A count from the report.
fn count(v: &Value, what: &str) -> usize {
    v.as_u64()
        .unwrap_or_else(|| panic!("report: {what} is not a count")) as usize
}

/// A curve report's chain, from `degree`, `segments`, `breaks` and `control_points` alone
/// (the counts checked against each other).
pub fn report_chain(report: &Value) -> IndependentChain<DVec2> {
    assert_eq!(report["kind"], "curve", "not a curve report");
    let degree = count(&report["degree"], "degree");
    let segments = count(&report["segments"], "segments");
    let breaks = numbers(&report["breaks"], "breaks");
    assert_eq!(
        breaks.len(),
        segments + 1,
        "report: breaks for {segments} segments"
    );
    assert!(
        breaks.windows(2).all(|w| w[1] > w[0]),
        "report: breaks not increasing"
    );
    let ctrl: Vec<DVec2> = report["control_points"]
        .as_array()
        .expect("report: control_points")
        .iter()
        .map(|p| {
            let c = numbers(p, "a control point");
            assert_eq!(c.len(), 2, "report: a 2D control point");
            DVec2::new(c[0], c[1])
        })
        .collect();
    assert_eq!(
        ctrl.len(),
        segments * degree + 1,
        "report: control points for {segments} segments of degree {degree}"
    );
    IndependentChain::new(&ctrl, degree)
}

/// A surface report's control net (rows along u) and degrees `[du, dv]`, from `degree`,
/// `patches`, `breaks_u`, `breaks_v` and `control_net` alone (checked against each other).
pub fn report_net(report: &Value) -> (Vec<Vec<DVec3>>, [usize; 2]) {
    assert_eq!(report["kind"], "surface", "not a surface report");
    let degree = numbers(&report["degree"], "degree");
    let patches = numbers(&report["patches"], "patches");
    let (du, dv) = (degree[0] as usize, degree[1] as usize);
    let (pu, pv) = (patches[0] as usize, patches[1] as usize);
    assert_eq!(
        numbers(&report["breaks_u"], "breaks_u").len(),
        pu + 1,
        "report: breaks_u"
    );
    assert_eq!(
        numbers(&report["breaks_v"], "breaks_v").len(),
        pv + 1,
        "report: breaks_v"
    );
    let net: Vec<Vec<DVec3>> = report["control_net"]
        .as_array()
        .expect("report: control_net")
        .iter()
        .map(|row| {
            row.as_array()
                .expect("report: a control_net row")
                .iter()
                .map(|p| {
                    let c = numbers(p, "a control point");
                    assert_eq!(c.len(), 3, "report: a 3D control point");
                    DVec3::new(c[0], c[1], c[2])
                })
                .collect()
        })
        .collect();
    assert_eq!(net.len(), pu * du + 1, "report: control_net rows");
    assert!(
        net.iter().all(|r| r.len() == pv * dv + 1),
        "report: control_net columns"
    );
    (net, [du, dv])
}

/// A surface report's grid ([`report_net`]).
pub fn report_grid(report: &Value) -> IndependentGrid {
    let (net, [du, dv]) = report_net(report);
    IndependentGrid::new(&net, du, dv)
}

/// Re-measure the offsets a curve report claims for `points` and panic unless they agree to
/// `rel` (relative); returns the independent figures.
pub fn check_curve_report(report: &Value, points: &[DVec2], rel: f64) -> Offsets {
    assert_eq!(report["input"]["points"], points.len(), "report: input.points");
    let o = report_chain(report).offsets(points);
    o.assert_matches(report, rel);
    o
}

/// Re-measure the offsets a surface report claims for `points` and panic unless they agree
/// to `rel` (relative); returns the independent figures.
pub fn check_surface_report(report: &Value, points: &[DVec3], rel: f64) -> Offsets {
    assert_eq!(report["input"]["points"], points.len(), "report: input.points");
    let o = report_grid(report).offsets(points);
    o.assert_matches(report, rel);
    o
}

/// The largest relative jump of the first derivative across the joins of a curve report's
/// chain, in the global parameter of its `breaks`: at the join of segments `k - 1` and `k`,
/// `d (P[kd] - P[kd-1]) / (t_k - t_{k-1})` against `d (P[kd+1] - P[kd]) / (t_{k+1} - t_k)`,
/// relative to the larger (0 for one segment).
pub fn report_c1_error(report: &Value) -> f64 {
    let d = count(&report["degree"], "degree");
    let t = numbers(&report["breaks"], "breaks");
    let p: Vec<DVec2> = report["control_points"]
        .as_array()
        .expect("report: control_points")
        .iter()
        .map(|c| {
            let c = numbers(c, "a control point");
            DVec2::new(c[0], c[1])
        })
        .collect();
    (1..t.len() - 1)
        .map(|k| {
            let left = (p[k * d] - p[k * d - 1]) * d as f64 / (t[k] - t[k - 1]);
            let right = (p[k * d + 1] - p[k * d]) * d as f64 / (t[k + 1] - t[k]);
            (left - right).length() / left.length().max(right.length()).max(f64::MIN_POSITIVE)
        })
        .fold(0.0, f64::max)
}
