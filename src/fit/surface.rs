//! `fit_surface`: one call from a 3D cloud and a patch-grid layout to a fitted grid, with the
//! closest-point offsets and the solver's effort (what the CLI's `fit-surface` reports).
//!
//! The fit is the joint Levenberg-Marquardt of [`mod@crate::optim::lsq`] (design net and every
//! point's `(u, v)` together, the parameters eliminated blockwise), so each iteration costs `O(n)`
//! in the number of points plus a banded solve independent of `n`. Large clouds are fitted in two
//! stages: a random subsample of [`SurfaceOptions::subsample`] points is fitted to convergence from
//! the initial parameters (see [`mod@crate::problem::param`]); then every point is projected onto
//! that surface (Newton's method from its own initial parameters) and a few joint iterations on the
//! whole cloud ([`SurfaceOptions::polish_iterations`]) let every point count. The reported offsets
//! are true closest-point distances, found by a global search warm-started from the final
//! parameters.

use super::grid_evo::fit_grid_evo;
use crate::chain::{ChainLayout, Continuity, GridLayout, PatchGrid};
use crate::error::{Error, Result};
use crate::geometry::{Blade, Grid};
use crate::keyword::keywords;
use crate::optim::evo::{EvoHooks, EvoOptions};
use crate::optim::hybrid::EvoSummary;
use crate::optim::lsq::{lsq, LsqFit, LsqHooks, LsqIterate, LsqOptions, Start};
use crate::optim::method::Method;
use crate::optim::report::{SolveReport, StopReason};
use crate::problem::offset::{Metric, OffsetStats};
use crate::problem::param::{blade_params, section_params, BladeParamOptions, SpanAxis};
use crate::problem::GridProblem;
use glam::DVec3;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use std::path::Path;
use std::time::Instant;

/// `--method` of a surface fit: one of [`Method::SURFACE`]; a method of curve fits alone is
/// refused by saying so.
pub fn parse_surface_method(s: &str) -> Result<Method> {
    match Method::parse_among(s, Method::CURVE) {
        Ok(m) if !Method::SURFACE.contains(&m) => Err(Error::invalid(format!(
            "method '{s}' is for curves only (surfaces: {})",
            Method::names(Method::SURFACE).join(", ")
        ))),
        _ => Method::parse_among(s, Method::SURFACE),
    }
}

/// Where the breaks of one direction of a patch grid go.
#[derive(Clone, Debug, PartialEq)]
pub enum Breaks {
    /// Equal patches.
    Uniform,
    /// Parameters in `[0, 1]`: the interior breaks (one fewer than the patches), or all of
    /// them from 0 to 1.
    Params(Vec<f64>),
    /// Positions along the span axis in model units (for `v` only, e.g. a blade's station
    /// radii): the interior breaks, or all of them (the first and last then stand for the
    /// cloud's ends). They are mapped to `v` the way the data points' initial parameters are.
    Span(Vec<f64>),
}

impl Breaks {
    /// Breaks from text: `uniform`; `span:R1,R2,...`, positions along the span axis; `stations:
    /// BLADE`, the station radii of a blade file (its reader's warnings go to `warn`); or
    /// parameters `T1,T2,...` in `[0, 1]`.
    pub fn parse(text: &str, warn: &mut dyn FnMut(&Path, &str)) -> Result<Breaks> {
        let numbers = |list: &str| -> Result<Vec<f64>> {
            list.split(',')
                .map(|t| match t.trim().parse::<f64>() {
                    Ok(v) if v.is_finite() => Ok(v),
                    Ok(_) => Err(Error::invalid(format!("'{}' is not a finite number", t.trim()))),
                    Err(_) => Err(Error::invalid(format!("'{}' is not a number", t.trim()))),
                })
                .collect()
        };
        let text = text.trim();
        if text.eq_ignore_ascii_case("uniform") {
            Ok(Breaks::Uniform)
        } else if let Some(list) = text.strip_prefix("span:") {
            Ok(Breaks::Span(numbers(list)?))
        } else if let Some(file) = text.strip_prefix("stations:") {
            let path = Path::new(file);
            let blade = Blade::from_file(path)?;
            blade.warnings.iter().for_each(|w| warn(path, w));
            Ok(Breaks::Span(blade.stations.iter().map(|s| s.radius).collect()))
        } else {
            Ok(Breaks::Params(numbers(text)?))
        }
    }
}

