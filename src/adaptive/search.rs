//! The search of Figs. 7 and 8: per family (degree, join continuity, how x and the breaks
//! are stored) grow from a coarse layout by splitting where the error is largest until the
//! tolerance holds, then reduce (remove breaks, lower the degree) while it still holds; the
//! families run in parallel batches, each stopping once it cannot beat the best count the
//! batches before it found;
//! the winner's breaks are then moved to let more of them go.

use super::encoding::{per_side_breaks, Breaks, Encoding, XStore};
use super::engine::{self, Data, Effort, Model, State, XRule, LE_BREAK};
use super::fairness::{chain_samples, Fairness, PER_SEGMENT};
use super::{AdaptOptions, FamilyTrace, HeldOut, Norm};
use crate::chain::ChainLayout;
use glam::DVec2;
use rayon::prelude::*;
use std::collections::HashMap;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

thread_local! {
    /// Fits run on this thread, to attribute them to the family it runs.
    static FAMILY_FITS: std::cell::Cell<usize> = const { std::cell::Cell::new(0) };
}

/// Families run at once ([`Search::run`]): a fixed number, so that results do not depend on
/// the machine's thread count. Two keep both cores of a small machine busy while the bound
/// still prunes early: with four, a 400-point NACA 4412 at 1e-4 took 172 fits and about twice
/// the time (145 fits with two; 153 when every family pruned by whatever bound another thread
/// had set).
const BATCH: usize = 2;

/// Fits while growing and reducing.
const GROW: Effort = Effort {
    iterations: 40,
    ftol: 1e-4,
    minimax: 0,
    give_up: f64::INFINITY,
    give_up_after: 3,
    max_stall: 2,
};
/// A fit that, at its current rate of convergence, cannot bring its largest distance below
/// this many tolerances within its iterations is abandoned: a fit above [`POLISH_RANGE`]
/// tolerances cannot be accepted anyway.
const GIVE_UP: f64 = POLISH_RANGE;
/// [`GIVE_UP`] for free fits, whose convergence along valleys is slow at first and speeds up
/// later (see [`Search::fit`]); they are judged from this iteration on.
const GIVE_UP_FREE: f64 = 8.0;
/// See [`GIVE_UP_FREE`].
const GIVE_UP_FREE_AFTER: usize = 10;
/// Offsets above this many tolerances are *far*: growth then splits every bad segment at
/// once (or adds half as many segments again) instead of one at a time.
const FAR: f64 = 8.0;
/// Breaks whose removal the reduction tries per round (those between the most accurate
/// segments).
const REDUCE_TRIES: usize = 6;
/// Layouts with more segments than this skip the break tuning (its cost grows with the
/// square of the breaks).
const TUNE_MAX_SEGMENTS: usize = 16;
/// Rounds of the minimax polish.
const POLISH_ROUNDS: usize = 40;
/// A least-squares fit whose largest distance is within this factor of the tolerance gets the
/// minimax polish before it is judged.
const POLISH_RANGE: f64 = 2.0;
/// A family stops growing when its best measure improved by less than this fraction over the
/// last `STALL_STEPS` steps.
const STALL_GAIN: f64 = 0.02;
/// See [`STALL_GAIN`].
const STALL_STEPS: usize = 5;

/// How a family places its breaks.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum BreakKind {
    /// Equal segments (per side under the aerofoil rule); nothing stored.
    Uniform,
    /// Anywhere; every break (but the leading edge's) is stored.
    Stored,
}

/// A family of layouts: the outer search's parameters (Fig. 8).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Family {
    pub aerofoil: bool,
    /// Under the aerofoil rule, one trailing-edge x for both surfaces (the data's two ends
    /// share their x).
    pub shared_te: bool,
    pub degree: usize,
    /// Continuity order of the joins (the leading edge's is 1 under the aerofoil rule).
    pub order: usize,
    pub breaks: BreakKind,
}

impl Family {
    /// A readable name, e.g. `aerofoil d5 C4 uniform`.
    pub fn name(&self) -> String {
        format!(
            "{} d{} C{} {}",
            if self.aerofoil { "aerofoil" } else { "free" },
            self.degree,
            self.order,
            match self.breaks {
                BreakKind::Uniform => "uniform",
                BreakKind::Stored => "stored-breaks",
            }
        )
    }

    fn orders(&self, degree: usize, breaks: &[f64]) -> Vec<usize> {
        let k = self.order.min(degree - 1);
        breaks[1..breaks.len() - 1]
            .iter()
            .map(|&b| if self.aerofoil && b == LE_BREAK { 1 } else { k })
            .collect()
    }

