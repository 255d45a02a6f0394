//! The data both evaluation paths share: the `#[repr(C)]` structs mirrored in the shaders, and
//! `Problem`, a layout, its targets and a reference design flattened into the arrays the
//! kernels read.
//!
//! **Mixed precision.** The kernels never see absolute coordinates. A reference design
//! `x_ref` (f64) is evaluated here in f64 at every target's start parameters: its offset
//! `r0 = S_ref(u0, v0) - q` and its first and second partials there. The kernels receive
//! those, rounded once to f32, and each individual as its difference `x - x_ref` (taken in f64,
//! then rounded); they compute in f32 only the difference's contribution. Every f32 quantity is
//! then an offset or a difference, so rounding errors are relative to those, not to where the
//! data sit:
//!
//! - at fixed parameters (`newton` 0) an offset is `r0 + Σ w_k Δ_k` exactly as written; its
//!   error is about `2⁻²⁴ (|r0| + (n + 1) max |w_k Δ_k|)` with n + 1 terms per coordinate
//!   (the weights `w_k`, basis products in f32, err by a few units in their last place, which
//!   only the small differences `Δ_k` see);
//! - a Newton step's displacement `δ` (local patch units) from the start parameters uses the
//!   reference's second-order Taylor polynomial, which errs by about `|∂³S_ref| |δ|³ / 6`
//!   (a third partial of the reference in local units) and, past a patch border, by `J δ² / 2`
//!   more (`J` the jump of the second derivative there). Each target carries how far its
//!   steps may go (`reach_u`, `reach_v`) for that error to stay below `2⁻¹³ ×` the targets'
//!   extent: a guard against extrapolating the polynomial where it could invent foot points
//!   (a foot point beyond reach is not followed, the offset is then an upper bound). Near the
//!   reference, where a population method converges, steps are short and the error `|∂³S|
//!   |δ|³ / 6` far below rounding (1e-15 for a step of 1e-5).
//!
//! Without a reference the evaluator takes every design point at the centre of the targets'
//! bounding box: the offsets are then exactly the old absolute ones, but measured from the
//! centre, so accuracy is about `2⁻²⁴ × extent` wherever the data sit. Population methods
//! re-anchor the reference at their best design (see [`PopulationEvaluator::set_reference`]).
//!
//! [`PopulationEvaluator::set_reference`]: super::PopulationEvaluator::set_reference

use super::basis::{bernstein, Unfused};
use super::{EvalLayout, Fitness, PopulationEvaluator, Targets};
use crate::bezier::{bernstein_jet, tensor_jet};
use crate::chain::ChainLayout;
use crate::error::{Error, Result};
use bytemuck::{Pod, Zeroable};
use glam::DVec3;

/// Uniform block of every shader. Must be kept in sync with `struct Config` in
/// `shaders/config.wgsl` (spliced into every shader).
///
/// The shaders take the degrees and the dimension as specialised constants; they are also
/// here for the CPU mirrors, which read them at run time.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Config {
    /// Individuals in this dispatch (GPU) or in the whole population (CPU).
    pub population: u32,
    /// Step between consecutive control-net values of one individual (structure of arrays).
    pub net_stride: u32,
    /// Design variables per individual.
    pub n_vars: u32,
    /// Control points of one expanded net (rows of the extraction map).
    pub n_ctrl: u32,
    /// Target points.
    pub n_points: u32,
    /// Target points per group (the last group may hold fewer).
    pub group_points: u32,
    /// Groups of target points; one partial result per group and individual.
    pub n_groups: u32,
    /// Foot-point Newton steps per point (0: parameters held fixed).
    pub newton: u32,
    /// Patches along u (segments, for a curve).
    pub patches_u: u32,
    /// Patches along v (1 for a curve).
    pub patches_v: u32,
    /// Control points per row of the net (1 for a curve).
    pub net_cols: u32,
    /// Dense-grid samples along u.
    pub grid_u: u32,
    /// Dense-grid samples along v.
    pub grid_v: u32,
    /// Degree along u.
    pub degree_u: u32,
    /// Degree along v (0 for a curve).
    pub degree_v: u32,
    /// Coordinates per point: 2 for a curve, 3 for a patch grid.
    pub dim: u32,
    /// 1 when Newton steps may cross patch borders, 0 when they are clamped to the start
    /// patch (the shader takes it as the specialised constant `CROSS`).
    pub cross: u32,
    /// Samples per patch side (one along v for a curve) of the foot-point search's candidate
    /// starts; 0: Newton starts at each target's start parameters.
    pub seeds: u32,
    /// How many patches around the start patch, along each direction, the candidates cover
    /// (with `cross`; else the start patch only).
    pub seed_ring: u32,
    /// Padding.
    pub _pad2: u32,
}