/// A patch-grid layout to fit: degrees, patches, continuity and breaks per direction
/// (`[u, v]`), with breaks that may depend on the cloud (see [`Breaks::Span`]).
#[derive(Clone, Debug, PartialEq)]
pub struct SurfaceLayout {
    /// `[du, dv]`.
    pub degree: [usize; 2],
    /// `[pu, pv]`.
    pub patches: [usize; 2],
    /// Continuity across the patch borders along u and along v.
    pub continuity: [Continuity; 2],
    /// Breaks along u.
    pub breaks_u: Breaks,
    /// Breaks along v.
    pub breaks_v: Breaks,
}

impl From<&GridLayout> for SurfaceLayout {
    fn from(l: &GridLayout) -> Self {
        SurfaceLayout {
            degree: [l.u.degree(), l.v.degree()],
            patches: [l.u.segments(), l.v.segments()],
            continuity: [l.u.continuity(), l.v.continuity()],
            breaks_u: Breaks::Params(l.u.breaks().to_vec()),
            breaks_v: Breaks::Params(l.v.breaks().to_vec()),
        }
    }
}

impl SurfaceLayout {
    /// Uniform breaks in both directions.
    #[must_use]
    pub fn uniform(degree: [usize; 2], patches: [usize; 2], continuity: [Continuity; 2]) -> Self {
        SurfaceLayout {
            degree,
            patches,
            continuity,
            breaks_u: Breaks::Uniform,
            breaks_v: Breaks::Uniform,
        }
    }

    /// The grid layout on a unit span (`v` from 0 to 1 along z), for the checks that need no
    /// cloud.
    pub fn unit_layout(&self) -> Result<GridLayout> {
        self.grid_layout(&SpanAxis {
            dir: DVec3::Z,
            lo: 0.0,
            hi: 1.0,
        })
    }

    /// The design net's shape `(nu, nv)` (it does not depend on the span), or `None` when the
    /// layout cannot be built without the cloud.
    #[must_use]
    pub fn design_shape(&self) -> Option<(usize, usize)> {
        self.unit_layout().ok().map(|g| g.design_shape())
    }

    /// Refuse a design net with more points than the `n` points of `cloud` can determine; a
    /// layout that cannot be built without the cloud's span passes here, the fit checks it.
    pub fn check_points(&self, n: usize, cloud: &Path) -> Result<()> {
        match self.design_shape() {
            Some((nu, nv)) if nu * nv > n => Err(Error::invalid(format!(
                "a {nu} x {nv} design net is more than the {n} points of {} can determine (at \
                 least {} are needed); ask for fewer patches",
                cloud.display(),
                nu * nv
            ))),
            _ => Ok(()),
        }
    }

    /// The grid layout, with span positions mapped to `v` along `axis`.
    pub fn grid_layout(&self, axis: &SpanAxis) -> Result<GridLayout> {
        let chain = |k: usize, breaks: &Breaks, name: &str| -> Result<ChainLayout> {
            let (d, p, c) = (self.degree[k], self.patches[k], self.continuity[k]);
            if p == 0 {
                return Err(Error::invalid(format!("patches along {name} must be at least 1")));
            }
            let values: Vec<f64> = match breaks {
                Breaks::Uniform => {
                    return ChainLayout::uniform(d, p, c)
                        .map_err(|e| Error::invalid(format!("layout along {name}: {e}")))
                }
                Breaks::Params(b) => b.clone(),
                Breaks::Span(_) if k == 0 => {
                    return Err(Error::invalid(
                        "breaks along u cannot be span positions (u runs around the section)",
                    ))
                }
                Breaks::Span(b) => b.iter().map(|&s| (s - axis.lo) / (axis.hi - axis.lo)).collect(),
            };
            let full = if values.len() + 1 == p {
                std::iter::once(0.0)
                    .chain(values)
                    .chain(std::iter::once(1.0))
                    .collect()
            } else if values.len() == p + 1 {
                let mut v = values;
                if matches!(breaks, Breaks::Span(_)) {
                    v[0] = 0.0;
                    v[p] = 1.0;
                }
                v
            } else {
                return Err(Error::invalid(format!(
                    "breaks along {name}: {} values for {p} patches (give the {} interior breaks, or all {})",
                    values.len(),
                    p - 1,
                    p + 1
                )));
            };
            if full.iter().any(|b| !b.is_finite())
                || full.windows(2).any(|w| w[1] <= w[0])
                || full[0] != 0.0
                || full[p] != 1.0
            {
                return Err(Error::invalid(format!(
                    "breaks along {name} must increase strictly from 0 to 1 (as parameters: {})",
                    full.iter()
                        .map(|b| format!("{b:.6}"))
                        .collect::<Vec<_>>()
                        .join(", ")
                )));
            }
            ChainLayout::with_breaks(d, full, c)
                .map_err(|e| Error::invalid(format!("layout along {name}: {e}")))
        };
        Ok(GridLayout::new(
            chain(0, &self.breaks_u, "u")?,
            chain(1, &self.breaks_v, "v")?,
        ))
    }
}

