//! `PatchGrid`: a grid of tensor-product Bezier patches chained in both directions.

use super::layout::{ChainLayout, Continuity};
use crate::bezier::{bernstein_jet, bernstein_levels, combine, BezierPatch, Vector};
use crate::error::{Error, Result};

/// The shape of a patch grid: one chain layout along u (rows) and one along v (columns).
///
/// The control net is the tensor product `net = E_u · D · E_vᵀ` of the design net `D`.
#[derive(Clone, Debug, PartialEq)]
pub struct GridLayout {
    /// Layout along u: degree `du`, `pu` patches.
    pub u: ChainLayout,
    /// Layout along v: degree `dv`, `pv` patches.
    pub v: ChainLayout,
}

impl GridLayout {
    /// A grid from its two chain layouts.
    #[must_use]
    pub fn new(u: ChainLayout, v: ChainLayout) -> Self {
        GridLayout { u, v }
    }

    /// A grid of uniformly spaced patches: `degree` and `patches` as `(u, v)`, one continuity
    /// order for every join.
    ///
    /// # Errors
    /// As [`ChainLayout::uniform`] for either direction.
    pub fn uniform(degree: (usize, usize), patches: (usize, usize), continuity: Continuity) -> Result<Self> {
        Ok(GridLayout {
            u: ChainLayout::uniform(degree.0, patches.0, continuity)?,
            v: ChainLayout::uniform(degree.1, patches.1, continuity)?,
        })
    }

    /// A row-major design net sampled from `f(a, b)` at the normalised design indices
    /// `a = i / (nu - 1)` and `b = j / (nv - 1)`: test surfaces, benchmark workloads.
    #[must_use]
    pub fn design_from<P>(&self, f: impl Fn(f64, f64) -> P) -> Vec<P> {
        let (nu, nv) = self.design_shape();
        let unit = |k: usize, n: usize| k as f64 / (n.max(2) - 1) as f64;
        (0..nu * nv)
            .map(|k| f(unit(k / nv, nu), unit(k % nv, nv)))
            .collect()
    }

    /// `(rows, columns)` of the design net.
    #[must_use]
    pub fn design_shape(&self) -> (usize, usize) {
        (self.u.design_count(), self.v.design_count())
    }

    /// `(rows, columns)` of the expanded control net.
    #[must_use]
    pub fn net_shape(&self) -> (usize, usize) {
        (self.u.expanded_count(), self.v.expanded_count())
    }

    /// `(pu, pv)`: patches along u and along v.
    #[must_use]
    pub fn patches(&self) -> (usize, usize) {
        (self.u.segments(), self.v.segments())
    }

    /// `net = E_u · D · E_vᵀ` for a row-major design net.
    #[must_use]
    pub fn expand<P: Vector>(&self, design: &[P]) -> Vec<P> {
        let (nu, nv) = self.design_shape();
        debug_assert_eq!(design.len(), nu * nv, "design net size does not match the layout");
        let (mu, mv) = self.net_shape();
        // Rows first: each design row through E_v, then each column through E_u.
        let mut half = vec![P::ZERO; nu * mv];
        for i in 0..nu {
            self.v
                .map()
                .apply_into(&design[i * nv..(i + 1) * nv], &mut half[i * mv..(i + 1) * mv]);
        }
        let mut net = vec![P::ZERO; mu * mv];
        let mut col = vec![P::ZERO; nu];
        let mut out = vec![P::ZERO; mu];
        for j in 0..mv {
            for i in 0..nu {
                col[i] = half[i * mv + j];
            }
            self.u.map().apply_into(&col, &mut out);
            for r in 0..mu {
                net[r * mv + j] = out[r];
            }
        }
        net
    }
}

/// A grid of Bezier patches: layout, design net and expanded control net (both row-major,
/// rows along u).
#[derive(Clone, Debug, PartialEq)]
pub struct PatchGrid<P: Vector> {
    layout: GridLayout,
    design: Vec<P>,
    net: Vec<P>,
}