/// One target point: the reference design's offset at the point's start parameters, and
/// those parameters. Must be kept in sync with `struct Target` in `shaders/eval_patch.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Target {
    /// x of `S_ref(u0, v0) - q`, model units (computed in f64, rounded once).
    pub rx: f32,
    /// y of that offset.
    pub ry: f32,
    /// z of that offset (0 for a curve).
    pub rz: f32,
    /// Patch `i * patches_v + j` holding the start parameters.
    pub patch_id: u32,
    /// Local parameter along u in that patch, in `[0, 1]`.
    pub u: f32,
    /// Local parameter along v in that patch, in `[0, 1]` (0 for a curve).
    pub v: f32,
    /// Largest displacement along u from `u` (local units of this patch) over which the
    /// reference's Taylor polynomial stays within its tolerance: Newton steps go no further.
    pub reach_u: f32,
    /// The same along v.
    pub reach_v: f32,
}

/// The reference design's first and second partials at a target's start parameters, per
/// coordinate, in the start patch's local parameters (f64, rounded once). Must be kept in sync
/// with `struct RefJet` in `shaders/eval_patch.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct RefJet {
    /// `∂S/∂u`.
    pub su: [f32; 3],
    /// `∂S/∂v` (0 for a curve).
    pub sv: [f32; 3],
    /// `∂²S/∂u²`.
    pub suu: [f32; 3],
    /// `∂²S/∂u∂v`.
    pub suv: [f32; 3],
    /// `∂²S/∂v²`.
    pub svv: [f32; 3],
    /// Padding to 64 bytes.
    pub _pad: f32,
}

/// Sum and maximum of squared offsets over one group of points. Must be kept in sync with
/// `struct Partial` in `shaders/eval_patch.wgsl` and `shaders/reduce.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Partial {
    /// Sum of squared offsets.
    pub sum_sq: f32,
    /// Largest squared offset.
    pub max_sq: f32,
}

/// One entry of the extraction map: design point `index` with `weight`. Must be kept in sync
/// with `struct MapEntry` in `shaders/expand.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct MapEntry {
    /// Design point index.
    pub index: u32,
    /// Its weight.
    pub weight: f32,
}

/// One sample of a dense grid along one direction: a patch and the local parameter in it.
/// Must be kept in sync with `struct Sample` in `shaders/dense_grid.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Sample {
    /// Patch index along this direction.
    pub index: u32,
    /// Local parameter in that patch, in `[0, 1]`.
    pub t: f32,
}

/// A point of a dense grid with its tangent cross product. Must be kept in sync with `struct
/// Vertex` in `shaders/dense_grid.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Vertex {
    /// Position x, relative to the evaluator's reference point.
    pub px: f32,
    /// Position y.
    pub py: f32,
    /// Position z.
    pub pz: f32,
    /// x of `∂S/∂u × ∂S/∂v` in the patch's local parameters (not normalised).
    pub nx: f32,
    /// y of that product.
    pub ny: f32,
    /// z of that product.
    pub nz: f32,
    /// `max(|∂S/∂u|², |∂S/∂v|²)`, the scale of that product.
    pub tangent_sq: f32,
    /// Padding to 32 bytes.
    pub _pad: f32,
}

/// Sentinel for "no patch held".
pub(crate) const NONE: u32 = u32::MAX;

pub use crate::chain::MAX_DEGREE;

pub(crate) use super::basis::NB;

/// The largest error Newton steps may let the reference's Taylor polynomial make, as a
/// fraction of the targets' extent (see [`Problem::refresh`]).
const REACH_TOLERANCE: f64 = 1.0 / 8192.0;

/// Below this many target points per group, splitting the points no longer pays.
const MIN_GROUP_POINTS: usize = 256;
/// Work items (blocks of 64 individuals times point groups) wanted for parallel slack.
const WANTED_ITEMS: usize = 64;

/// How the target points are split into groups for a population of `population`:
/// `(group_points, n_groups)`. Small populations get several groups so that both paths have
/// parallel work; the split depends only on the population and the point count, so the CPU
/// and the GPU add the same partial sums in the same order.
#[must_use]
pub(crate) fn point_groups(population: usize, points: usize) -> (usize, usize) {
    let blocks = population.div_ceil(64).max(1);
    let wanted = WANTED_ITEMS.div_ceil(blocks);
    let most = points.div_ceil(MIN_GROUP_POINTS).max(1);
    let groups = wanted.clamp(1, most).min(65_535);
    let group_points = points.div_ceil(groups).max(1);
    (group_points, points.div_ceil(group_points).max(1))
}