/// Where the initial `(u, v)` of the data points come from.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum ParamSource {
    /// From the sections when the cloud has them, else blade-aware. The default.
    #[default]
    Auto,
    /// From the sections ([`section_params`]); an error for an unordered cloud.
    Sections,
    /// Blade-aware, ignoring any sections ([`blade_params`]).
    Blade,
}

keywords!(ParamSource, "parameterisation", { Auto => "auto", Sections => "sections", Blade => "blade" });

/// Everything [`fit_surface`] needs besides the data and the layout.
#[derive(Clone, Debug, PartialEq)]
pub struct SurfaceOptions {
    /// The method, one of [`Method::SURFACE`]. Default least squares.
    pub method: Method,
    /// Where the initial parameters come from. Default [`ParamSource::Auto`].
    pub params: ParamSource,
    /// Options of the blade-aware parameterisation.
    pub blade: BladeParamOptions,
    /// The Levenberg-Marquardt options of the main fit (the subsample, or the whole cloud when
    /// it is small). Default: at most 100 iterations, converged when 3 iterations gain less
    /// than 1e-4 of the sum of squares (on noisy clouds the iteration then only slides the
    /// parameters along the surface), initial damping 1e-3, one global foot-point check.
    pub lsq: LsqOptions,
    /// Clouds with more points than this are fitted on a subsample of about this many first
    /// (an equal share from every patch, plus the points nearest the four edges). 0 never
    /// subsamples. Default 20,000.
    pub subsample: usize,
    /// Joint iterations on the whole cloud after a subsample fit. Default 2.
    pub polish_iterations: usize,
    /// Seed of the subsample. Default 0.
    pub seed: u64,
    /// Options of the evolutionary methods (population, generations, backend, seed, ...).
    /// Default [`EvoOptions::default`].
    pub evo: EvoOptions,
}

impl Default for SurfaceOptions {
    fn default() -> Self {
        SurfaceOptions {
            method: Method::Lsq,
            params: ParamSource::Auto,
            blade: BladeParamOptions::default(),
            lsq: LsqOptions {
                max_iterations: 100,
                ftol: 1e-4,
                window: 3,
                initial_damping: 1e-3,
                global_checks: 1,
                ..LsqOptions::default()
            },
            subsample: 20_000,
            polish_iterations: 2,
            seed: 0,
            evo: EvoOptions::default(),
        }
    }
}

/// The name of the whole-cloud stage after a subsample fit: a fixed number of joint
/// iterations over every point (`SurfaceOptions::polish_iterations`).
const POLISH_STAGE: &str = "full";

/// One stage of a surface fit.
#[derive(Clone, Debug, PartialEq)]
pub struct SurfaceStage {
    /// `subsample`, `full` (the whole cloud after a subsample fit) or `lsq` (the whole cloud
    /// in one stage); for the evolutionary methods `ga` or `cmaes`, then `lsq` for the polish
    /// (on the subsample when there is one).
    pub name: &'static str,
    /// Points the stage fitted.
    pub points: usize,
    /// The stage's solver report.
    pub report: SolveReport,
}