impl<P: Vector> PatchGrid<P> {
    /// A grid from its layout and its row-major design net.
    pub fn new(layout: GridLayout, design: Vec<P>) -> Result<Self> {
        let (nu, nv) = layout.design_shape();
        if design.len() != nu * nv {
            return Err(Error::invalid(format!(
                "{} design points given, the layout needs {nu} x {nv} = {}",
                design.len(),
                nu * nv
            )));
        }
        let net = layout.expand(&design);
        Ok(PatchGrid { layout, design, net })
    }

    /// The layout.
    #[must_use]
    pub fn layout(&self) -> &GridLayout {
        &self.layout
    }

    /// The design net, row-major.
    #[must_use]
    pub fn design(&self) -> &[P] {
        &self.design
    }

    /// The expanded control net, row-major.
    #[must_use]
    pub fn net(&self) -> &[P] {
        &self.net
    }

    /// Replace the design net and regenerate the control net.
    pub fn set_design(&mut self, design: &[P]) {
        // `copy_from_slice` refuses a design of another size (a panic in every build).
        self.design.copy_from_slice(design);
        self.net = self.layout.expand(&self.design);
    }

    /// The same grid as a C1 grid of its degrees and breaks, with the same control net (see
    /// [`CurveChain::to_c1`](super::CurveChain::to_c1)).
    pub fn to_c1(&self) -> Result<PatchGrid<P>> {
        let c1 = |l: &ChainLayout| {
            l.as_c1()
                .ok_or_else(|| Error::invalid("a grid with C0 joins has no C1 form"))
        };
        let layout = GridLayout::new(c1(&self.layout.u)?, c1(&self.layout.v)?);
        let (mu, mv) = layout.net_shape();
        let (du, dv) = (layout.u.degree(), layout.v.degree());
        let keep = |r: usize, d: usize, m: usize| !r.is_multiple_of(d) || r == 0 || r == m - 1;
        let design: Vec<P> = (0..mu)
            .filter(|&r| keep(r, du, mu))
            .flat_map(|r| (0..mv).filter(move |&c| keep(c, dv, mv)).map(move |c| (r, c)))
            .map(|(r, c)| self.net[r * mv + c])
            .collect();
        let grid = PatchGrid::new(layout, design)?;
        super::check_regenerated(grid.net(), &self.net, "grid")?;
        Ok(grid)
    }

    /// Patch `(i, j)`: rows `i*du ..= (i+1)*du`, columns `j*dv ..= (j+1)*dv` of the net.
    #[must_use]
    pub fn patch(&self, i: usize, j: usize) -> BezierPatch<P> {
        let (du, dv) = (self.layout.u.degree(), self.layout.v.degree());
        let mv = self.layout.net_shape().1;
        let mut ctrl = Vec::with_capacity((du + 1) * (dv + 1));
        for r in i * du..=(i + 1) * du {
            ctrl.extend_from_slice(&self.net[r * mv + j * dv..=r * mv + (j + 1) * dv]);
        }
        BezierPatch::new(du, dv, ctrl)
    }

    /// Evaluate at global parameters `(u, v)` in `[0, 1]²`.
    #[must_use]
    pub fn eval(&self, u: f64, v: f64) -> P {
        let (i, a) = self.layout.u.locate(u);
        let (j, b) = self.layout.v.locate(v);
        self.patch(i, j).eval(a, b)
    }

    /// The cut `S(·, v)` as a chain along u: every net row combined along v, the control net
    /// of the u layout's chain (its point at `u` is [`PatchGrid::eval`]'s at `(u, v)`, to
    /// rounding).
    #[must_use]
    pub fn cut_net(&self, v: f64) -> Vec<P> {
        let dv = self.layout.v.degree();
        let mv = self.layout.net_shape().1;
        let (j, b) = self.layout.v.locate(v);
        let [w] = bernstein_levels::<33, 1>(dv, b);
        self.net
            .chunks(mv)
            .map(|row| combine(&row[j * dv..=(j + 1) * dv], &w))
            .collect()
    }