/// The end of `[0, 1]` nearer `t`.
fn near_end(t: f64) -> f64 {
    if t < 0.5 {
        0.0
    } else {
        1.0
    }
}

/// A target's start parameters, located in f64.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Located {
    /// Patch `i * pv + j`.
    patch: u32,
    /// Local u in it.
    u: f64,
    /// Local v in it.
    v: f64,
    /// Index of the point in input order.
    point: u32,
}

/// A layout, its targets and the reference design flattened for the kernels: degrees, breaks,
/// the extraction map in f32 compressed rows, and the targets sorted by patch with the
/// reference's offsets, partials and basis weights at their start parameters.
#[derive(Clone, Debug)]
pub(crate) struct Problem {
    /// 2 for a curve, 3 for a grid.
    pub dim: usize,
    /// Degree along u.
    pub du: usize,
    /// Degree along v (0 for a curve).
    pub dv: usize,
    /// Patches along u.
    pub pu: usize,
    /// Patches along v.
    pub pv: usize,
    /// Columns of the control net.
    pub net_cols: usize,
    /// Control points of the expanded net.
    pub n_ctrl: usize,
    /// Design variables per individual (design points times `dim`).
    pub n_vars: usize,
    /// Breaks along u followed by breaks along v, in f32.
    pub breaks: Vec<f32>,
    /// Row starts of the extraction map (`n_ctrl + 1`).
    pub map_start: Vec<u32>,
    /// Entries of the extraction map.
    pub map_entries: Vec<MapEntry>,
    /// Targets sorted by patch.
    pub targets: Vec<Target>,
    /// `weights[k * ncp + a * (dv + 1) + b]`: `B_a(u0) B_b(v0)` of target `k`, in f32 by the
    /// shader's recurrence (the values `eval_patch.wgsl` computes for itself).
    pub weights: Vec<f32>,
    /// The reference's partials at each target's start parameters.
    pub jets: Vec<RefJet>,
    /// `targets[k]` is input point `order[k]`.
    pub order: Vec<u32>,
    /// Foot-point Newton steps.
    pub newton: u32,
    /// Whether Newton steps may cross patch borders.
    pub cross: bool,
    /// Candidate starts of the foot-point search per patch side (see [`Config::seeds`]).
    pub seeds: u32,
    u: ChainLayout,
    v: Option<ChainLayout>,
    /// The map's weights in f64, parallel to `map_entries`.
    map_f64: Vec<f64>,
    /// Target points in input order.
    points: Vec<[f64; 3]>,
    /// Start parameters of the sorted targets.
    located: Vec<Located>,
    /// The reference design.
    reference: Vec<f64>,
    /// Its expanded net.
    ref_net: Vec<DVec3>,
}

