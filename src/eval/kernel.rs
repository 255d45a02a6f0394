//! The data both evaluation paths share: the `#[repr(C)]` structs mirrored in the shaders, and
//! `Problem`, a layout and its targets flattened into the arrays the kernels read.

use super::{EvalLayout, Targets};
use crate::chain::ChainLayout;
use crate::error::{Error, Result};
use bytemuck::{Pod, Zeroable};

/// Uniform block of every shader. Must be kept in sync with `struct Config` in
/// `shaders/expand.wgsl`, `shaders/eval_patch.wgsl`, `shaders/reduce.wgsl` and
/// `shaders/dense_grid.wgsl`.
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
    /// Padding to a multiple of 16 bytes.
    pub _pad0: u32,
    /// Padding.
    pub _pad1: u32,
    /// Padding.
    pub _pad2: u32,
}

/// One target point with its start parameters. Must be kept in sync with `struct Target` in
/// `shaders/eval_patch.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Target {
    /// x coordinate.
    pub x: f32,
    /// y coordinate.
    pub y: f32,
    /// z coordinate (0 for a curve).
    pub z: f32,
    /// Patch `i * patches_v + j` holding the start parameters.
    pub patch_id: u32,
    /// Local parameter along u in that patch, in `[0, 1]`.
    pub u: f32,
    /// Local parameter along v in that patch, in `[0, 1]` (0 for a curve).
    pub v: f32,
    /// Padding to 32 bytes.
    pub _pad0: u32,
    /// Padding to 32 bytes.
    pub _pad1: u32,
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

/// A point of a dense grid with its unit normal. Must be kept in sync with `struct Vertex`
/// in `shaders/dense_grid.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Vertex {
    /// Position x.
    pub px: f32,
    /// Position y.
    pub py: f32,
    /// Position z.
    pub pz: f32,
    /// Unit normal x (0 where the surface is degenerate).
    pub nx: f32,
    /// Unit normal y.
    pub ny: f32,
    /// Unit normal z.
    pub nz: f32,
}

/// Sentinel for "no patch held".
pub(crate) const NONE: u32 = u32::MAX;

pub use crate::chain::MAX_DEGREE;

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

/// A layout and its targets flattened for the kernels: degrees, breaks, the extraction map in
/// f32 compressed rows, and the targets sorted by patch.
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
    /// `targets[k]` is input point `order[k]`.
    pub order: Vec<u32>,
    /// Foot-point Newton steps.
    pub newton: u32,
    /// Whether Newton steps may cross patch borders.
    pub cross: bool,
    u: ChainLayout,
    v: Option<ChainLayout>,
    points: Vec<[f64; 3]>,
}

impl Problem {
    /// Flatten `layout` and `targets`, checking their sizes.
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
                            }
                        }
                    }
                    None => map_entries.extend(iu.iter().zip(wu).map(|(&a, &wa)| MapEntry {
                        index: a,
                        weight: wa as f32,
                    })),
                }
                map_start.push(map_entries.len() as u32);
            }
        }
        let n_vars = u.design_count() * design_cols * dim;
        let points = targets.points().iter().map(|p| [p.x, p.y, p.z]).collect();
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
            order: Vec::new(),
            newton,
            cross: false,
            u,
            v,
            points,
        };
        let params: Vec<[f64; 2]> = targets.params().iter().map(|p| [p.x, p.y]).collect();
        problem.set_params(&params)?;
        Ok(problem)
    }

    /// Replace the start parameters: global `(u, v)` per input point (`v` ignored for a curve),
    /// clamped to `[0, 1]`. Re-sorts the targets by patch.
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
        let mut tagged: Vec<(Target, u32)> = self
            .points
            .iter()
            .zip(params)
            .enumerate()
            .map(|(k, (p, t))| {
                let (i, a) = self.u.locate(t[0]);
                let (j, b) = self.v.as_ref().map_or((0, 0.0), |v| v.locate(t[1]));
                let target = Target {
                    x: p[0] as f32,
                    y: p[1] as f32,
                    z: p[2] as f32,
                    patch_id: (i * self.pv + j) as u32,
                    u: a as f32,
                    v: b as f32,
                    _pad0: 0,
                    _pad1: 0,
                };
                (target, k as u32)
            })
            .collect();
        // Stable: points of one patch keep their input order.
        tagged.sort_by_key(|(t, _)| t.patch_id);
        self.targets = tagged.iter().map(|(t, _)| *t).collect();
        self.order = tagged.iter().map(|(_, k)| *k).collect();
        Ok(())
    }

    /// Number of target points.
    #[must_use]
    pub fn n_points(&self) -> usize {
        self.targets.len()
    }

    /// Individuals in `population` (a whole number of rows of `n_vars`), checked against `out`.
    pub fn rows(&self, population: &[f32], out_len: usize) -> Result<usize> {
        if !population.len().is_multiple_of(self.n_vars) {
            return Err(Error::invalid(format!(
                "population of {} values is not a whole number of rows of {} design variables",
                population.len(),
                self.n_vars
            )));
        }
        let rows = population.len() / self.n_vars;
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
            _pad0: 0,
            _pad1: 0,
            _pad2: 0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::chain::{Continuity, GridLayout};
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

    #[test]
    fn the_grid_map_is_the_tensor_product() {
        let u = ChainLayout::with_breaks(3, vec![0.0, 0.4, 1.0], Continuity::C1).unwrap();
        let v = ChainLayout::uniform(2, 3, Continuity::C1).unwrap();
        let g = GridLayout::new(u, v);
        let (nu, nv) = g.design_shape();
        let design: Vec<DVec3> = (0..nu * nv)
            .map(|k| DVec3::new(k as f64 * 0.1, (k as f64).sin(), (k * k) as f64 * 0.01))
            .collect();
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
    fn targets_are_sorted_by_patch_with_local_parameters() {
        let u = ChainLayout::uniform(3, 2, Continuity::C1).unwrap();
        let v = ChainLayout::uniform(3, 2, Continuity::C1).unwrap();
        let pts = [DVec3::X, DVec3::Y, DVec3::Z];
        let uv = [
            DVec2::new(0.75, 0.75),
            DVec2::new(0.25, 0.25),
            DVec2::new(0.75, 0.1),
        ];
        let targets = Targets::grid(&pts, &uv).unwrap();
        let p = Problem::new(&EvalLayout::Grid(GridLayout::new(u, v)), &targets, 0).unwrap();
        assert_eq!(p.order, vec![1, 2, 0]);
        assert_eq!(
            p.targets.iter().map(|t| t.patch_id).collect::<Vec<_>>(),
            vec![0, 2, 3]
        );
        assert_eq!((p.targets[1].u, p.targets[1].v), (0.5, 0.2));
        assert_eq!(p.targets[0].y, 1.0);
    }
}