    /// The model of this family over `breaks` at `degree`.
    fn model(&self, degree: usize, breaks: Vec<f64>) -> Option<Model> {
        let orders = self.orders(degree, &breaks);
        let layout = ChainLayout::with_orders(degree, breaks, orders).ok()?;
        if self.aerofoil {
            Model::aerofoil(layout, self.shared_te).ok()
        } else {
            Some(Model::free(layout))
        }
    }

    /// Stored scalars of a layout of this family.
    fn count(&self, layout: &ChainLayout) -> usize {
        let n = layout.design_count();
        let stored_breaks = match self.breaks {
            BreakKind::Uniform => 0,
            BreakKind::Stored => layout.segments() - 1 - usize::from(self.aerofoil),
        };
        if self.aerofoil {
            n + 3 - usize::from(self.shared_te) + stored_breaks
        } else {
            2 * n + stored_breaks
        }
    }

    fn initial_breaks(&self) -> Vec<f64> {
        if self.aerofoil {
            vec![0.0, LE_BREAK, 1.0]
        } else {
            vec![0.0, 1.0]
        }
    }
}

/// A fitted candidate.
#[derive(Clone, Debug)]
pub(crate) struct Cand {
    pub fam: Family,
    pub model: Model,
    pub state: State,
    pub count: usize,
}

impl Cand {
    /// A candidate of family `fam`, its stored scalars counted from the model's layout.
    fn new(fam: Family, model: Model, state: State) -> Self {
        let count = fam.count(&model.layout);
        Cand {
            fam,
            model,
            state,
            count,
        }
    }

    /// The stored form of the candidate.
    pub fn encoding(&self) -> Encoding {
        let layout = &self.model.layout;
        let breaks = layout.breaks();
        let inner: Vec<f64> = breaks[1..breaks.len() - 1]
            .iter()
            .copied()
            .filter(|&b| !(self.fam.aerofoil && b == LE_BREAK))
            .collect();
        let stored = match (self.fam.breaks, self.fam.aerofoil) {
            (BreakKind::Stored, _) => Breaks::Stored(inner),
            (BreakKind::Uniform, true) => {
                let first = breaks.iter().filter(|&&b| b < LE_BREAK).count();
                Breaks::UniformPerSide {
                    first,
                    second: layout.segments() - first,
                }
            }
            (BreakKind::Uniform, false) => Breaks::Uniform {
                segments: layout.segments(),
            },
        };
        let x = match self.model.rule {
            XRule::Free => XStore::Free(self.state.coeffs.iter().map(|p| p.x).collect()),
            XRule::Aerofoil { .. } => {
                XStore::AerofoilRule(self.model.theta(&self.state.coeffs).unwrap_or_default())
            }
        };
        Encoding {
            degree: layout.degree(),
            joins: layout.orders().to_vec(),
            breaks: stored,
            x,
            y: self.state.coeffs.iter().map(|p| p.y).collect(),
        }
    }
}

/// Why a family stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Stop {
    Met,
    Pruned,
    Limit,
    Stalled,
    Failed,
}

impl Stop {
    fn name(self) -> &'static str {
        match self {
            Stop::Met => "met",
            Stop::Pruned => "pruned",
            Stop::Limit => "limit",
            Stop::Stalled => "stalled",
            Stop::Failed => "failed",
        }
    }
}

/// A candidate that meets the tolerance is accepted only when its layout also passes the
/// held-out check (refitted on every other data point, the others within
/// [`HELD_OUT_FACTOR`] tolerances), its chain changes the sign of its curvature no more
/// often than the source ([`Fairness`]), and it stays near the source between the data points
/// without turning more than it ([`super::Follows`]).
pub const HELD_OUT_FACTOR: f64 = 3.0;

/// What a candidate meeting the tolerance must also pass, and on which data.
#[derive(Clone, Copy)]
pub(crate) struct Checks<'a> {
    /// The user's tolerance (a search on a subsample aims below it).
    pub tol: f64,
    /// The sign-change rule and the source's count; `None`: not checked.
    pub fairness: Option<&'a Fairness>,
    /// The held-out check runs on these points; with `Some(keep)` the search's data are the
    /// points `keep` of them, and a candidate's parameters are spread to all of them.
    pub full: &'a [DVec2],
    pub keep: Option<&'a [usize]>,
    /// Run the held-out check in the search.
    pub held_out: bool,
}

/// Candidates that met the tolerance but were refused, by reason.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct Refused {
    /// The held-out check failed.
    pub held_out: usize,
    /// More curvature sign changes than the source.
    pub waves: usize,
    /// Left the source between the data points, or turned more than it ([`super::Follows`]).
    pub strays: usize,
}