impl Problem {
    /// Flatten `layout` and `targets`, checking their sizes; the reference is the centre of
    /// the targets' bounding box.
    pub fn new(layout: &EvalLayout, targets: &Targets, newton: u32) -> Result<Self> {
        let (u, v, dim) = match layout {
            EvalLayout::Curve(c) => (c.clone(), None, 2),
            EvalLayout::Grid(g) => (g.u.clone(), Some(g.v.clone()), 3),
        };
        let du = u.degree();
        let dv = v.as_ref().map_or(0, ChainLayout::degree);
        if du > MAX_DEGREE || dv > MAX_DEGREE {
            return Err(Error::invalid(format!(
                "population evaluation supports degrees up to {MAX_DEGREE} (got {du} x {dv})"
            )));
        }
        if targets.is_empty() {
            return Err(Error::invalid(
                "population evaluation needs at least one target point",
            ));
        }
        if targets.len() > u32::MAX as usize / 2 {
            return Err(Error::invalid("too many target points"));
        }
        let pu = u.segments();
        let pv = v.as_ref().map_or(1, ChainLayout::segments);
        let net_cols = v.as_ref().map_or(1, ChainLayout::expanded_count);
        let n_ctrl = u.expanded_count() * net_cols;
        let mut breaks: Vec<f32> = u.breaks().iter().map(|&b| b as f32).collect();
        match &v {
            Some(v) => breaks.extend(v.breaks().iter().map(|&b| b as f32)),
            None => breaks.extend([0.0, 1.0]),
        }
        // The map of the whole net: the Kronecker product of the two chain maps (row-major
        // net, row-major design net), or the chain map itself for a curve.
        let design_cols = v.as_ref().map_or(1, ChainLayout::design_count);
        let mut map_start = vec![0u32];
        let mut map_entries = Vec::new();
        let mut map_f64 = Vec::new();
        for r in 0..u.expanded_count() {
            let (iu, wu) = u.map().row(r);
            for c in 0..net_cols {
                match &v {
                    Some(v) => {
                        let (iv, wv) = v.map().row(c);
                        for (&a, &wa) in iu.iter().zip(wu) {
                            for (&b, &wb) in iv.iter().zip(wv) {
                                map_entries.push(MapEntry {
                                    index: a * design_cols as u32 + b,
                                    weight: (wa * wb) as f32,
                                });
                                map_f64.push(wa * wb);
                            }
                        }
                    }
                    None => {
                        for (&a, &wa) in iu.iter().zip(wu) {
                            map_entries.push(MapEntry {
                                index: a,
                                weight: wa as f32,
                            });
                            map_f64.push(wa);
                        }
                    }
                }
                map_start.push(map_entries.len() as u32);
            }
        }
        let n_vars = u.design_count() * design_cols * dim;
        let points: Vec<[f64; 3]> = targets.points().iter().map(|p| [p.x, p.y, p.z]).collect();
        // The default reference: every design point at the centre of the targets' box.
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for p in &points {
            for c in 0..3 {
                lo[c] = lo[c].min(p[c]);
                hi[c] = hi[c].max(p[c]);
            }
        }
        let centre: Vec<f64> = (0..dim).map(|c| 0.5 * (lo[c] + hi[c])).collect();
        let reference: Vec<f64> = (0..n_vars).map(|k| centre[k % dim]).collect();
        let mut problem = Problem {
            dim,
            du,
            dv,
            pu,
            pv,
            net_cols,
            n_ctrl,
            n_vars,
            breaks,
            map_start,
            map_entries,
            targets: Vec::new(),
            weights: Vec::new(),
            jets: Vec::new(),
            order: Vec::new(),
            newton,
            cross: false,
            seeds: 0,
            u,
            v,
            map_f64,
            points,
            located: Vec::new(),
            reference: Vec::new(),
            ref_net: Vec::new(),
        };
        problem.expand_reference(reference);
        let params: Vec<[f64; 2]> = targets.params().iter().map(|p| [p.x, p.y]).collect();
        problem.set_params(&params)?;
        Ok(problem)
    }

    /// Replace the start parameters: global `(u, v)` per input point (`v` ignored for a curve),
    /// clamped to `[0, 1]`. Re-sorts the targets by patch and re-evaluates the reference there.
    pub fn set_params(&mut self, params: &[[f64; 2]]) -> Result<()> {
        if params.len() != self.points.len() {
            return Err(Error::invalid(format!(
                "{} parameters given for {} target points",
                params.len(),
                self.points.len()
            )));
        }
        if params.iter().flatten().any(|t| !t.is_finite()) {
            return Err(Error::invalid("target parameters must be finite"));
        }
        let mut located: Vec<Located> = params
            .iter()
            .enumerate()
            .map(|(k, t)| {
                let (i, a) = self.u.locate(t[0]);
                let (j, b) = self.v.as_ref().map_or((0, 0.0), |v| v.locate(t[1]));
                Located {
                    patch: (i * self.pv + j) as u32,
                    u: a,
                    v: b,
                    point: k as u32,
                }
            })
            .collect();
        // Stable: points of one patch keep their input order.
        located.sort_by_key(|l| l.patch);
        self.order = located.iter().map(|l| l.point).collect();
        self.located = located;
        self.refresh();
        Ok(())
    }

    /// Replace the reference design (`n_vars` finite values) and re-evaluate it at the start
    /// parameters.
    pub fn set_reference(&mut self, design: &[f64]) -> Result<()> {
        if design.len() != self.n_vars {
            return Err(Error::invalid(format!(
                "a reference design of {} values for {} design variables",
                design.len(),
                self.n_vars
            )));
        }
        if design.iter().any(|x| !x.is_finite()) {
            return Err(Error::invalid("the reference design must be finite"));
        }
        self.expand_reference(design.to_vec());
        self.refresh();
        Ok(())
    }

    /// The reference design.
    #[must_use]
    pub fn reference(&self) -> &[f64] {
        &self.reference
    }

    /// Store `design` as the reference and expand it through the f64 map.
    fn expand_reference(&mut self, design: Vec<f64>) {
        let dim = self.dim;
        self.ref_net = (0..self.n_ctrl)
            .map(|r| {
                let mut p = [0.0; 3];
                let (s, e) = (self.map_start[r] as usize, self.map_start[r + 1] as usize);
                for (m, &w) in self.map_entries[s..e].iter().zip(&self.map_f64[s..e]) {
                    for (c, pc) in p.iter_mut().enumerate().take(dim) {
                        *pc += w * design[m.index as usize * dim + c];
                    }
                }
                DVec3::from_array(p)
            })
            .collect();
        self.reference = design;
    }