    /// Point and partial derivatives with respect to the global parameters at `(u, v)`.
    #[must_use]
    pub fn partials(&self, u: f64, v: f64) -> (P, P, P) {
        let (i, a) = self.layout.u.locate(u);
        let (j, b) = self.layout.v.locate(v);
        let (p, pu, pv) = self.patch(i, j).partials(a, b);
        (
            p,
            pu * (1.0 / self.layout.u.segment_length(i)),
            pv * (1.0 / self.layout.v.segment_length(j)),
        )
    }

    /// The partial derivatives `(S_u, S_v)` at every `(us[a], vs[b])` (row `a`, column `b`):
    /// what [`PatchGrid::partials`] gives there, bit for bit, with each sample's basis along u
    /// and along v computed once, each net row combined along v once for every v sample,
    /// and no patch copied out.
    #[must_use]
    pub fn partials_on(&self, us: &[f64], vs: &[f64]) -> Vec<Vec<(P, P)>> {
        let (du, dv) = (self.layout.u.degree(), self.layout.v.degree());
        let mv = self.layout.net_shape().1;
        // Each parameter's segment, its scale, and its Bernstein values and derivatives.
        let basis = |l: &ChainLayout, d: usize, t: f64| {
            let (k, a) = l.locate(t);
            let [b, db] = bernstein_jet::<33, 2>(d, a);
            (k, 1.0 / l.segment_length(k), b, db)
        };
        let rows: Vec<_> = us.iter().map(|&u| basis(&self.layout.u, du, u)).collect();
        // The net rows the u samples reach.
        let first = rows.iter().map(|r| r.0 * du).min().unwrap_or(0);
        let last = rows.iter().map(|r| r.0 * du + du).max().unwrap_or(0);
        let mut out = vec![Vec::with_capacity(vs.len()); us.len()];
        let (mut along, mut across) = (Vec::new(), Vec::new());
        for &v in vs {
            let (j, sv, bv, dbv) = basis(&self.layout.v, dv, v);
            // Every reached net row combined along v (BezierPatch::weighted's inner sums,
            // in its order), with the v basis and with its derivative.
            along.clear();
            across.clear();
            for r in first..=last {
                let row = &self.net[r * mv + j * dv..=r * mv + (j + 1) * dv];
                along.push(combine(row, &bv));
                across.push(combine(row, &dbv));
            }
            for (o, (i, su, bu, dbu)) in out.iter_mut().zip(&rows) {
                let reach = i * du - first..=i * du + du - first;
                let pu = combine(&along[reach.clone()], dbu);
                let pv = combine(&across[reach], bu);
                o.push((pu * *su, pv * sv));
            }
        }
        out
    }

    /// The largest relative jump of the cross-border first derivative over every patch border,
    /// in both directions, measured on the control net (as `verify.py` does, with the floor of
    /// [`PatchGrid::derivative_jump`]).
    #[must_use]
    pub fn continuity_error(&self) -> f64 {
        self.derivative_jump(1)
    }