/// The search's shared context.
pub(crate) struct Search<'a> {
    data: Data<'a>,
    tol: f64,
    norm: Norm,
    opts: &'a AdaptOptions,
    aerofoil_params: Option<Vec<f64>>,
    free_params: Vec<f64>,
    /// The data's two ends share their x: the aerofoil rule stores one trailing-edge x.
    shared_te: bool,
    /// Most design points a layout may have: half the data points, so that every coordinate
    /// is at least twice overdetermined. More approach interpolation, which follows the data's
    /// noise instead of its shape.
    limit: usize,
    /// Most stored scalars a layout may have (fewer than the data's scalars, and at most
    /// [`AdaptOptions::max_scalars`]).
    scalar_limit: usize,
    /// Fewest stored scalars of a candidate that meets the tolerance so far (`usize::MAX`
    /// before one is found).
    bound: AtomicUsize,
    fits: AtomicUsize,
    /// First fits shared between families, by x storage and degree (`None`: it failed).
    starts: Mutex<HashMap<(bool, usize), Option<State>>>,
    checks: Checks<'a>,
    refused_held_out: AtomicUsize,
    refused_waves: AtomicUsize,
    refused_strays: AtomicUsize,
}

/// What the search found.
pub(crate) struct Found {
    /// The best candidate meeting the tolerance, else the one closest to it.
    pub best: Cand,
    pub met: bool,
    pub trace: Vec<FamilyTrace>,
    pub fits: usize,
    /// Candidates meeting the tolerance that the other checks refused.
    pub refused: Refused,
}

impl<'a> Search<'a> {
    pub fn new(
        points: &'a [DVec2],
        tol: f64,
        opts: &'a AdaptOptions,
        aerofoil_params: Option<Vec<f64>>,
        free_params: Vec<f64>,
        checks: Checks<'a>,
    ) -> Self {
        let n = points.len();
        let extent = points
            .iter()
            .fold(0.0_f64, |m, p| m.max(p.x.abs()).max(p.y.abs()));
        let shared_te = (points[0].x - points[n - 1].x).abs() <= 1e-12 * extent;
        // Stored scalars below the data's own count (2 per point), or it is no compression.
        let scalar_limit = opts.max_scalars.map_or(2 * n - 1, |m| m.min(2 * n - 1));
        Search {
            data: Data { points },
            tol,
            norm: opts.norm,
            opts,
            aerofoil_params,
            free_params,
            shared_te,
            limit: n / 2,
            scalar_limit,
            bound: AtomicUsize::new(usize::MAX),
            fits: AtomicUsize::new(0),
            starts: Mutex::new(HashMap::new()),
            checks,
            refused_held_out: AtomicUsize::new(0),
            refused_waves: AtomicUsize::new(0),
            refused_strays: AtomicUsize::new(0),
        }
    }

    /// Candidates meeting the tolerance refused so far.
    pub fn refusals(&self) -> Refused {
        Refused {
            held_out: self.refused_held_out.load(Ordering::Relaxed),
            waves: self.refused_waves.load(Ordering::Relaxed),
            strays: self.refused_strays.load(Ordering::Relaxed),
        }
    }

    /// The held-out check of `c`'s layout on the checks' data (see [`Checks::full`]).
    pub fn held_out(&self, c: &Cand) -> Option<HeldOut> {
        let params = match self.checks.keep {
            Some(keep) => super::spread_params(keep, &c.state.params, self.checks.full.len()),
            None => c.state.params.clone(),
        };
        super::held_out(self.checks.full, c, params, self.opts)
    }

    /// True when `c`, which meets the tolerance, also passes the held-out check, waves no more
    /// than the source and follows it between the points; a refusal is counted by its reason.
    fn sound(&self, c: &Cand) -> bool {
        if let Some(f) = self.checks.fairness {
            let samples = chain_samples(&c.model.layout, &c.state.coeffs, PER_SEGMENT);
            if f.count(&samples) > f.source {
                self.refused_waves.fetch_add(1, Ordering::Relaxed);
                return false;
            }
            if !f.follows(&samples, self.checks.tol).passes() {
                self.refused_strays.fetch_add(1, Ordering::Relaxed);
                return false;
            }
        }
        if self.checks.held_out {
            // A layout too large for the check (more design points than every other data
            // point can determine) cannot show that it holds between the points: refused too.
            let m = self.held_out(c).map(|h| match self.norm {
                Norm::Max => h.max,
                Norm::Rms => h.rms,
            });
            if !m.is_some_and(|m| m <= HELD_OUT_FACTOR * self.checks.tol) {
                self.refused_held_out.fetch_add(1, Ordering::Relaxed);
                return false;
            }
        }
        true
    }

    fn measure(&self, s: &State) -> f64 {
        match self.norm {
            Norm::Max => s.max(),
            Norm::Rms => s.rms(),
        }
    }