    /// The reference's partials at local `(u, v)` of patch `(i, j)`: `jet[ou][ov][c]`, orders
    /// up to 3 together, in the patch's local units.
    fn reference_jet(&self, i: usize, j: usize, u: f64, v: f64) -> [[[f64; 3]; 4]; 4] {
        let (du, dv) = (self.du, self.dv);
        let bu = bernstein_jet::<NB, 4>(du, u);
        let bv = bernstein_jet::<NB, 4>(dv, v);
        let net = &self.ref_net[i * du * self.net_cols + j * dv..];
        let jet = tensor_jet(
            net,
            self.net_cols,
            (du + 1, dv + 1),
            bu.each_ref(),
            bv.each_ref(),
            3,
        );
        jet.map(|row| row.map(|p| p.to_array()))
    }

    /// How far Newton steps may move from local `(u, v)` of patch `(i, j)` before the
    /// reference's second-order Taylor polynomial errs by more than `tol` (see the module notes):
    /// the cubic remainder within the patch, and the jump of the second derivative at a
    /// border within reach (where the polynomial runs on past the patch).
    fn reach(&self, i: usize, j: usize, u: f64, v: f64, jet: &[[[f64; 3]; 4]; 4], tol: f64) -> [f64; 2] {
        let norm = |x: &[f64; 3]| x.iter().map(|c| c * c).sum::<f64>().sqrt();
        // Third partials bound the remainder by m3 (|δu| + |δv|)³ / 6 ≤ (4/3) m3 δ³.
        let m3 = [jet[3][0], jet[2][1], jet[1][2], jet[0][3]]
            .iter()
            .map(norm)
            .fold(0.0, f64::max);
        let inner = if m3 > 0.0 {
            (0.75 * tol / m3).cbrt()
        } else {
            f64::INFINITY
        };
        let mut reach = [inner; 2];
        // A border nearer than that: past it the neighbour's second derivative differs by the
        // jump J, and the polynomial errs by up to J δ² / 2.
        let jump = |dir: usize, near: f64, neighbour: Option<(usize, usize, f64, f64)>| -> f64 {
            match neighbour {
                Some((ni, nj, nu, nv)) if near < inner => {
                    let here = self.reference_jet(
                        i,
                        j,
                        if dir == 0 { near_end(u) } else { u },
                        if dir == 1 { near_end(v) } else { v },
                    );
                    let there = self.reference_jet(ni, nj, nu, nv);
                    // Second derivative along dir, in this patch's local units.
                    let (h0, h1) = if dir == 0 {
                        (self.u.segment_length(i), self.u.segment_length(ni))
                    } else {
                        let lv = self.v.as_ref().map_or(1.0, |l| l.segment_length(j));
                        (lv, self.v.as_ref().map_or(1.0, |l| l.segment_length(nj)))
                    };
                    let k = (h0 / h1).powi(2);
                    let (a, b) = if dir == 0 {
                        (here[2][0], there[2][0])
                    } else {
                        (here[0][2], there[0][2])
                    };
                    let d = [a[0] - k * b[0], a[1] - k * b[1], a[2] - k * b[2]];
                    let j2 = norm(&d);
                    if j2 > 0.0 {
                        (2.0 * tol / j2).sqrt()
                    } else {
                        f64::INFINITY
                    }
                }
                _ => f64::INFINITY,
            }
        };
        let pv = self.pv;
        let below_u = (i > 0).then(|| (i - 1, j, 1.0, v));
        let above_u = (i + 1 < self.pu).then(|| (i + 1, j, 0.0, v));
        let below_v = (j > 0).then(|| (i, j - 1, u, 1.0));
        let above_v = (j + 1 < pv).then(|| (i, j + 1, u, 0.0));
        let near_u = if u < 0.5 { (u, below_u) } else { (1.0 - u, above_u) };
        let near_v = if v < 0.5 { (v, below_v) } else { (1.0 - v, above_v) };
        reach[0] = reach[0].min(jump(0, near_u.0, near_u.1));
        reach[1] = reach[1].min(jump(1, near_v.0, near_v.1));
        reach
    }