/// What [`fit_surface`] tells its caller while it runs (the library never prints).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SurfaceProgress {
    /// The initial parameters are ready (`source` says which method made them).
    Params {
        /// `sections` or `blade`.
        source: &'static str,
        /// Seconds spent.
        seconds: f64,
    },
    /// A stage starts.
    Stage {
        /// The stage's name (see [`SurfaceStage::name`]).
        name: &'static str,
        /// Points it fits.
        points: usize,
    },
    /// A Levenberg-Marquardt iteration ended.
    Iteration(LsqIterate),
    /// The final closest-point search over every point starts.
    Offsets {
        /// Points measured.
        points: usize,
    },
}

/// A fitted patch grid with its offsets and the effort spent.
#[derive(Clone, Debug, PartialEq)]
pub struct SurfaceFit {
    /// The fitted grid.
    pub grid: PatchGrid<DVec3>,
    /// The closest-point parameters `(u, v)` of every data point.
    pub params: Vec<[f64; 2]>,
    /// True closest-point offsets of every data point, in f64.
    pub stats: OffsetStats<DVec3>,
    /// The span axis the parameters were measured along.
    pub axis: SpanAxis,
    /// `sections` or `blade`: where the initial parameters came from.
    pub param_source: &'static str,
    /// The stages, in order.
    pub stages: Vec<SurfaceStage>,
    /// Iterations and evaluations summed over the stages, wall-clock seconds of the whole fit
    /// (parameters and final offsets included), and the stop of the stage that decides how
    /// the fit ended (see [`SurfaceFit::stopped`]).
    pub report: SolveReport,
    /// The evolutionary run (backend, throughput, stop) for the evolutionary methods.
    pub evolution: Option<EvoSummary>,
}

impl SurfaceFit {
    /// The cap that cut the fit short: that of `report.stop`, the least-squares stage's (an
    /// evolutionary method's polish included; not the generation limit, nor the whole-cloud
    /// polish's fixed iterations); `None` when the fit stopped on its own.
    #[must_use]
    pub fn stopped(&self) -> Option<&'static str> {
        self.report.cap()
    }
}

/// The stage whose end is the fit's: the least-squares stage, an evolutionary method's polish
/// included. A generation limit is the evolutionary stage's own end, and the whole-cloud
/// polish after a subsample fit runs its fixed number of iterations by design: neither says
/// whether the fit converged. `None` for an evolutionary method without a polish.
fn deciding_stage(stages: &[SurfaceStage], evolution: bool) -> Option<&SurfaceStage> {
    stages
        .iter()
        .skip(usize::from(evolution))
        .find(|s| s.name != POLISH_STAGE)
}

/// Initial parameters of a cloud, and the name of the method that made them.
pub fn initial_params(
    points: &[DVec3],
    grid: Option<Grid>,
    opts: &SurfaceOptions,
) -> Result<(Vec<[f64; 2]>, SpanAxis, &'static str)> {
    match (opts.params, grid) {
        (ParamSource::Sections | ParamSource::Auto, Some(g)) => {
            let (p, a) = section_params(points, g, opts.blade.span)?;
            Ok((p, a, "sections"))
        }
        (ParamSource::Sections, None) => Err(Error::invalid(
            "parameters from sections need a structured cloud (CSV with section,index columns)",
        )),
        (ParamSource::Blade | ParamSource::Auto, _) => {
            let (p, a) = blade_params(points, &opts.blade)?;
            Ok((p, a, "blade"))
        }
    }
}