    /// Fit `model` from `z` (or the linear fit at `params`).
    fn fit(
        &self,
        fam: Family,
        model: Model,
        start: Option<Vec<DVec2>>,
        params: Vec<f64>,
        effort: &Effort,
    ) -> Option<Cand> {
        self.fits.fetch_add(1, Ordering::Relaxed);
        FAMILY_FITS.with(|f| f.set(f.get() + 1));
        // Aerofoil-rule fits converge in a few iterations: one that cannot come near the
        // tolerance is abandoned, and one whose largest offset stalls is stopped. Free fits
        // creep along valleys (design points sliding along the curve) while their offsets
        // still fall: cut short, they leave poor parameters to the next layout, so they run
        // on unless very far from the tolerance.
        let effort = Effort {
            give_up: match (self.norm, fam.aerofoil) {
                (Norm::Max, true) => GIVE_UP * self.tol,
                (Norm::Max, false) => GIVE_UP_FREE * self.tol,
                _ => f64::INFINITY,
            },
            give_up_after: if fam.aerofoil {
                effort.give_up_after
            } else {
                GIVE_UP_FREE_AFTER
            },
            max_stall: if fam.aerofoil { effort.max_stall } else { 0 },
            ..*effort
        };
        let state = engine::fit(&model, &self.data, start, params, &effort)?;
        if !state.coeffs.iter().all(|v| v.is_finite()) {
            return None;
        }
        Some(Cand::new(fam, model, state))
    }

    /// True when the candidate meets the tolerance, after a minimax polish if it is close, and
    /// is sound ([`Search::sound`]).
    fn accept(&self, c: &mut Cand) -> bool {
        self.meets(c) && self.sound(c)
    }

    /// True when the candidate meets the tolerance, after a minimax polish if it is close.
    fn meets(&self, c: &mut Cand) -> bool {
        let mut m = self.measure(&c.state);
        if m <= self.tol {
            return true;
        }
        if m > POLISH_RANGE * self.tol {
            return false;
        }
        // Close: converge the fit fully (growth stops a fit once its largest offset stalls).
        self.fits.fetch_add(1, Ordering::Relaxed);
        FAMILY_FITS.with(|f| f.set(f.get() + 1));
        let full = Effort {
            max_stall: 0,
            ftol: 1e-7,
            ..GROW
        };
        if let Some(state) = engine::fit(
            &c.model,
            &self.data,
            Some(c.state.coeffs.clone()),
            c.state.params.clone(),
            &full,
        ) {
            if self.measure(&state) < m {
                c.state = state;
                m = self.measure(&c.state);
            }
        }
        if m <= self.tol {
            return true;
        }
        if self.norm == Norm::Max && self.opts.minimax {
            self.fits.fetch_add(1, Ordering::Relaxed);
            FAMILY_FITS.with(|f| f.set(f.get() + 1));
            let effort = Effort {
                minimax: POLISH_ROUNDS,
                ..GROW
            };
            let polished = engine::minimax(&c.model, &self.data, c.state.clone(), &effort);
            if polished.max() <= self.tol {
                c.state = polished;
                return true;
            }
        }
        false
    }

    /// The families of the outer search, most promising first.
    fn families(&self) -> Vec<Family> {
        let mut out = Vec::new();
        let (lo, hi) = (self.opts.min_degree.max(2), self.opts.max_degree);
        let modes: &[bool] = match (self.aerofoil_params.is_some(), self.opts.mode) {
            (true, super::Mode::Auto) => &[true, false],
            (true, super::Mode::Aerofoil) => &[true],
            (_, _) => &[false],
        };
        for &aerofoil in modes {
            for breaks in [BreakKind::Uniform, BreakKind::Stored] {
                // Beside the aerofoil rule, free chains with stored breaks never came within
                // reach on the aerofoil files and cost the most: left out there.
                if !aerofoil && modes.len() == 2 && breaks == BreakKind::Stored {
                    continue;
                }
                // Smoothest joins first: they store the fewest numbers per segment.
                for order_class in 0..3 {
                    let mut degrees: Vec<usize> = (lo..=hi).collect();
                    // Middle degrees first.
                    degrees.sort_by_key(|&d| (d as i64 - 5).abs());
                    for d in degrees {
                        let order = match order_class {
                            0 => d - 1,
                            1 => 2,
                            _ => 1,
                        };
                        if order == 0 || order >= d {
                            continue;
                        }
                        let fam = Family {
                            aerofoil,
                            shared_te: aerofoil && self.shared_te,
                            degree: d,
                            order,
                            breaks,
                        };
                        if !out.contains(&fam) {
                            out.push(fam);
                        }
                    }
                }
            }
        }
        out
    }