    /// Rebuild the kernels' per-target arrays from the located targets and the reference.
    fn refresh(&mut self) {
        let (du, dv) = (self.du, self.dv);
        let ncp = (du + 1) * (dv + 1);
        // A guard against extrapolating the Taylor polynomial far, where it can invent closest
        // points that are not there: steps stop where it could err by 2⁻¹³ of the extent. (Near
        // the reference, where population methods converge, steps are far shorter and the
        // polynomial exact to rounding; tighter guards bias the offsets of individuals whose
        // foot points move further, and cost the GA and CMA-ES their minima on case 1.)
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for p in &self.points {
            for c in 0..3 {
                lo[c] = lo[c].min(p[c]);
                hi[c] = hi[c].max(p[c]);
            }
        }
        let extent = (0..3).map(|c| hi[c] - lo[c]).fold(0.0, f64::max);
        let tol = REACH_TOLERANCE * extent.max(f64::MIN_POSITIVE);
        let mut targets = Vec::with_capacity(self.located.len());
        let mut jets = Vec::with_capacity(self.located.len());
        let mut weights = Vec::with_capacity(self.located.len() * ncp);
        for l in &self.located {
            let i = l.patch as usize / self.pv;
            let j = l.patch as usize - i * self.pv;
            let jet = self.reference_jet(i, j, l.u, l.v);
            let reach = self.reach(i, j, l.u, l.v, &jet, tol);
            // The shader's weights: its f32 recurrence at the f32 parameters, multiply then add.
            let fu = bernstein::<Unfused>(du, l.u as f32);
            let fv = bernstein::<Unfused>(dv, l.v as f32);
            for wu in &fu[..=du] {
                for wv in &fv[..=dv] {
                    weights.push(wu * wv);
                }
            }
            let q = &self.points[l.point as usize];
            let r = [0, 1, 2].map(|c| (jet[0][0][c] - q[c]) as f32);
            let f = |x: [f64; 3]| x.map(|v| v as f32);
            targets.push(Target {
                rx: r[0],
                ry: r[1],
                rz: r[2],
                patch_id: l.patch,
                u: l.u as f32,
                v: l.v as f32,
                reach_u: reach[0].min(f64::from(f32::MAX)) as f32,
                reach_v: reach[1].min(f64::from(f32::MAX)) as f32,
            });
            jets.push(RefJet {
                su: f(jet[1][0]),
                sv: f(jet[0][1]),
                suu: f(jet[2][0]),
                suv: f(jet[1][1]),
                svv: f(jet[0][2]),
                _pad: 0.0,
            });
        }
        self.targets = targets;
        self.jets = jets;
        self.weights = weights;
    }

    /// Number of target points.
    #[must_use]
    pub fn n_points(&self) -> usize {
        self.targets.len()
    }

    /// The rounding error an f32 sum of squares near `sum_sq` may carry, to first order, for
    /// an individual near the reference: `2⁻²⁴ (N + 2 (n + D + 1)) sum_sq` for N points, n
    /// control points a patch and D coordinates (the sum over the points, then each offset's
    /// chain of n + 1 multiply-adds and its square doubled).
    #[must_use]
    pub fn resolution(&self, sum_sq: f64) -> f64 {
        let terms = self.n_points() + 2 * (self.ncp() + self.dim + 1);
        terms as f64 * f64::from(f32::EPSILON) / 2.0 * sum_sq.abs()
    }

    /// The patches around the start patch that the foot-point search's candidates cover: the
    /// whole chain for a curve (a handful of segments, and a perturbed contour's closest point
    /// may lie across its trailing edge or fold), the eight neighbours for a patch grid (whose
    /// patch count would make a global candidate set cost more than the Newton steps).
    #[must_use]
    pub fn seed_ring(&self) -> u32 {
        if self.dv == 0 && self.pv == 1 {
            self.pu as u32
        } else {
            1
        }
    }

    /// Control points of one patch.
    #[must_use]
    pub fn ncp(&self) -> usize {
        (self.du + 1) * (self.dv + 1)
    }

    /// Individuals in `population` (a whole number of rows of `n_vars`), checked against `out`.
    pub fn rows(&self, population_len: usize, out_len: usize) -> Result<usize> {
        if !population_len.is_multiple_of(self.n_vars) {
            return Err(Error::invalid(format!(
                "population of {population_len} values is not a whole number of rows of {} \
                 design variables",
                self.n_vars
            )));
        }
        let rows = population_len / self.n_vars;
        if rows != out_len {
            return Err(Error::invalid(format!(
                "{rows} individuals but room for {out_len} results"
            )));
        }
        if rows > u32::MAX as usize / 2 {
            return Err(Error::invalid("population too large"));
        }
        Ok(rows)
    }