    /// The largest relative jump of the cross-border `order`-th derivative (with respect to the
    /// global parameter) over every patch border, in both directions, measured on the control
    /// net: at a border the derivative from each side is `d!/(d-k)! / h^k` times the `k`-th
    /// difference of the net ending (left) or starting (right) there.
    ///
    /// The jump is relative to the larger of the two derivatives, but never to less than
    /// `1e-9` times the net's diameter over `h^k`: where an edge of the surface collapses to a
    /// point (a blade tip) both derivatives are rounding noise, and their difference relative
    /// to each other means nothing.
    #[must_use]
    pub fn derivative_jump(&self, order: u32) -> f64 {
        let k = order as usize;
        let (mu, mv) = self.layout.net_shape();
        let at = |r: usize, c: usize| self.net[r * mv + c];
        let (lo, hi) = self.net.iter().fold(
            (vec![f64::MAX; P::DIM], vec![f64::MIN; P::DIM]),
            |(mut lo, mut hi), p| {
                for c in 0..P::DIM {
                    lo[c] = lo[c].min(p.coord(c));
                    hi[c] = hi[c].max(p.coord(c));
                }
                (lo, hi)
            },
        );
        let diameter = lo
            .iter()
            .zip(&hi)
            .map(|(a, b)| (b - a) * (b - a))
            .sum::<f64>()
            .sqrt();
        // (-1)^i C(k, i)
        let binom: Vec<f64> = (0..=k)
            .map(|i| {
                let c = (0..i).fold(1.0, |acc, j| acc * (k - j) as f64 / (j + 1) as f64);
                if i % 2 == 0 {
                    c
                } else {
                    -c
                }
            })
            .collect();
        let mut worst: f64 = 0.0;
        // `line(i)` is the i-th net point across the border; `join` its index at the border.
        let mut check = |d: usize, hl: f64, hr: f64, join: usize, line: &dyn Fn(usize) -> P| {
            if k == 0 || k > d {
                return;
            }
            let factor = (0..k).fold(1.0, |acc, j| acc * (d - j) as f64);
            let mut left = P::ZERO;
            let mut right = P::ZERO;
            for (i, &w) in binom.iter().enumerate() {
                left += line(join - i) * w;
                right += line(join + k - i) * w;
            }
            let left = left * (factor / hl.powi(order as i32));
            // Forward differences alternate from the far end: (-1)^(k-i) C(k,i) P_{join+i}.
            let right = right * (factor / hr.powi(order as i32));
            let floor = 1e-9 * diameter / hl.min(hr).powi(order as i32);
            let scale = left
                .length()
                .max(right.length())
                .max(floor)
                .max(f64::MIN_POSITIVE);
            worst = worst.max((left - right).length() / scale);
        };
        // Joins across u (every column of the net), then across v (every row).
        for (along_u, dir, lines) in [(true, &self.layout.u, mv), (false, &self.layout.v, mu)] {
            let d = dir.degree();
            for b in 1..dir.segments() {
                let (hl, hr) = (dir.segment_length(b - 1), dir.segment_length(b));
                for line in 0..lines {
                    check(d, hl, hr, b * d, &|k| {
                        if along_u {
                            at(k, line)
                        } else {
                            at(line, k)
                        }
                    });
                }
            }
        }
        worst
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::chain::Continuity;
    use glam::DVec3;
    use proptest::prelude::*;
    use std::ops::Range;

    #[test]
    fn the_papers_blade_net() {
        let u = ChainLayout::uniform(3, 4, Continuity::C1).unwrap();
        let v = ChainLayout::uniform(3, 2, Continuity::C1).unwrap();
        let g = GridLayout::new(u, v);
        assert_eq!(g.design_shape(), (10, 6));
        assert_eq!(g.net_shape(), (13, 7));
        assert_eq!(g.patches(), (4, 2));
    }

    proptest! {
        #[test]
        fn c1_across_every_border((deg, patches, seed, warp) in grid_cases(2..5, 1..4, 400)) {
            let grid = random_grid(deg, patches, [Continuity::C1, Continuity::C1], warp, &seed);
            prop_assert!(grid.continuity_error() < 1e-9, "jump {}", grid.continuity_error());
            // And the surface itself: the cross-border derivative from both sides agrees.
            let (p0, _, _) = grid.partials(0.37, 0.61);
            prop_assert!((p0 - grid.eval(0.37, 0.61)).length() < 1e-14);
        }
    }

    proptest! {
        #[test]
        fn a_cut_net_evaluates_as_the_grid((deg, patches, seed, warp) in grid_cases(2..6, 1..4, 300)) {
            let grid = random_grid(deg, patches, [Continuity::C1, Continuity::C1], warp, &seed);
            let u = &grid.layout().u;
            for v in [0.0, 0.23, 0.5, 0.91, 1.0] {
                let net = grid.cut_net(v);
                prop_assert_eq!(net.len(), grid.layout().net_shape().0);
                for t in [0.0, 0.11, 0.5, 0.77, 1.0] {
                    let (i, a) = u.locate(t);
                    let p = crate::bezier::BezierCurve::new(net[i * u.degree()..=(i + 1) * u.degree()].to_vec()).eval(a);
                    prop_assert!((p - grid.eval(t, v)).length() < 1e-13, "at ({t}, {v})");
                }
            }
        }
    }

    /// Degrees and patch counts along u and v drawn from `deg` and `patches`, `seeds` values for
    /// the design points, and the warps of the breaks along u and v.
    fn grid_cases(
        deg: Range<usize>,
        patches: Range<usize>,
        seeds: usize,
    ) -> impl Strategy<Value = ([usize; 2], [usize; 2], Vec<f64>, [f64; 2])> {
        use prop::array::uniform2;
        let seed = prop::collection::vec(-1.0f64..1.0, seeds);
        (uniform2(deg), uniform2(patches), seed, uniform2(0.2f64..0.8))
    }

    fn random_grid(
        deg: [usize; 2],
        patches: [usize; 2],
        cont: [Continuity; 2],
        warp: [f64; 2],
        seed: &[f64],
    ) -> PatchGrid<DVec3> {
        let chain = |k: usize| {
            let p = patches[k];
            let b: Vec<f64> = (0..=p)
                .map(|i| (i as f64 / p as f64).powf(warp[k] + 0.5))
                .collect();
            ChainLayout::with_breaks(deg[k], b, cont[k]).unwrap()
        };
        let g = GridLayout::new(chain(0), chain(1));
        let (nu, nv) = g.design_shape();
        let design = (0..nu * nv)
            .map(|i| {
                DVec3::new(
                    seed[3 * i % seed.len()],
                    seed[(3 * i + 1) % seed.len()],
                    seed[(3 * i + 2) % seed.len()],
                )
            })
            .collect();
        PatchGrid::new(g, design).unwrap()
    }

    proptest! {
        #[test]
        fn c2_across_every_border_and_mixed_continuity(
            (deg, [pu, pv], seed, warp) in grid_cases(3..6, 1..5, 600),
        ) {
            let both = random_grid(deg, [pu, pv], [Continuity::C2, Continuity::C2], warp, &seed);
            prop_assert!(both.derivative_jump(1) < 1e-9, "C1 jump {}", both.derivative_jump(1));
            prop_assert!(both.derivative_jump(2) < 1e-8, "C2 jump {}", both.derivative_jump(2));
            // C1 along u, C2 along v: first derivatives continuous everywhere; the v borders
            // alone are C2 (measured on a grid with no u borders).
            let mixed = random_grid(deg, [1, pv], [Continuity::C1, Continuity::C2], warp, &seed);
            prop_assert!(mixed.derivative_jump(2) < 1e-8);
            let mixed = random_grid(deg, [pu, pv], [Continuity::C1, Continuity::C2], warp, &seed);
            prop_assert!(mixed.derivative_jump(1) < 1e-9);
            // C0 joins share points only: with random design points the tangents jump.
            if pu > 1 {
                let c0 = random_grid(deg, [pu, 1], [Continuity::C0, Continuity::C1], warp, &seed);
                prop_assert!(c0.derivative_jump(1) > 1e-6);
            }
        }

        #[test]
        fn the_net_is_the_tensor_product_of_the_two_chain_maps(
            du in 2usize..5, dv in 2usize..5, pu in 1usize..4, pv in 1usize..4,
            seed in prop::collection::vec(-1.0f64..1.0, 300),
        ) {
            let grid = random_grid([du, dv], [pu, pv], [Continuity::C1, Continuity::C1], [0.5, 0.3], &seed);
            let l = grid.layout();
            let (eu, ev) = (l.u.map().to_dense(), l.v.map().to_dense());
            let ((nu, nv), (mu, mv)) = (l.design_shape(), l.net_shape());
            for r in 0..mu {
                for c in 0..mv {
                    let mut want = DVec3::ZERO;
                    for i in 0..nu {
                        for j in 0..nv {
                            want += grid.design()[i * nv + j] * (eu[r * nu + i] * ev[c * nv + j]);
                        }
                    }
                    prop_assert!((grid.net()[r * mv + c] - want).length() < 1e-12);
                }
            }
        }
    }

    #[test]
    fn a_collapsed_edge_is_not_a_jump() {
        // A cone: the v = 1 edge of every patch is one point, so derivatives across the u
        // borders there are rounding noise.
        let layout = GridLayout::uniform((3, 3), (3, 1), Continuity::C1).unwrap();
        let design: Vec<DVec3> = layout.design_from(|a, b| {
            let ang = 2.0 * a;
            DVec3::new((1.0 - b) * ang.cos(), (1.0 - b) * ang.sin(), b) + DVec3::splat(0.1)
        });
        let grid = PatchGrid::new(layout, design).unwrap();
        assert!(grid.continuity_error() < 1e-9, "{}", grid.continuity_error());
    }

    /// A grid on `u` x `v` whose design point `(i, j)` is `(i, j, ((i nv + j) 7 mod 5) / 10)`.
    fn stepped(u: ChainLayout, v: ChainLayout) -> PatchGrid<DVec3> {
        let g = GridLayout::new(u, v);
        let (nu, nv) = g.design_shape();
        let design: Vec<DVec3> = (0..nu * nv)
            .map(|i| DVec3::new((i / nv) as f64, (i % nv) as f64, ((i * 7) % 5) as f64 * 0.1))
            .collect();
        PatchGrid::new(g, design).unwrap()
    }

    #[test]
    fn partial_derivatives_are_continuous_at_a_border() {
        let u = ChainLayout::with_breaks(3, vec![0.0, 0.3, 1.0], Continuity::C1).unwrap();
        let v = ChainLayout::with_breaks(2, vec![0.0, 0.6, 1.0], Continuity::C1).unwrap();
        let grid = stepped(u, v);
        let h = 1e-9;
        for &v in &[0.1, 0.5, 0.9] {
            let (_, a, _) = grid.partials(0.3 - h, v);
            let (_, b, _) = grid.partials(0.3 + h, v);
            assert!((a - b).length() < 1e-6 * a.length());
        }
        for &u in &[0.1, 0.5, 0.9] {
            let (_, _, a) = grid.partials(u, 0.6 - h);
            let (_, _, b) = grid.partials(u, 0.6 + h);
            assert!((a - b).length() < 1e-6 * a.length());
        }
    }

    #[test]
    fn partials_on_a_sample_grid_are_the_partials_bit_for_bit() {
        let u = ChainLayout::with_breaks(4, vec![0.0, 0.2, 0.35, 1.0], Continuity::C2).unwrap();
        let v = ChainLayout::with_breaks(3, vec![0.0, 0.6, 1.0], Continuity::C1).unwrap();
        let grid = stepped(u, v);
        // Breaks, ends and points between them.
        let us: Vec<f64> = (0..=40).map(|k| k as f64 / 40.0).chain([0.2, 0.35]).collect();
        let vs: Vec<f64> = (0..=25).map(|k| k as f64 / 25.0).chain([0.6]).collect();
        let on = grid.partials_on(&us, &vs);
        for (a, &u) in us.iter().enumerate() {
            for (b, &v) in vs.iter().enumerate() {
                let (_, pu, pv) = grid.partials(u, v);
                assert_eq!(on[a][b], (pu, pv), "at ({u}, {v})");
            }
        }
    }
}