    /// Run the whole search: the families in batches of [`BATCH`], each batch in parallel.
    /// A family prunes by the bound the batches before it set, fixed while its batch runs, so
    /// the result (and every count in the trace) does not depend on the thread count or on
    /// which family finishes first.
    pub fn run(&self) -> Option<Found> {
        let families = self.families();
        let mut results: Vec<Outcome> = Vec::with_capacity(families.len());
        for batch in families.chunks(BATCH) {
            let bound = self.bound.load(Ordering::Relaxed);
            self.first_fits(batch, bound);
            let outcomes: Vec<Outcome> = batch
                .par_iter()
                .map(|&fam| {
                    let clock = std::time::Instant::now();
                    let before = FAMILY_FITS.with(|f| f.get());
                    let mut outcome = self.run_family(fam, bound);
                    outcome.fits = FAMILY_FITS.with(|f| f.get()) - before;
                    outcome.seconds = clock.elapsed().as_secs_f64();
                    outcome
                })
                .collect();
            for m in outcomes.iter().filter_map(|o| o.met.as_ref()) {
                self.bound.fetch_min(m.count, Ordering::Relaxed);
            }
            results.extend(outcomes);
        }
        let mut trace = Vec::new();
        let mut best_met: Option<Cand> = None;
        let mut closest: Option<Cand> = None;
        for o in results {
            trace.push(FamilyTrace {
                family: o.fam.name(),
                steps: o.steps,
                best_scalars: o.met.as_ref().map(|c| c.count),
                best_measure: o
                    .closest
                    .as_ref()
                    .map_or(f64::INFINITY, |c| self.measure(&c.state)),
                outcome: o.stop.name().to_string(),
                fits: o.fits,
                seconds: o.seconds,
            });
            if let Some(c) = o.met {
                let better = best_met
                    .as_ref()
                    .is_none_or(|b| (c.count, self.measure(&c.state)) < (b.count, self.measure(&b.state)));
                if better {
                    best_met = Some(c);
                }
            }
            if let Some(c) = o.closest {
                if closest
                    .as_ref()
                    .is_none_or(|b| self.measure(&c.state) < self.measure(&b.state))
                {
                    closest = Some(c);
                }
            }
        }
        let (best, met) = match best_met {
            Some(b) => {
                let b = if self.opts.optimise_breaks && b.fam.breaks == BreakKind::Stored {
                    self.optimise(b)
                } else {
                    b
                };
                (b, true)
            }
            None => (closest?, false),
        };
        Some(Found {
            best,
            met,
            trace,
            fits: self.fits.load(Ordering::Relaxed),
            refused: self.refusals(),
        })
    }

    /// Refit `cand`'s layout on this search's data from its unknowns and the parameters
    /// `params` (one per data point); if the tolerance does not hold, grow its family from
    /// there for at most `max_steps` layouts. Returns the result and whether the tolerance
    /// holds.
    pub fn continue_from(&self, cand: &Cand, params: Vec<f64>, max_steps: usize) -> Option<(Cand, bool)> {
        // The candidate as it is, measured on these data: often the tolerance already holds.
        let same = Cand {
            state: engine::state(&cand.model, &self.data, cand.state.coeffs.clone(), params.clone()),
            ..cand.clone()
        };
        if self.measure(&same.state) <= self.tol && self.sound(&same) {
            return Some((same, true));
        }
        let c = self.fit(
            cand.fam,
            cand.model.clone(),
            Some(cand.state.coeffs.clone()),
            params,
            &GROW,
        )?;
        let out = self.grow_from(
            c,
            Outcome::failed(cand.fam),
            max_steps,
            self.bound.load(Ordering::Relaxed),
        );
        if let Some(m) = &out.met {
            self.bound.fetch_min(m.count, Ordering::Relaxed);
        }
        match (out.met, out.closest) {
            (Some(m), _) => Some((m, true)),
            (None, Some(c)) => Some((c, false)),
            (None, None) => None,
        }
    }

    /// Candidate fits run so far.
    pub fn fits(&self) -> usize {
        self.fits.load(Ordering::Relaxed)
    }

    fn start_params(&self, fam: &Family) -> Vec<f64> {
        match (&self.aerofoil_params, fam.aerofoil) {
            (Some(p), true) => p.clone(),
            _ => self.free_params.clone(),
        }
    }

    /// Grow one family until it meets the tolerance, cannot beat `bound` (the fewest stored
    /// scalars met before), reaches the limit or stalls; then reduce.
    fn run_family(&self, fam: Family, bound: usize) -> Outcome {
        let mut out = Outcome::failed(fam);
        let Some(model) = fam.model(fam.degree, fam.initial_breaks()) else {
            return out;
        };
        if let Some(stop) = self.refused(fam, &model, bound) {
            out.stop = stop;
            return out;
        }
        let Some(cand) = self.initial(fam, model) else {
            return out;
        };
        self.grow_from(cand, out, usize::MAX, bound)
    }