    /// `rows` (f32 or f64 design variables) as f32 differences from the reference, the form
    /// the kernels take.
    pub fn differences<T: Gene>(&self, rows: &[T], out: &mut Vec<f32>) {
        use rayon::prelude::*;
        // Blocks of whole rows a task: at a GA's population sizes this pass is a large part of
        // the host's share of a GPU evaluation (7 million values at 65,536 × 108).
        const BLOCK_ROWS: usize = 512;
        let n = self.n_vars.max(1);
        out.resize(rows.len(), 0.0);
        out.par_chunks_mut(BLOCK_ROWS * n)
            .zip(rows.par_chunks(BLOCK_ROWS * n))
            .for_each(|(out, rows)| {
                for (o, (&x, &r)) in out.iter_mut().zip(rows.iter().zip(self.reference.iter().cycle())) {
                    *o = (x.to_f64() - r) as f32;
                }
            });
    }

    /// The uniform block for `population` individuals with net stride `net_stride`.
    #[must_use]
    pub fn config(&self, population: usize, net_stride: usize, groups: (usize, usize)) -> Config {
        Config {
            population: population as u32,
            net_stride: net_stride as u32,
            n_vars: self.n_vars as u32,
            n_ctrl: self.n_ctrl as u32,
            n_points: self.n_points() as u32,
            group_points: groups.0 as u32,
            n_groups: groups.1 as u32,
            newton: self.newton,
            patches_u: self.pu as u32,
            patches_v: self.pv as u32,
            net_cols: self.net_cols as u32,
            grid_u: 0,
            grid_v: 0,
            degree_u: self.du as u32,
            degree_v: self.dv as u32,
            dim: self.dim as u32,
            cross: u32::from(self.cross),
            seeds: self.seeds,
            seed_ring: self.seed_ring(),
            _pad2: 0,
        }
    }
}

/// A design variable as populations hold it: f32 (as the population methods breed them) or
/// f64 (as read from a file, or for designs far from the origin).
pub trait Gene: bytemuck::Pod + Send + Sync + 'static {
    /// The value in f64 (exact).
    fn to_f64(self) -> f64;

    /// Evaluate rows of this type on `evaluator` ([`PopulationEvaluator::evaluate`] or
    /// [`PopulationEvaluator::evaluate_f64`]).
    fn evaluate_on(
        evaluator: &mut dyn PopulationEvaluator,
        population: &[Self],
        out: &mut [Fitness],
    ) -> Result<()>;
}

impl Gene for f32 {
    #[inline(always)]
    fn to_f64(self) -> f64 {
        f64::from(self)
    }

    fn evaluate_on(
        evaluator: &mut dyn PopulationEvaluator,
        population: &[Self],
        out: &mut [Fitness],
    ) -> Result<()> {
        evaluator.evaluate(population, out)
    }
}

impl Gene for f64 {
    #[inline(always)]
    fn to_f64(self) -> f64 {
        self
    }