/// The indices of a subsample of about `count` points, sorted, without repeats: an equal
/// share of random points from every patch (by the initial parameters; a patch with fewer
/// points gives all it has, so small patches, like the blade's last span before the tip, keep
/// their data), plus the `count / 50` points with the smallest and with the largest initial
/// `u` and `v` each, so that the four edges of the surface keep theirs (a random 2% of the
/// root section leaves the edge there free to pull back).
fn subsample(params: &[[f64; 2]], layout: &GridLayout, count: usize, seed: u64) -> Vec<usize> {
    let n = params.len();
    let (pu, pv) = layout.patches();
    let mut by_cell: Vec<Vec<usize>> = vec![Vec::new(); pu * pv];
    for (j, t) in params.iter().enumerate() {
        let (a, _) = layout.u.locate(t[0]);
        let (b, _) = layout.v.locate(t[1]);
        by_cell[a * pv + b].push(j);
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let quota = count.div_ceil(pu * pv).max(1);
    let mut idx = Vec::with_capacity(count + count / 10);
    for cell in &by_cell {
        if cell.len() <= quota {
            idx.extend_from_slice(cell);
        } else {
            idx.extend(
                rand::seq::index::sample(&mut rng, cell.len(), quota)
                    .into_iter()
                    .map(|k| cell[k]),
            );
        }
    }
    let edge = (count / 50).min(n / 4);
    if edge > 0 {
        let mut order: Vec<usize> = (0..n).collect();
        for k in 0..2 {
            let key = |i: &usize| params[*i][k];
            order.select_nth_unstable_by(edge, |a, b| key(a).total_cmp(&key(b)));
            idx.extend_from_slice(&order[..edge]);
            order.select_nth_unstable_by(n - 1 - edge, |a, b| key(a).total_cmp(&key(b)));
            idx.extend_from_slice(&order[n - edge..]);
        }
    }
    idx.sort_unstable();
    idx.dedup();
    idx
}

/// Fit a patch grid of `layout` to `points` (with their section structure when known) by
/// closest-point least squares or an evolutionary method; see the module docs for the stages.
pub fn fit_surface(
    points: &[DVec3],
    grid: Option<Grid>,
    layout: &SurfaceLayout,
    opts: &SurfaceOptions,
    progress: &mut dyn FnMut(SurfaceProgress),
) -> Result<SurfaceFit> {
    fit_surface_with(points, grid, layout, opts, progress, &mut EvoHooks::default())
}

/// What the main stage ends with.
struct MainStage {
    /// The fitted design net.
    design: Vec<DVec3>,
    /// The parameters of the stage's points on it.
    params: Vec<[f64; 2]>,
    /// The evolutionary run, for the evolutionary methods.
    evolution: Option<EvoSummary>,
}

/// The main stage on `problem` (a subsample, or the whole cloud) from its parameters: least
/// squares, or the evolutionary method from the linear least-squares start (then the polish
/// when the method has one). Pushes the stages run; returns the design, the parameters on it
/// and the evolutionary summary.
fn main_stage(
    problem: &GridProblem<'_, DVec3>,
    layout: &GridLayout,
    name: &'static str,
    opts: &SurfaceOptions,
    progress: &mut dyn FnMut(SurfaceProgress),
    hooks: &mut EvoHooks<'_>,
    stages: &mut Vec<SurfaceStage>,
) -> Result<MainStage> {
    let points = problem.points().len();
    let start = problem.linear_fit(problem.params())?;
    let Some((algorithm, polish)) = opts.method.evolutionary() else {
        progress(SurfaceProgress::Stage { name, points });
        let fit = observed_lsq(
            problem,
            Start::Design(start, problem.params().to_vec()),
            &opts.lsq,
            progress,
        )?;
        stages.push(SurfaceStage {
            name,
            points,
            report: fit.report,
        });
        return Ok(MainStage {
            design: fit.design,
            params: fit.params,
            evolution: None,
        });
    };
    progress(SurfaceProgress::Stage {
        name: algorithm.name(),
        points,
    });
    let fit = fit_grid_evo(
        problem.points(),
        problem.params().to_vec(),
        layout.clone(),
        &start,
        algorithm,
        polish,
        &opts.evo,
        &opts.lsq,
        hooks,
    )?;
    for (k, st) in fit.summary.stages.iter().enumerate() {
        stages.push(SurfaceStage {
            name: if k == 0 { algorithm.name() } else { "lsq" },
            points,
            report: st.report,
        });
    }
    let design = fit.grid.design().to_vec();
    let mut params = problem.params().to_vec();
    problem.project(&design, &mut params);
    Ok(MainStage {
        design,
        params,
        evolution: Some(fit.summary),
    })
}

/// One least-squares fit from `start`, every iteration reported to `progress`.
fn observed_lsq(
    problem: &GridProblem<'_, DVec3>,
    start: Start<DVec3, 2>,
    opts: &LsqOptions,
    progress: &mut dyn FnMut(SurfaceProgress),
) -> Result<LsqFit<DVec3, 2>> {
    let mut observe = |it: &LsqIterate, _: &[DVec3], _: &[[f64; 2]]| {
        progress(SurfaceProgress::Iteration(*it));
        true
    };
    let hooks = LsqHooks {
        guard: None,
        observe: Some(&mut observe),
    };
    lsq(problem, &[start], opts, hooks)?
        .pop()
        .ok_or_else(|| Error::Numerical("lsq: no fit".into()))
}

/// How far, in diagonals of the cloud's bounding box, a fitted control point may lie outside
/// that box: a net that reaches further has patches the cloud does not hold in place (too few
/// points across them), and its surface, exported to CAD, bulges far off the blade.
pub const NET_REACH: f64 = 10.0;

/// Refuse a control net that leaves the bounding box of `points` by more than [`NET_REACH`]
/// times its diagonal, with advice (an input error: the layout asked for is the cause).
pub fn check_net_bounded(points: &[DVec3], net: &[DVec3]) -> Result<()> {
    let lo = points.iter().fold(DVec3::splat(f64::INFINITY), |a, &p| a.min(p));
    let hi = points
        .iter()
        .fold(DVec3::splat(f64::NEG_INFINITY), |a, &p| a.max(p));
    let diagonal = (hi - lo).length();
    let outside = |p: DVec3| {
        if p.is_finite() {
            (lo - p).max(p - hi).max(DVec3::ZERO).length()
        } else {
            f64::INFINITY
        }
    };
    let Some((k, far)) = net
        .iter()
        .map(|&p| outside(p))
        .enumerate()
        .max_by(|a, b| a.1.total_cmp(&b.1))
    else {
        return Ok(());
    };
    if far.is_finite() && far <= NET_REACH * diagonal {
        return Ok(());
    }
    Err(Error::invalid(format!(
        "the fitted control net leaves the cloud's bounding box by {far:.4e} ({:.0} times its \
         diagonal of {diagonal:.4e}) at control point {k}: some patches have too few points across \
         them to hold them in place. Use fewer patches, breaks that leave several of the data's \
         sections in every patch, or adapt-surface, which chooses the layout",
        far / diagonal
    )))
}

/// [`fit_surface`] with hooks into an evolutionary run (progress, checkpoints, resume).
pub fn fit_surface_with(
    points: &[DVec3],
    grid: Option<Grid>,
    layout: &SurfaceLayout,
    opts: &SurfaceOptions,
    progress: &mut dyn FnMut(SurfaceProgress),
    hooks: &mut EvoHooks<'_>,
) -> Result<SurfaceFit> {
    let clock = Instant::now();
    if !Method::SURFACE.contains(&opts.method) {
        return Err(Error::invalid(format!(
            "{} is not a method of surface fits",
            opts.method
        )));
    }
    if let Some(j) = points.iter().position(|p| !p.is_finite()) {
        return Err(Error::invalid(format!(
            "data point {j} has a non-finite coordinate"
        )));
    }
    let (mut params, axis, source) = initial_params(points, grid, opts)?;
    let layout = layout.grid_layout(&axis)?;
    let (nu, nv) = layout.design_shape();
    if points.len() < nu * nv {
        return Err(Error::invalid(format!(
            "{} data points cannot determine a {nu} x {nv} design net: at least {} are needed",
            points.len(),
            nu * nv
        )));
    }
    progress(SurfaceProgress::Params {
        source,
        seconds: clock.elapsed().as_secs_f64(),
    });
    let n = points.len();
    let sub = opts.subsample > 0 && n > opts.subsample && opts.subsample >= nu * nv;
    let mut stages = Vec::new();
    let full = GridProblem::grid(layout.clone(), points, params.clone(), Metric::Closest)?;
    let (design, evolution) = if sub {
        let idx = subsample(&params, &layout, opts.subsample, opts.seed);
        let sub_points: Vec<DVec3> = idx.iter().map(|&i| points[i]).collect();
        let sub_params: Vec<[f64; 2]> = idx.iter().map(|&i| params[i]).collect();
        let problem = GridProblem::grid(layout.clone(), &sub_points, sub_params, Metric::Closest)?;
        let MainStage {
            design, evolution, ..
        } = main_stage(&problem, &layout, "subsample", opts, progress, hooks, &mut stages)?;
        // The whole cloud: Levenberg-Marquardt first moves every point to its own foot point on
        // the subsample's surface (Newton's method from its initial parameters).
        let polish = LsqOptions {
            max_iterations: opts.polish_iterations,
            global_checks: 0,
            ..opts.lsq
        };
        let polished = opts.method.evolutionary().is_none_or(|(_, p)| p);
        if opts.polish_iterations > 0 && polished {
            progress(SurfaceProgress::Stage {
                name: POLISH_STAGE,
                points: n,
            });
            let fit = observed_lsq(&full, Start::Design(design, params), &polish, progress)?;
            params = fit.params;
            stages.push(SurfaceStage {
                name: POLISH_STAGE,
                points: n,
                report: fit.report,
            });
            (fit.design, evolution)
        } else {
            full.project(&design, &mut params);
            (design, evolution)
        }
    } else {
        let stage = main_stage(&full, &layout, "lsq", opts, progress, hooks, &mut stages)?;
        params = stage.params;
        (stage.design, stage.evolution)
    };
    progress(SurfaceProgress::Offsets { points: n });
    let (stats, feet) = full.closest_stats(&design, Some(&params));
    let grid = full.patch_grid(&design)?;
    check_net_bounded(points, grid.net())?;
    let (iterations, evaluations) = stages.iter().fold((0, 0), |(i, e), s| {
        (i + s.report.iterations, e + s.report.evaluations)
    });
    let stop = deciding_stage(&stages, evolution.is_some()).map_or(StopReason::Converged, |s| s.report.stop);
    Ok(SurfaceFit {
        grid,
        params: feet,
        stats,
        axis,
        param_source: source,
        stages,
        report: SolveReport {
            iterations,
            evaluations: evaluations + 1,
            seconds: clock.elapsed().as_secs_f64(),
            stop,
        },
        evolution,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A net of more design points than the cloud has is refused, naming the cloud and the
    /// count needed; a layout that needs the cloud's span is left to the fit.
    #[test]
    fn a_net_larger_than_the_cloud_is_refused() {
        let layout = SurfaceLayout {
            degree: [3, 3],
            patches: [2, 1],
            continuity: [Continuity::C1, Continuity::C1],
            breaks_u: Breaks::Uniform,
            breaks_v: Breaks::Uniform,
        };
        let (nu, nv) = layout.design_shape().unwrap();
        let cloud = Path::new("c.csv");
        assert!(layout.check_points(nu * nv, cloud).is_ok());
        let e = layout.check_points(nu * nv - 1, cloud).unwrap_err();
        assert!(e.is_user_error());
        assert_eq!(
            e.to_string(),
            format!(
                "a {nu} x {nv} design net is more than the {} points of c.csv can determine (at \
                 least {} are needed); ask for fewer patches",
                nu * nv - 1,
                nu * nv
            )
        );
        // A break at radius 10 lies beyond the unit span: the net waits for the cloud's.
        let span = SurfaceLayout {
            patches: [2, 2],
            breaks_v: Breaks::Span(vec![10.0]),
            ..layout
        };
        assert_eq!(span.design_shape(), None);
        assert!(span.check_points(1, cloud).is_ok());
    }

    /// A net inside the cloud's box, or out by a few diagonals, passes; one 30 km from a 100 m
    /// blade is refused, naming the distance and advice.
    #[test]
    fn control_nets_far_outside_the_cloud_are_refused() {
        let cloud = [DVec3::ZERO, DVec3::new(4.0, 1.0, 100.0)];
        let diag = cloud[1].length();
        let ok = [
            DVec3::new(2.0, 0.5, 50.0),
            DVec3::new(4.0 + 5.0 * diag, 1.0, 100.0),
        ];
        assert!(check_net_bounded(&cloud, &ok).is_ok());
        let far = [DVec3::new(2.0, 0.5, 50.0), DVec3::new(2.0, 30_000.0, 50.0)];
        let e = check_net_bounded(&cloud, &far).unwrap_err();
        assert!(e.is_user_error());
        let msg = e.to_string();
        assert!(
            msg.contains("control point 1") && msg.contains("fewer patches"),
            "{msg}"
        );
        let nan = [DVec3::new(f64::NAN, 0.0, 0.0)];
        assert!(check_net_bounded(&cloud, &nan).is_err());
    }

    fn stage(name: &'static str, stop: StopReason) -> SurfaceStage {
        SurfaceStage {
            name,
            points: 10,
            report: SolveReport {
                iterations: 1,
                evaluations: 1,
                seconds: 0.0,
                stop,
            },
        }
    }

    #[test]
    fn the_least_squares_stage_decides_how_a_fit_ended() {
        use StopReason::{Converged, MaxEvaluations, MaxIterations};
        let stop = |stages: &[SurfaceStage], evo: bool| deciding_stage(stages, evo).map(|s| s.report.stop);
        // The subsample stage, not the whole-cloud polish that always ends at its cap.
        let sub = [
            stage("subsample", MaxEvaluations),
            stage(POLISH_STAGE, MaxIterations),
        ];
        assert_eq!(stop(&sub, false), Some(MaxEvaluations));
        let sub = [stage("subsample", Converged), stage(POLISH_STAGE, MaxIterations)];
        assert_eq!(stop(&sub, false), Some(Converged));
        // An evolutionary method's polish, not its generation limit.
        let evo = [stage("ga", MaxIterations), stage("lsq", Converged)];
        assert_eq!(stop(&evo, true), Some(Converged));
        let evo = [
            stage("ga", MaxIterations),
            stage("lsq", MaxEvaluations),
            stage(POLISH_STAGE, MaxIterations),
        ];
        assert_eq!(stop(&evo, true), Some(MaxEvaluations));
        // Without a polish nothing caps it.
        assert_eq!(stop(&[stage("ga", MaxIterations)], true), None);
    }

    /// Break lists parse as parameters, span positions or a blade's stations, and a bad number
    /// is named; a surface fit refuses a method of curves only.
    #[test]
    fn breaks_parse_from_their_text() {
        let mut none = |_: &Path, w: &str| panic!("warning {w}");
        assert_eq!(Breaks::parse(" Uniform ", &mut none).unwrap(), Breaks::Uniform);
        assert_eq!(
            Breaks::parse("0.25, 0.5", &mut none).unwrap(),
            Breaks::Params(vec![0.25, 0.5])
        );
        assert_eq!(
            Breaks::parse("span:10,20.5", &mut none).unwrap(),
            Breaks::Span(vec![10.0, 20.5])
        );
        let e = Breaks::parse("0.5,x", &mut none).unwrap_err().to_string();
        assert_eq!(e, "'x' is not a number");
        let e = Breaks::parse("span:inf", &mut none).unwrap_err().to_string();
        assert_eq!(e, "'inf' is not a finite number");
        let blade = concat!(env!("CARGO_MANIFEST_DIR"), "/data/blade_paper.json");
        match Breaks::parse(&format!("stations:{blade}"), &mut none).unwrap() {
            Breaks::Span(r) => assert!(r.len() > 2 && r.windows(2).all(|w| w[0] < w[1]), "{r:?}"),
            other => panic!("{other:?}"),
        }
        assert_eq!(parse_surface_method("CMA-ES+lsq").unwrap(), Method::CmaesLsq);
        let e = parse_surface_method("nm").unwrap_err().to_string();
        assert_eq!(
            e,
            "method 'nm' is for curves only (surfaces: lsq, ga, cmaes, ga+lsq, cmaes+lsq)"
        );
        let e = parse_surface_method("ga+cmaes").unwrap_err().to_string();
        assert_eq!(
            e,
            "unknown method 'ga+cmaes' (expected lsq, ga, cmaes, ga+lsq or cmaes+lsq)"
        );
        let layout = SurfaceLayout::uniform([3, 3], [4, 2], [Continuity::C1; 2]);
        assert_eq!(layout.design_shape(), Some((10, 6)));
    }
}