    /// Why `model` is not fitted, if it is not: more design points or stored scalars than the
    /// data allow ([`Stop::Limit`]), or no fewer stored scalars than `bound`, the best layout
    /// found before ([`Stop::Pruned`]).
    fn refused(&self, fam: Family, model: &Model, bound: usize) -> Option<Stop> {
        let count = fam.count(&model.layout);
        if model.layout.design_count() > self.limit || count > self.scalar_limit {
            Some(Stop::Limit)
        } else if count >= bound {
            Some(Stop::Pruned)
        } else {
            None
        }
    }

    /// The first fits the families of `batch` that `bound` does not refuse will start from,
    /// those not made yet, in parallel (counted in the search's fits, not a family's). A
    /// family's first layout (one segment, or one per aerofoil surface) has no join of its
    /// continuity, so families differing only in their joins and breaks share it: it is
    /// fitted once per x storage and degree. A first fit that fails is stored as `None`.
    fn first_fits(&self, batch: &[Family], bound: usize) {
        let Ok(mut starts) = self.starts.lock() else {
            return;
        };
        let mut todo: Vec<(Family, Model)> = Vec::new();
        for &fam in batch {
            let Some(model) = fam.model(fam.degree, fam.initial_breaks()) else {
                continue;
            };
            let key = (fam.aerofoil, fam.degree);
            let fresh =
                !starts.contains_key(&key) && !todo.iter().any(|(f, _)| (f.aerofoil, f.degree) == key);
            if fresh && self.refused(fam, &model, bound).is_none() {
                todo.push((fam, model));
            }
        }
        let made: Vec<((bool, usize), Option<State>)> = todo
            .into_par_iter()
            .map(|(fam, model)| {
                let cand = self.fit(fam, model, None, self.start_params(&fam), &GROW);
                ((fam.aerofoil, fam.degree), cand.map(|c| c.state))
            })
            .collect();
        starts.extend(made);
    }

    /// The first fit of a family, made by [`Search::first_fits`] before its batch ran.
    fn initial(&self, fam: Family, model: Model) -> Option<Cand> {
        let key = (fam.aerofoil, fam.degree);
        let state = self.starts.lock().ok()?.get(&key).cloned().flatten()?;
        Some(Cand::new(fam, model, state))
    }

    /// Grow `cand`'s family from `cand` (see [`Search::run_family`]) for at most `max_steps`
    /// layouts, recording in `out`.
    fn grow_from(&self, mut cand: Cand, mut out: Outcome, max_steps: usize, bound: usize) -> Outcome {
        let fam = cand.fam;
        let mut history: Vec<f64> = Vec::new();
        loop {
            out.steps += 1;
            if self.accept(&mut cand) {
                let reduced = self.reduce(cand);
                out.closest = Some(reduced.clone());
                out.met = Some(reduced);
                out.stop = Stop::Met;
                return out;
            }
            let m = self.measure(&cand.state);
            if out.closest.as_ref().is_none_or(|c| m < self.measure(&c.state)) {
                out.closest = Some(cand.clone());
            }
            history.push(m);
            if history.len() > STALL_STEPS {
                let old = history[history.len() - 1 - STALL_STEPS];
                let best = history
                    .iter()
                    .rev()
                    .take(STALL_STEPS)
                    .fold(f64::INFINITY, |a, &b| a.min(b));
                if best > old * (1.0 - STALL_GAIN) {
                    out.stop = Stop::Stalled;
                    return out;
                }
            }
            if out.steps >= max_steps {
                out.stop = Stop::Stalled;
                return out;
            }
            let Some((model, z)) = self.grow(&cand) else {
                out.stop = Stop::Limit;
                return out;
            };
            if let Some(stop) = self.refused(fam, &model, bound) {
                out.stop = stop;
                return out;
            }
            match self.fit(fam, model, z, cand.state.params.clone(), &GROW) {
                Some(c) => cand = c,
                None => {
                    out.stop = Stop::Failed;
                    return out;
                }
            }
        }
    }

    /// Largest distance per segment of `c`'s layout (points by their parameter).
    fn segment_errors(&self, c: &Cand) -> Vec<f64> {
        let layout = &c.model.layout;
        let mut err = vec![0.0_f64; layout.segments()];
        for (&t, &d) in c.state.params.iter().zip(&c.state.dist) {
            let k = layout.locate(t).0;
            err[k] = err[k].max(d);
        }
        err
    }