    fn evaluate_on(
        evaluator: &mut dyn PopulationEvaluator,
        population: &[Self],
        out: &mut [Fitness],
    ) -> Result<()> {
        evaluator.evaluate_f64(population, out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::chain::{Continuity, GridLayout, PatchGrid};
    use glam::{DVec2, DVec3};

    #[test]
    fn groups_cover_every_point_once() {
        for &pop in &[1, 16, 100, 1024, 5000, 200_000] {
            for &n in &[1, 82, 255, 256, 1000, 4096, 100_000] {
                let (gp, ng) = point_groups(pop, n);
                assert!(gp * ng >= n && gp * (ng - 1) < n, "pop {pop} n {n}: {gp} x {ng}");
                assert!(ng == 1 || gp >= MIN_GROUP_POINTS / 2);
            }
        }
        assert_eq!(point_groups(200_000, 4096).1, 1);
        assert!(point_groups(16, 4096).1 > 1);
    }

    fn wavy() -> (GridLayout, Vec<DVec3>) {
        let u = ChainLayout::with_breaks(3, vec![0.0, 0.4, 1.0], Continuity::C1).unwrap();
        let v = ChainLayout::uniform(2, 3, Continuity::C1).unwrap();
        let g = GridLayout::new(u, v);
        let (nu, nv) = g.design_shape();
        let design: Vec<DVec3> = (0..nu * nv)
            .map(|k| DVec3::new(k as f64 * 0.1, (k as f64).sin(), (k * k) as f64 * 0.01))
            .collect();
        (g, design)
    }

    #[test]
    fn the_grid_map_is_the_tensor_product() {
        let (g, design) = wavy();
        let (nu, nv) = g.design_shape();
        let net = g.expand(&design);
        let targets = Targets::grid(&[DVec3::ZERO], &[DVec2::new(0.5, 0.5)]).unwrap();
        let p = Problem::new(&EvalLayout::Grid(g), &targets, 0).unwrap();
        assert_eq!(p.n_ctrl, net.len());
        assert_eq!(p.n_vars, nu * nv * 3);
        for (r, expect) in net.iter().enumerate() {
            let (s, e) = (p.map_start[r] as usize, p.map_start[r + 1] as usize);
            let mut got = DVec3::ZERO;
            for m in &p.map_entries[s..e] {
                got += design[m.index as usize] * f64::from(m.weight);
            }
            assert!((got - *expect).length() < 1e-6, "row {r}");
        }
    }

    #[test]
    fn the_reference_jet_is_the_f64_grids() {
        let (g, design) = wavy();
        let grid = PatchGrid::new(g.clone(), design.clone()).unwrap();
        let uv = [DVec2::new(0.3, 0.55), DVec2::new(0.9, 0.1)];
        let q = [DVec3::new(0.1, 0.2, 0.3), DVec3::new(-1.0, 2.0, 0.5)];
        let targets = Targets::grid(&q, &uv).unwrap();
        let mut p = Problem::new(&EvalLayout::Grid(g.clone()), &targets, 0).unwrap();
        let flat: Vec<f64> = design.iter().flat_map(|d| [d.x, d.y, d.z]).collect();
        p.set_reference(&flat).unwrap();
        for (k, t) in p.targets.iter().enumerate() {
            let i = p.order[k] as usize;
            let (s, su, sv) = grid.partials(uv[i].x, uv[i].y);
            let r = s - q[i];
            let got = DVec3::new(t.rx.into(), t.ry.into(), t.rz.into());
            assert!((got - r).length() < 1e-6 * r.length().max(1.0), "offset {k}");
            // Local partials: the global ones times the patch lengths.
            let (iu, _) = g.u.locate(uv[i].x);
            let (iv, _) = g.v.locate(uv[i].y);
            let (hu, hv) = (g.u.segment_length(iu), g.v.segment_length(iv));
            let j = &p.jets[k];
            let gsu = DVec3::new(j.su[0].into(), j.su[1].into(), j.su[2].into());
            let gsv = DVec3::new(j.sv[0].into(), j.sv[1].into(), j.sv[2].into());
            assert!((gsu - su * hu).length() < 1e-5 * su.length() * hu, "su {k}");
            assert!((gsv - sv * hv).length() < 1e-5 * sv.length() * hv, "sv {k}");
            // Second partials by central differences of the f64 first partials.
            let h = 1e-5;
            let (_, su1, sv1) = grid.partials(uv[i].x + h, uv[i].y);
            let (_, su0, sv0) = grid.partials(uv[i].x - h, uv[i].y);
            let suu = (su1 - su0) / (2.0 * h) * hu * hu;
            let suv = (sv1 - sv0) / (2.0 * h) * hu * hv;
            let got_uu = DVec3::new(j.suu[0].into(), j.suu[1].into(), j.suu[2].into());
            let got_uv = DVec3::new(j.suv[0].into(), j.suv[1].into(), j.suv[2].into());
            assert!((got_uu - suu).length() < 1e-4 * suu.length().max(1.0), "suu {k}");
            assert!((got_uv - suv).length() < 1e-4 * suv.length().max(1.0), "suv {k}");
        }
        let w: f32 = p.weights[..p.ncp()].iter().sum();
        assert!((w - 1.0).abs() < 1e-6, "the weights of a point sum to 1");
    }

    #[test]
    fn the_default_reference_is_the_centre_and_differences_are_taken_in_f64() {
        let (g, _) = wavy();
        let q = [DVec3::new(1000.0, 2000.0, 3.0), DVec3::new(1001.0, 2002.0, 5.0)];
        let targets = Targets::grid(&q, &[DVec2::new(0.1, 0.2), DVec2::new(0.7, 0.8)]).unwrap();
        let p = Problem::new(&EvalLayout::Grid(g), &targets, 0).unwrap();
        assert_eq!(&p.reference()[..3], &[1000.5, 2001.0, 4.0]);
        // The map's rows are affine, so the reference is the centre everywhere.
        let t = &p.targets[0];
        let k = p.order[0] as usize;
        assert_eq!(
            [t.rx, t.ry, t.rz],
            [
                (1000.5 - q[k].x) as f32,
                (2001.0 - q[k].y) as f32,
                (4.0 - q[k].z) as f32
            ]
        );
        let mut out = Vec::new();
        p.differences(&vec![1000.5 + 1e-9; p.n_vars], &mut out);
        // 1000.5 + 1e-9 is itself rounded in f64 (ulp 1.1e-13); the difference keeps that.
        assert!((f64::from(out[0]) - 1e-9).abs() < 2e-13);
    }
}