    /// The next layout of the family. Stored breaks: the worst segment is split at the
    /// error-weighted median of its points' parameters, and while the offsets are far above
    /// the tolerance so is every segment within half the worst (the exact splits are the
    /// warm start). Uniform breaks: one equal segment more on the worse surface, or half as
    /// many again while far above the tolerance.
    fn grow(&self, c: &Cand) -> Option<(Model, Option<Vec<DVec2>>)> {
        let fam = c.fam;
        let layout = &c.model.layout;
        let d = layout.degree();
        let far = FAR * self.tol;
        match fam.breaks {
            BreakKind::Stored => {
                let err = self.segment_errors(c);
                let worst = err.iter().fold(0.0_f64, |a, &b| a.max(b));
                let k0 = (0..err.len()).max_by(|&a, &b| err[a].total_cmp(&err[b]))?;
                let mut split: Vec<usize> = (0..err.len())
                    .filter(|&k| k == k0 || (worst > far && err[k] > far.max(0.5 * worst)))
                    .collect();
                // Split from the last segment back, so earlier indices stay valid.
                split.sort_unstable_by(|a, b| b.cmp(a));
                let positions: Vec<f64> = split.iter().map(|&k| self.split_position(c, k)).collect();
                let (mut l2, mut c2) = (layout.clone(), c.state.coeffs.clone());
                for t in positions {
                    let (l, cc) = l2.split(t, fam.order.min(d - 1), &c2).ok()?;
                    l2 = l;
                    c2 = cc;
                }
                let model = match &c.model.rule {
                    XRule::Free => Model::free(l2),
                    XRule::Aerofoil { shared_te, .. } => Model::aerofoil(l2, *shared_te).ok()?,
                };
                Some((model, Some(c2)))
            }
            BreakKind::Uniform => {
                let more = |s: usize, e: f64| if e > far { s + (s / 2).max(1) } else { s + 1 };
                let breaks = if fam.aerofoil {
                    let first = layout.breaks().iter().filter(|&&b| b < LE_BREAK).count();
                    let second = layout.segments() - first;
                    let (mut e1, mut e2) = (0.0_f64, 0.0_f64);
                    for (&t, &e) in c.state.params.iter().zip(&c.state.dist) {
                        if t < LE_BREAK {
                            e1 = e1.max(e);
                        } else {
                            e2 = e2.max(e);
                        }
                    }
                    let (a, b) = if e1.max(e2) > far {
                        (
                            if e1 > far { more(first, e1) } else { first },
                            if e2 > far { more(second, e2) } else { second },
                        )
                    } else if e1 >= e2 {
                        (first + 1, second)
                    } else {
                        (first, second + 1)
                    };
                    per_side_breaks(a, b)
                } else {
                    let s = more(layout.segments(), self.measure(&c.state));
                    (0..=s).map(|k| k as f64 / s as f64).collect()
                };
                Some((fam.model(d, breaks)?, None))
            }
        }
    }

    /// Where to split segment `k` of `c`: the error-weighted median of the parameters of its
    /// points, kept a tenth of the segment away from its ends.
    fn split_position(&self, c: &Cand, k: usize) -> f64 {
        let layout = &c.model.layout;
        let (a, b) = (layout.breaks()[k], layout.breaks()[k + 1]);
        let mut pts: Vec<(f64, f64)> = c
            .state
            .params
            .iter()
            .zip(&c.state.dist)
            .filter(|(&t, _)| t > a && t < b)
            .map(|(&t, &e)| (t, e * e))
            .collect();
        let h = b - a;
        let mut t = a + 0.5 * h;
        if !pts.is_empty() {
            pts.sort_by(|x, y| x.0.total_cmp(&y.0));
            let total: f64 = pts.iter().map(|p| p.1).sum();
            let mut acc = 0.0;
            for p in &pts {
                acc += p.1;
                if acc >= 0.5 * total {
                    t = p.0;
                    break;
                }
            }
        }
        t.clamp(a + 0.1 * h, b - 0.1 * h)
    }

    /// Layouts with fewer stored scalars than `c`'s: each removable break (or one equal
    /// segment less per side), then the degree one lower.
    fn reductions(&self, c: &Cand) -> Vec<(Family, Model)> {
        let fam = c.fam;
        let layout = &c.model.layout;
        let d = layout.degree();
        let breaks = layout.breaks();
        let mut out = Vec::new();
        match fam.breaks {
            BreakKind::Stored => {
                let err = self.segment_errors(c);
                let mut idx: Vec<usize> = (1..breaks.len() - 1)
                    .filter(|&i| !(fam.aerofoil && breaks[i] == LE_BREAK))
                    .collect();
                // Breaks between the most accurate segments first, and only the first few.
                idx.sort_by(|&i, &j| (err[i - 1].max(err[i])).total_cmp(&err[j - 1].max(err[j])));
                idx.truncate(REDUCE_TRIES);
                for i in idx {
                    let mut b = breaks.to_vec();
                    b.remove(i);
                    if let Some(m) = fam.model(d, b) {
                        out.push((fam, m));
                    }
                }
            }
            BreakKind::Uniform => {
                if fam.aerofoil {
                    let first = breaks.iter().filter(|&&b| b < LE_BREAK).count();
                    let second = layout.segments() - first;
                    for (f, s) in [
                        (first.saturating_sub(1), second),
                        (first, second.saturating_sub(1)),
                    ] {
                        if f >= 1 && s >= 1 {
                            if let Some(m) = fam.model(d, per_side_breaks(f, s)) {
                                out.push((fam, m));
                            }
                        }
                    }
                } else if layout.segments() > 1 {
                    let s = layout.segments() - 1;
                    if let Some(m) = fam.model(d, (0..=s).map(|k| k as f64 / s as f64).collect()) {
                        out.push((fam, m));
                    }
                }
            }
        }
        if d > self.opts.min_degree.max(2) {
            let lower = Family {
                degree: d - 1,
                order: fam.order.min(d - 2).max(1),
                ..fam
            };
            if let Some(m) = lower.model(d - 1, breaks.to_vec()) {
                out.push((lower, m));
            }
        }
        out
    }

    /// Remove breaks and lower the degree while the tolerance holds.
    fn reduce(&self, mut c: Cand) -> Cand {
        'outer: loop {
            for (fam, model) in self.reductions(&c) {
                if fam.count(&model.layout) >= c.count {
                    continue;
                }
                if let Some(mut r) = self.fit(fam, model, None, c.state.params.clone(), &GROW) {
                    if self.accept(&mut r) {
                        c = r;
                        continue 'outer;
                    }
                }
            }
            return c;
        }
    }

    /// Move the breaks of `c` (coordinate search on the measure, each trial a warm refit)
    /// so that breaks can go: for the few most removable breaks, remove it, tune the rest,
    /// and keep the result if the tolerance holds.
    fn optimise(&self, mut c: Cand) -> Cand {
        'outer: loop {
            if c.model.layout.segments() > TUNE_MAX_SEGMENTS {
                return c;
            }
            let options: Vec<(Family, Model)> = self
                .reductions(&c)
                .into_iter()
                .filter(|(f, m)| f.breaks == BreakKind::Stored && f.count(&m.layout) < c.count)
                .take(3)
                .collect();
            for (fam, model) in options {
                let Some(r) = self.fit(fam, model, None, c.state.params.clone(), &GROW) else {
                    continue;
                };
                let mut tuned = self.tune_breaks(r);
                if self.accept(&mut tuned) {
                    c = self.reduce(tuned);
                    continue 'outer;
                }
            }
            return c;
        }
    }

    /// Coordinate search over the movable breaks of `c`, minimising the measure.
    fn tune_breaks(&self, mut c: Cand) -> Cand {
        let fam = c.fam;
        let d = c.model.layout.degree();
        let nb = c.model.layout.breaks().len();
        let mut best = self.measure(&c.state);
        let mut step: Vec<f64> = vec![0.3; nb];
        for _round in 0..6 {
            let mut any = false;
            for i in 1..nb - 1 {
                let breaks = c.model.layout.breaks().to_vec();
                if fam.aerofoil && breaks[i] == LE_BREAK {
                    continue;
                }
                let gap = (breaks[i] - breaks[i - 1]).min(breaks[i + 1] - breaks[i]);
                let mut moved = false;
                for dir in [1.0, -1.0] {
                    let mut b = breaks.clone();
                    b[i] += dir * step[i] * gap;
                    if !(b[i] > b[i - 1] && b[i] < b[i + 1]) || (fam.aerofoil && b[i] == LE_BREAK) {
                        continue;
                    }
                    let Some(model) = fam.model(d, b) else {
                        continue;
                    };
                    if let Some(r) = self.fit(fam, model, None, c.state.params.clone(), &GROW) {
                        let m = self.measure(&r.state);
                        if m < best {
                            best = m;
                            c = r;
                            moved = true;
                            any = true;
                            break;
                        }
                    }
                }
                if !moved {
                    step[i] *= 0.5;
                }
            }
            if !any && step.iter().all(|&s| s < 0.02) {
                break;
            }
        }
        c
    }
}

/// One family's result.
struct Outcome {
    fam: Family,
    steps: usize,
    fits: usize,
    seconds: f64,
    met: Option<Cand>,
    closest: Option<Cand>,
    stop: Stop,
}

impl Outcome {
    /// A family's outcome before its first fit: no steps, no fits, failed.
    fn failed(fam: Family) -> Self {
        Outcome {
            fam,
            steps: 0,
            fits: 0,
            seconds: 0.0,
            met: None,
            closest: None,
            stop: Stop::Failed,
        }
    }
}
