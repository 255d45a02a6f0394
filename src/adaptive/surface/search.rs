//! One family's search: growth by splitting, break removal most removable first, degree
//! reduction, each candidate fitted and checked; and the encoding of its result.

use super::super::blade::{Chordwise, ColumnFrames};
use super::super::encoding::Breaks;
use super::super::Norm;
use super::data::Data;
use super::encoding::SurfaceEncoding;
use super::fitter::{fold_at, norm_of, scale_by, span_maxima, Fitted, Fitter};
use super::span;
use super::{sampled_offsets, SpanBreaks, SurfaceAdaptOptions, SurfaceFamilyTrace, BULK_START};
use crate::chain::{ChainLayout, PatchGrid};
use crate::error::{Error, Result};
use crate::problem::checker::sampled_within;
use crate::team::{Reader, Record, Writer};
use glam::DVec3;
use std::sync::atomic::{AtomicUsize, Ordering};

/// One family of the search.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct Family {
    pub(super) du: usize,
    pub(super) dv: usize,
    pub(super) ou: usize,
    pub(super) ov: usize,
    /// Breaks split at data-driven positions (stored) instead of equal.
    pub(super) split: bool,
    /// How it grows ([`Growth`]).
    pub(super) growth: Growth,
    /// Where a bulk family's span breaks go ([`Data::break_sites`]; never
    /// [`SpanBreaks::Auto`], which [`Search::run`] resolves).
    pub(super) sites: SpanBreaks,
}

/// How a family grows and what it must pass.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Growth {
    /// One break at a time, where it buys the most accuracy per stored scalar.
    Greedy,
    /// [`Search::grow_bulk`]: the sections' ends anchored, a break between every two
    /// sections, u grown by splitting every bad segment at once, and the fold check part of
    /// meeting the tolerance.
    Bulk,
    /// A bulk family of the chord rule whose chordwise law carries the trailing-edge term,
    /// with span fairness.
    TrailingEdge,
}

impl Family {
    /// A bulk family (trailing-edge families included).
    pub(super) fn bulk(&self) -> bool {
        self.growth != Growth::Greedy
    }

    /// A trailing-edge family.
    pub(super) fn te(&self) -> bool {
        self.growth == Growth::TrailingEdge
    }

    pub(super) fn name(&self) -> String {
        format!(
            "d{}x{} C{}xC{} {}{}",
            self.du,
            self.dv,
            self.ou,
            self.ov,
            if self.split { "split" } else { "uniform" },
            match self.growth {
                Growth::TrailingEdge => " trailing-edge",
                Growth::Bulk => " bulk",
                Growth::Greedy => "",
            }
        ) + if self.bulk() && self.sites == SpanBreaks::Sections {
            ", span breaks at the sections"
        } else {
            ""
        }
    }

    pub(super) fn layout(&self, degree: usize, order: usize, breaks: &[f64]) -> Option<ChainLayout> {
        ChainLayout::with_order(degree, breaks.to_vec(), order).ok()
    }
}

/// A candidate layout pair and its fit.
#[derive(Clone)]
pub(super) struct Cand {
    pub(super) bu: Vec<f64>,
    pub(super) bv: Vec<f64>,
    pub(super) fit: Fitted,
    pub(super) scalars: usize,
    /// The stored numbers of the fitted net ([`store`]), computed once per fit.
    pub(super) coords: Vec<f64>,
}

pub(super) struct Search<'d, 'a> {
    pub(super) data: &'d Data<'a>,
    pub(super) opts: &'d SurfaceAdaptOptions,
    pub(super) limit_u: usize,
    pub(super) limit_scalars: usize,
    /// Hold every section to its own share of the tolerance ([`Data::slack`]: a blade
    /// definition's joined sections to [`super::BETWEEN_FACTOR`] of it), not all to the
    /// tolerance itself: the polish's ([`Search::polish`]).
    pub(super) loose: bool,
}

pub(super) fn is_uniform(b: &[f64]) -> bool {
    let s = (b.len() - 1) as f64;
    b.iter()
        .enumerate()
        .all(|(k, &x)| (x - k as f64 / s).abs() <= 1e-12)
}

/// The first of `n` tries, in order, that `f` keeps (`f(j)`: the fits it ran and what it
/// kept), and the fits of the tries up to it (of all when none is kept): what running them
/// one after another until one is kept gives, bit for bit, whatever the threads do. Each try
/// after the first is offered to idle threads ([`rayon::join`]) and starts only while no
/// earlier try is known kept, so a thread left alone runs exactly the tries in order, and an
/// idle one runs ahead on the next (its work lost when an earlier try is kept).
pub(super) fn first_in_order<T: Send>(
    n: usize,
    f: &(dyn Fn(usize) -> (usize, Option<T>) + Sync),
) -> (usize, Option<(usize, T)>) {
    type Slot<T> = Option<(usize, Option<T>)>;
    fn chain<T: Send>(
        j: usize,
        slots: &mut [Slot<T>],
        first: &AtomicUsize,
        f: &(dyn Fn(usize) -> (usize, Option<T>) + Sync),
    ) {
        let Some((here, rest)) = slots.split_first_mut() else {
            return;
        };
        rayon::join(
            || {
                if first.load(Ordering::Acquire) < j {
                    return;
                }
                let r = f(j);
                if r.1.is_some() {
                    first.fetch_min(j, Ordering::AcqRel);
                }
                *here = Some(r);
            },
            || chain(j + 1, rest, first, f),
        );
    }
    let first = AtomicUsize::new(usize::MAX);
    let mut slots: Vec<Slot<T>> = (0..n).map(|_| None).collect();
    chain(0, &mut slots, &first, f);
    let mut fits = 0;
    // A slot is empty only after a kept try.
    for (j, slot) in slots.into_iter().enumerate() {
        let Some((k, kept)) = slot else { break };
        fits += k;
        if let Some(t) = kept {
            return (fits, Some((j, t)));
        }
    }
    (fits, None)
}

impl<'d, 'a> Search<'d, 'a> {
    pub(super) fn scalars(&self, fam: &Family, bu: &[f64], bv: &[f64]) -> Option<usize> {
        let lu = fam.layout(fam.du, fam.ou, bu)?;
        let lv = fam.layout(fam.dv, fam.ov, bv)?;
        let per = if self.data.blade.is_some() {
            1
        } else {
            self.data.axes.len()
        };
        let frames = if self.data.blade.is_some() {
            Chordwise::frame_len_for(fam.du, fam.te()) * lv.design_count()
        } else {
            0
        };
        let rule = if self.data.span.is_some() { 2 } else { 0 };
        let breaks = |b: &[f64]| if is_uniform(b) { 0 } else { b.len() - 2 };
        Some(lu.design_count() * lv.design_count() * per + frames + rule + breaks(bu) + breaks(bv))
    }

    pub(super) fn fit(
        &self,
        count: &mut usize,
        fam: &Family,
        bu: &[f64],
        bv: &[f64],
        u0: &[f64],
    ) -> Option<Cand> {
        let lu = fam.layout(fam.du, fam.ou, bu)?;
        let lv = fam.layout(fam.dv, fam.ov, bv)?;
        // The bulk families have a span a section, so dv more columns than sections: the chord
        // rule's span fairness holds them, and without it the ridge of a singular solve.
        let limit_v = self.data.sections + if fam.bulk() { fam.dv } else { 0 };
        if lu.design_count() > self.limit_u || lv.design_count() > limit_v {
            return None;
        }
        let scalars = self.scalars(fam, bu, bv)?;
        if scalars > self.limit_scalars {
            return None;
        }
        *count += 1;
        let ends: Option<Vec<(usize, f64)>> = fam.bulk().then(|| {
            (0..self.data.sections)
                .flat_map(|k| [(k * self.data.per, 0.0), ((k + 1) * self.data.per - 1, 1.0)])
                .collect()
        });
        let mut f = Fitter::new(
            self.data,
            lu,
            lv,
            self.data.points,
            self.data.point_v(),
            self.scale(),
            ends.as_deref(),
        )?;
        let fit = f.fit(u0, self.opts)?;
        let coords = store(self.data, fam, bu, bv, &fit.design)?;
        Some(Cand {
            bu: bu.to_vec(),
            bv: bv.to_vec(),
            fit,
            scalars,
            coords,
        })
    }

    /// The fit's own offsets meet the tolerance, and so do the checker's
    /// ([`sampled_offsets`]) on the grid the stored numbers regenerate; a bulk family's grid
    /// also passes the fold check, which runs first: it costs less than the checker, and
    /// most of the bulk families' break removals that the checker refuses fold.
    pub(super) fn met(&self, fam: &Family, c: &Cand) -> bool {
        self.checkable(fam, c).is_some_and(|grid| {
            !(fam.bulk() && fold_at(&grid).is_some())
                && self.checker_within(&grid)
                && self.span_fault(&grid).is_none()
        })
    }

    /// Whether the checker's offsets ([`sampled_offsets`]) of `grid` meet the tolerance: under
    /// the max norm by [`sampled_within`], which answers the same for less work.
    fn checker_within(&self, grid: &PatchGrid<DVec3>) -> bool {
        match self.opts.norm {
            Norm::Max => sampled_within(grid, self.data.points, &|p| self.opts.tol * self.slack(p)),
            Norm::Rms => {
                let mut d = sampled_offsets(grid, self.data.points);
                if let Some(s) = self.scale() {
                    scale_by(&mut d, &s);
                }
                norm_of(&d, Norm::Rms) <= self.opts.tol
            }
        }
    }

    /// Every point's share of the tolerance when it differs from 1 ([`Search::loose`],
    /// [`Data::scale_of`]).
    fn scale(&self) -> Option<Vec<f64>> {
        self.loose
            .then(|| self.data.scale_of(0..self.data.points.len()))
            .flatten()
    }

    /// The tolerances point `p` is held to ([`Search::loose`]).
    fn slack(&self, p: usize) -> f64 {
        if self.loose {
            self.data.slack_at(p)
        } else {
            1.0
        }
    }

    /// Where a grid fails the mid-station checks ([`span::check`]), when the search holds
    /// them ([`SurfaceAdaptOptions::span_checks`]).
    fn span_fault(&self, grid: &PatchGrid<DVec3>) -> Option<f64> {
        if self.opts.span_checks {
            span::check(self.data, grid, self.opts.tol).worst
        } else {
            None
        }
    }

    /// The checker's offsets ([`sampled_offsets`]) of a candidate whose own offsets meet the
    /// tolerance, with the grid the stored numbers regenerate (for the fold check); `None`
    /// when they do not.
    pub(super) fn check(&self, fam: &Family, c: &Cand) -> Option<(Vec<f64>, PatchGrid<DVec3>)> {
        let grid = self.checkable(fam, c)?;
        Some((sampled_offsets(&grid, self.data.points), grid))
    }

    /// The grid the stored numbers of a candidate regenerate, when its own offsets meet the
    /// tolerance (the checker and the fold check look at no other).
    pub(super) fn checkable(&self, fam: &Family, c: &Cand) -> Option<PatchGrid<DVec3>> {
        (c.fit.measure <= self.opts.tol)
            .then(|| encode(self.data, fam, c).grid().ok())
            .flatten()
    }

    /// The u split: in the segment holding the worst point, at the squared-error-weighted
    /// mean of its points' u (kept inside the middle 80 % of the segment).
    pub(super) fn split_u(&self, fam: &Family, c: &Cand) -> Vec<f64> {
        if !fam.split {
            let s = c.bu.len();
            return (0..=s).map(|k| k as f64 / s as f64).collect();
        }
        let worst = (0..c.fit.err.len())
            .max_by(|&a, &b| c.fit.err[a].total_cmp(&c.fit.err[b]))
            .unwrap_or(0);
        let seg = c.bu[1..c.bu.len() - 1].partition_point(|&b| b <= c.fit.u[worst]);
        let (a, b) = (c.bu[seg], c.bu[seg + 1]);
        let (mut sw, mut swt) = (0.0, 0.0);
        for (t, e) in c.fit.u.iter().zip(&c.fit.err) {
            if *t >= a && *t <= b {
                sw += e * e;
                swt += e * e * t;
            }
        }
        let t = if sw > 0.0 { swt / sw } else { 0.5 * (a + b) };
        let t = t.clamp(a + 0.1 * (b - a), b - 0.1 * (b - a));
        let mut out = c.bu.clone();
        out.insert(seg + 1, t);
        out
    }

    /// The v split: in the span holding the worst section, at the weighted mean of its
    /// sections' v, moved to lie strictly between two sections.
    pub(super) fn split_v(&self, fam: &Family, c: &Cand) -> Option<Vec<f64>> {
        if !fam.split {
            let s = c.bv.len();
            return Some((0..=s).map(|k| k as f64 / s as f64).collect());
        }
        let per = self.data.per;
        let sec_err: Vec<f64> = (0..self.data.sections)
            .map(|k| {
                c.fit.err[k * per..(k + 1) * per]
                    .iter()
                    .fold(0.0, |m: f64, e| m.max(*e))
            })
            .collect();
        let v = &self.data.v;
        let worst = (0..sec_err.len()).max_by(|&a, &b| sec_err[a].total_cmp(&sec_err[b]))?;
        let mut order: Vec<usize> = (0..v.len()).collect();
        order.sort_by(|&a, &b| v[a].total_cmp(&v[b]));
        let sorted: Vec<f64> = order.iter().map(|&k| v[k]).collect();
        let seg = c.bv[1..c.bv.len() - 1]
            .partition_point(|&b| b <= v[worst])
            .min(c.bv.len() - 2);
        let (a, b) = (c.bv[seg], c.bv[seg + 1]);
        let (mut sw, mut swt) = (0.0, 0.0);
        for k in 0..v.len() {
            if v[k] >= a && v[k] <= b {
                sw += sec_err[k] * sec_err[k];
                swt += sec_err[k] * sec_err[k] * v[k];
            }
        }
        let t = if sw > 0.0 { swt / sw } else { 0.5 * (a + b) };
        // Between the two consecutive sections around t, both inside (a, b).
        let i = sorted.partition_point(|&s| s <= t).clamp(1, sorted.len() - 1);
        let mut cands = [i - 1, i, i.saturating_sub(2), (i + 1).min(sorted.len() - 1)]
            .into_iter()
            .filter(|&j| j + 1 < sorted.len())
            .map(|j| 0.5 * (sorted[j] + sorted[j + 1]))
            .filter(|&m| m > a && m < b)
            .collect::<Vec<f64>>();
        cands.sort_by(|x, y| (x - t).abs().total_cmp(&(y - t).abs()));
        let m = *cands.first()?;
        let mut out = c.bv.clone();
        out.insert(seg + 1, m);
        Some(out)
    }

    /// The bulk families' growth: a break half-way between every two neighbouring
    /// sections along the span (held), [`BULK_START`] equal segments around, then every u
    /// segment holding a point beyond half the largest offset and 0.9 of the tolerance (by the
    /// fit's offsets, or by the checker's once those meet it) split at once at the median u
    /// of its points, until the
    /// tolerance holds by both or no segment with points of every section twice over is left
    /// to split. The greedy one-break-a-step growth of the other families stalled on the IEA
    /// blades (its offsets gained under 2 % four steps running, 285 stored scalars at max
    /// 2.1e-2 on the IEA 15 MW at 1e-3), where this meets the tolerance.
    pub(super) fn grow_bulk(
        &self,
        fam: &Family,
        nfits: &mut usize,
        closest: &mut Option<Cand>,
        trace: &mut SurfaceFamilyTrace,
    ) -> Option<Cand> {
        let data = self.data;
        let tol = self.opts.tol;
        // Along the span a break at every place `SpanBreaks` allows: by default half-way
        // between every two neighbouring sections, so that each span holds one section, at
        // the middle row of the checker's seeds where the sections are evenly spaced.
        let mut bv = vec![0.0];
        bv.extend(data.break_sites(fam.dv, fam.sites));
        bv.push(1.0);
        let bv = bv;
        let mut bu: Vec<f64> = (0..=BULK_START).map(|k| k as f64 / BULK_START as f64).collect();
        let mut u0 = data.u0(fam.te()).to_vec();
        loop {
            let Some(c) = self.fit(nfits, fam, &bu, &bv, &u0) else {
                trace.outcome = "reached the data's limit".into();
                return None;
            };
            if closest.as_ref().is_none_or(|b| c.fit.measure < b.fit.measure) {
                *closest = Some(c.clone());
            }
            let mut fold = None;
            let err = match self.check(fam, &c) {
                Some((e, grid)) if norm_of(&e, self.opts.norm) <= tol => match fold_at(&grid) {
                    None if self.span_fault(&grid).is_none() => return Some(c),
                    // Meets the tolerance but not between the sections: refine where the
                    // offsets are largest, as when the checker misses.
                    None => e,
                    // Meets the tolerance but folds: split the u segment of the fold.
                    Some(u) => {
                        fold = Some(u);
                        e
                    }
                },
                // Within the tolerance by its own offsets: refine where the checker misses.
                Some((e, _)) => e.iter().zip(&c.fit.err).map(|(a, b)| a.max(*b)).collect(),
                None => c.fit.err.clone(),
            };
            if *nfits >= self.opts.max_family_fits {
                trace.outcome = "gave up (fits per family)".into();
                return None;
            }
            // Split where the offsets exceed half the largest (and 0.9 of the tolerance): on
            // the IEA 15 MW at 1e-3 this met it with 448 stored scalars where splitting every
            // segment beyond 0.9 of the tolerance stopped at 538 (both with the reduction in
            // break order, before `sweep_bulk`), and at 1e-4 it got to
            // 1.2e-3 before the data's limit, where the other reached it at 2.9e-3.
            let aim = (0.5 * norm_of(&err, Norm::Max)).max(0.9 * tol);
            // u: the segments holding a point beyond the aim.
            let nseg = bu.len() - 1;
            let mut seg_pts: Vec<Vec<f64>> = vec![Vec::new(); nseg];
            let mut seg_bad = vec![false; nseg];
            for (p, &t) in c.fit.u.iter().enumerate() {
                let s = bu[1..nseg].partition_point(|&b| b <= t);
                seg_pts[s].push(t);
                if err[p] > aim {
                    seg_bad[s] = true;
                }
            }
            if let Some(u) = fold {
                seg_bad.fill(false);
                seg_bad[bu[1..nseg].partition_point(|&b| b <= u)] = true;
            }
            let least = if fold.is_some() {
                data.sections
            } else {
                2 * data.sections
            };
            let mut nbu = bu.clone();
            for s in 0..nseg {
                if !seg_bad[s] || seg_pts[s].len() < least {
                    continue;
                }
                let mut pts = seg_pts[s].clone();
                pts.sort_by(f64::total_cmp);
                let (a, b) = (bu[s], bu[s + 1]);
                let m = pts[pts.len() / 2].clamp(a + 0.2 * (b - a), b - 0.2 * (b - a));
                nbu.push(m);
            }
            nbu.sort_by(f64::total_cmp);
            if nbu.len() == bu.len() {
                trace.outcome = "reached the data's limit (nothing left to split)".into();
                return None;
            }
            if fam
                .layout(fam.du, fam.ou, &nbu)
                .is_none_or(|l| l.design_count() > self.limit_u)
            {
                trace.outcome = "reached the data's limit".into();
                return None;
            }
            bu = nbu;
            u0 = c.fit.u.clone();
        }
    }

    /// Grow from one patch until the tolerance holds, then remove breaks while it holds.
    /// `bound`: the fewest stored scalars a family run before met the tolerance with; a
    /// growing family stops (pruned) once its layout has as many.
    pub(super) fn run(&self, fam: Family, bound: usize) -> Searched {
        let mut trace = SurfaceFamilyTrace {
            family: fam.name(),
            fits: 0,
            best_scalars: None,
            best_measure: f64::INFINITY,
            outcome: String::new(),
            seconds: 0.0,
        };
        let mut nfits = 0;
        let mut closest: Option<Cand> = None;
        if fam.bulk() {
            let mut fam = fam;
            let mut winner = self.grow_bulk(&fam, &mut nfits, &mut closest, &mut trace);
            // [`SpanBreaks::Auto`] (whose families start midway): the breaks at the sections
            // where midway ones left nothing to split.
            let retry = self.opts.span_breaks == SpanBreaks::Auto && fam.te() && fam.dv % 2 == 1;
            if winner.is_none() && retry {
                let at = Family {
                    sites: SpanBreaks::Sections,
                    ..fam
                };
                let mut again = SurfaceFamilyTrace {
                    family: at.name(),
                    ..trace.clone()
                };
                winner = self.grow_bulk(&at, &mut nfits, &mut closest, &mut again);
                if winner.is_some() {
                    (fam, trace) = (at, again);
                } else {
                    trace.outcome = format!("{}; at the sections, {}", trace.outcome, again.outcome);
                }
            }
            // Kept for a second sweep, span breaks first ([`super::run_families`]).
            let grown = if fam.te() { winner.clone() } else { None };
            let (w, c, t) = self.finish(fam, winner, closest, nfits, trace);
            return Searched(w, c, t, grown, fam.sites);
        }
        let mut cur = match self.fit(&mut nfits, &fam, &[0.0, 1.0], &[0.0, 1.0], self.data.u0(fam.te())) {
            Some(c) => c,
            None => {
                trace.outcome = "the first layout could not be fitted".into();
                trace.fits = nfits;
                return Searched(None, None, trace, None, fam.sites);
            }
        };
        let mut stall = 0;
        let winner = loop {
            if closest.as_ref().is_none_or(|b| cur.fit.measure < b.fit.measure) {
                closest = Some(cur.clone());
            }
            if cur.scalars >= bound {
                trace.outcome = format!("pruned (as many stored scalars as the {bound} met before)");
                break None;
            }
            let checked = self.check(&fam, &cur);
            let mut between = None;
            if let Some((e, grid)) = &checked {
                if norm_of(e, self.opts.norm) <= self.opts.tol {
                    between = self.span_fault(grid);
                    if between.is_none() {
                        break Some(cur);
                    }
                }
            }
            let checked = checked.map(|(e, _)| e);
            // Meets the tolerance at the sections but not between them: a span break at the
            // worst mid-station, so the neighbours there are followed on their own.
            if let Some(v) = between {
                let mut bv = cur.bv.clone();
                if !bv.iter().any(|b| (b - v).abs() < 1e-9) {
                    bv.push(v);
                    bv.sort_by(f64::total_cmp);
                    if let Some(next) = self.fit(&mut nfits, &fam, &cur.bu, &bv, &cur.fit.u) {
                        cur = next;
                        continue;
                    }
                }
            }
            if nfits >= self.opts.max_family_fits {
                trace.outcome = "gave up (fits per family)".into();
                break None;
            }
            if let Some(err) = checked {
                // The fit meets the tolerance but the checker's coarse search does not find
                // the closest points: one more span break where it misses most (its seeds
                // then sit closer along the span), or a u break where no v break fits.
                let by_checker = Cand {
                    fit: Fitted {
                        err,
                        ..cur.fit.clone()
                    },
                    ..cur.clone()
                };
                let next = self
                    .split_v(&fam, &by_checker)
                    .and_then(|bv| self.fit(&mut nfits, &fam, &cur.bu, &bv, &cur.fit.u))
                    .or_else(|| {
                        self.fit(
                            &mut nfits,
                            &fam,
                            &self.split_u(&fam, &by_checker),
                            &cur.bv,
                            &cur.fit.u,
                        )
                    });
                match next {
                    Some(next) => {
                        cur = next;
                        continue;
                    }
                    None => {
                        trace.outcome = "reached the data's limit (the checker's search)".into();
                        break None;
                    }
                }
            }
            // Both growths are fitted whatever they give: side by side when a thread is idle.
            let ((nu, grow_u), (nv, grow_v)) = rayon::join(
                || {
                    let mut n = 0;
                    let c = self.fit(&mut n, &fam, &self.split_u(&fam, &cur), &cur.bv, &cur.fit.u);
                    (n, c)
                },
                || {
                    let mut n = 0;
                    let c = self
                        .split_v(&fam, &cur)
                        .and_then(|bv| self.fit(&mut n, &fam, &cur.bu, &bv, &cur.fit.u));
                    (n, c)
                },
            );
            nfits += nu + nv;
            // Accuracy bought per stored scalar added.
            let gain = |c: &Cand| {
                (cur.fit.measure / c.fit.measure).ln() / (c.scalars.saturating_sub(cur.scalars).max(1)) as f64
            };
            let next = match (grow_u, grow_v) {
                (Some(a), Some(b)) => Some(if gain(&a) >= gain(&b) { a } else { b }),
                (a, b) => a.or(b),
            };
            let Some(next) = next else {
                trace.outcome = "reached the data's limit".into();
                break None;
            };
            stall = if next.fit.measure > 0.98 * cur.fit.measure {
                stall + 1
            } else {
                0
            };
            if stall >= 4 {
                trace.outcome = "offsets stalled".into();
                break None;
            }
            cur = next;
        };
        let (w, c, t) = self.finish(fam, winner, closest, nfits, trace);
        Searched(w, c, t, None, fam.sites)
    }

    /// The largest offset of `w`'s fit in every segment (`along_v` false) or span of `b`.
    fn span_maxima_of(&self, w: &Cand, b: &[f64], along_v: bool) -> Vec<f64> {
        span_maxima(
            b,
            (0..w.fit.err.len()).map(|p| {
                let t = if along_v {
                    self.data.v[p / self.data.per]
                } else {
                    w.fit.u[p]
                };
                (t, w.fit.err[p])
            }),
        )
    }

    /// A bulk family's reduction: one sweep over the breaks, one direction after the other as
    /// `order` says (u first in every family's own reduction), each tried once (the
    /// greedy families' repeated sweeps took 100 s on the IEA 15 MW cloud), the most
    /// removable first: the break whose two neighbouring segments (spans) hold the smallest
    /// largest offset of the current layout, found again after every try. A removal is kept
    /// when the layout has fewer stored scalars and still meets the tolerance ([`Search::met`]).
    /// In break order instead the sweep kept 1,238, 1,192 and 448 stored scalars on the IEA
    /// 3.4 MW AeroDyn and windIO v1 clouds and the IEA 15 MW cloud at 1e-3; this order keeps
    /// 1,194, 1,051 and 471 (`benches/peers/README.md`). The tries between two kept removals
    /// run in their order on this thread, and ahead of it on idle ones ([`first_in_order`]):
    /// the same result as one after another.
    pub(super) fn sweep_bulk(&self, fam: &Family, mut w: Cand, nfits: &mut usize, order: SweepOrder) -> Cand {
        for along_v in order.along_v() {
            let breaks = |c: &Cand| if along_v { c.bv.clone() } else { c.bu.clone() };
            let mut untried: Vec<f64> = {
                let b = breaks(&w);
                b[1..b.len() - 1].to_vec()
            };
            while !untried.is_empty() {
                let b = breaks(&w);
                let span_max = self.span_maxima_of(&w, &b, along_v);
                // Every untried break is still a break of `w` (removals only drop the one
                // tried): its index `k` in `b`, scored by the spans on either side. While
                // removals fail `w` stays, and so do the scores: the tries run in this order
                // (ties in `untried`'s, as `min_by` picks the first least) until one is kept.
                let mut order: Vec<(usize, usize, f64)> = untried
                    .iter()
                    .enumerate()
                    .filter_map(|(i, x)| {
                        let k = b.iter().position(|y| y == x)?;
                        Some((i, k, span_max[k - 1].max(span_max[k])))
                    })
                    .collect();
                order.sort_by(|a, c| a.2.total_cmp(&c.2));
                if order.is_empty() {
                    break;
                }
                let (fits, kept) = first_in_order(order.len(), &|j| {
                    let k = order[j].1;
                    let (mut bu, mut bv) = (w.bu.clone(), w.bv.clone());
                    if along_v {
                        bv.remove(k);
                    } else {
                        bu.remove(k);
                    }
                    let mut n = 0;
                    let c = self
                        .fit(&mut n, fam, &bu, &bv, &w.fit.u)
                        .filter(|c| c.scalars < w.scalars && self.met(fam, c));
                    (n, c)
                });
                *nfits += fits;
                let tried = kept.as_ref().map_or(order.len(), |(j, _)| j + 1);
                let gone: Vec<usize> = order[..tried].iter().map(|o| o.0).collect();
                untried = untried
                    .iter()
                    .enumerate()
                    .filter(|(i, _)| !gone.contains(i))
                    .map(|(_, x)| *x)
                    .collect();
                match kept {
                    Some((_, c)) => w = c,
                    // Every untried break with a place in `w` was tried and none kept.
                    None => break,
                }
            }
        }
        w
    }

    /// The polish of a bulk family's winner `w`, which passes the mid-station checks: two
    /// neighbouring breaks merged into one ([`Search::merge`], around the sections, then along
    /// the span), then one more removal sweep ([`Search::sweep_bulk`], u first). Every kept
    /// layout meets the tolerance and passes the mid-station checks, whether or not the
    /// search holds them ([`SurfaceAdaptOptions`]'s `span_checks`), so a polished winner never
    /// sends a blade definition's search round for more sections; a winner that fails them
    /// comes back as it is (its faults say where sections join the data).
    ///
    /// A sweep tries each break once, so a removal refused early can hold after later ones;
    /// and where no break can go, two can often become one between them. At 1e-3 of the
    /// chord (160 points a section, back to back) the polish took the IEA 15 MW from 861
    /// stored scalars to 713 (16.3 s instead of 14.4) and the IEA 3.4 MW AeroDyn blade from
    /// 1,390 to 1,341 (27.8 s instead of 26.8), and left the NREL 5 MW (514) and the IEA 10
    /// MW (883) as they were (0.9 and 1.0 s more). Repeating it while a round gains took the
    /// IEA 15 MW on to 691 for 2.8 s more. Trying each pair of u breaks also at 0.3 and 0.7
    /// of the way between them took the IEA 10 MW from 883 to 851 and left the other three
    /// as they were, but took the NREL 5 MW from 18.3 to 19.8 s against the 20 s its search
    /// is held to.
    ///
    /// Where a blade definition's sections joined the data between its stations, a second
    /// round then holds them to their own share ([`Data::slack`]: [`super::BETWEEN_FACTOR`]
    /// tolerances, as the surface is held between the stations) from the first round's
    /// result, so it can only gain, and a round's faults (which decide whether sections join)
    /// stay those of the strict winner. At 1e-3 (160 points a section) it took the NREL 5 MW
    /// from 514 stored scalars to 466, the IEA 10 MW from 883 to 851 and the IEA 3.4 MW AeroDyn
    /// blade from 1,341 to 1,292. On a build whose fits differed in their last bits, holding
    /// the joined sections so in the whole search gave the IEA 10 MW 768 but sent the NREL 5
    /// MW's search a third time (its tip, 28 s), and the loose round alone (not after the
    /// strict one) left the IEA 10 MW with more than the strict round did.
    pub(super) fn polish(&self, fam: &Family, w: Cand, nfits: &mut usize) -> Cand {
        let opts = SurfaceAdaptOptions {
            span_checks: true,
            ..*self.opts
        };
        let held = Search { opts: &opts, ..*self };
        if !held.met(fam, &w) {
            return w;
        }
        let c = held.polish_round(fam, w, nfits);
        // Then with a blade definition's joined sections held to their own share.
        let loose = Search { loose: true, ..held };
        let Some(scale) = loose.scale() else {
            return c;
        };
        let mut c = c;
        scale_by(&mut c.fit.err, &scale);
        c.fit.measure = norm_of(&c.fit.err, self.opts.norm);
        loose.polish_round(fam, c, nfits)
    }

    /// One round of [`Search::polish`]: merges around the sections, along the span, then a
    /// removal sweep.
    fn polish_round(&self, fam: &Family, w: Cand, nfits: &mut usize) -> Cand {
        let c = self.merge(fam, w, nfits, false);
        let c = self.merge(fam, c, nfits, true);
        self.sweep_bulk(fam, c, nfits, SweepOrder::UFirst)
    }

    /// Merges of two neighbouring breaks of `w` into one, around the sections (`along_v`
    /// false) or along the span, while one is kept: breaks `k` and `k + 1` give way to one
    /// half-way between them (along the span, the place [`super::SpanBreaks`] allows nearest
    /// to it, other than the two breaks, inside the spans around them). The pairs are
    /// tried in the order of the largest offset of their three spans, the least first; a
    /// merge is kept when the layout has fewer stored scalars and still meets the tolerance
    /// ([`Search::met`]).
    pub(super) fn merge(&self, fam: &Family, mut w: Cand, nfits: &mut usize, along_v: bool) -> Cand {
        let sites = self.data.break_sites(fam.dv, fam.sites);
        loop {
            let b = if along_v { w.bv.clone() } else { w.bu.clone() };
            if b.len() < 4 {
                return w;
            }
            let span_max = self.span_maxima_of(&w, &b, along_v);
            // (k, the merged break, the pair's score)
            let mut order: Vec<(usize, f64, f64)> = (1..b.len() - 2)
                .filter_map(|k| {
                    let half = 0.5 * (b[k] + b[k + 1]);
                    let m = if along_v {
                        sites
                            .iter()
                            .copied()
                            .filter(|&x| x > b[k - 1] && x < b[k + 2] && x != b[k] && x != b[k + 1])
                            .min_by(|x, y| (x - half).abs().total_cmp(&(y - half).abs()))?
                    } else {
                        half
                    };
                    Some((k, m, span_max[k - 1].max(span_max[k]).max(span_max[k + 1])))
                })
                .collect();
            order.sort_by(|a, c| a.2.total_cmp(&c.2));
            let (fits, kept) = first_in_order(order.len(), &|j| {
                let (k, m, _) = order[j];
                let (mut bu, mut bv) = (w.bu.clone(), w.bv.clone());
                let merged = if along_v { &mut bv } else { &mut bu };
                merged.remove(k + 1);
                merged[k] = m;
                let mut n = 0;
                let c = self
                    .fit(&mut n, fam, &bu, &bv, &w.fit.u)
                    .filter(|c| c.scalars < w.scalars && self.met(fam, c));
                (n, c)
            });
            *nfits += fits;
            match kept {
                Some((_, c)) => w = c,
                None => return w,
            }
        }
    }

    /// Remove every break that can go while the tolerance holds, and close the trace.
    pub(super) fn finish(
        &self,
        fam: Family,
        winner: Option<Cand>,
        closest: Option<Cand>,
        mut nfits: usize,
        mut trace: SurfaceFamilyTrace,
    ) -> (Option<Cand>, Option<Cand>, SurfaceFamilyTrace) {
        let winner = winner.map(|mut w| {
            if fam.bulk() {
                w = self.sweep_bulk(&fam, w, &mut nfits, SweepOrder::UFirst);
                trace.outcome = "met".into();
                trace.best_scalars = Some(w.scalars);
                return w;
            }
            // Reduction: drop every break that can go while the tolerance holds.
            loop {
                let tries: Vec<(Vec<f64>, Vec<f64>)> = (1..w.bu.len() - 1)
                    .map(|k| {
                        let mut b = w.bu.clone();
                        b.remove(k);
                        (b, w.bv.clone())
                    })
                    .chain((1..w.bv.len() - 1).map(|k| {
                        let mut b = w.bv.clone();
                        b.remove(k);
                        (w.bu.clone(), b)
                    }))
                    .filter(|_| fam.split)
                    .collect();
                // The first removal in order that holds ([`first_in_order`]).
                let (fits, kept) = first_in_order(tries.len(), &|j| {
                    let (bu, bv) = &tries[j];
                    let mut n = 0;
                    let c = self
                        .fit(&mut n, &fam, bu, bv, &w.fit.u)
                        .filter(|c| c.scalars < w.scalars && self.met(&fam, c));
                    (n, c)
                });
                nfits += fits;
                match kept {
                    Some((_, c)) => w = c,
                    None => break,
                }
            }
            trace.outcome = "met".into();
            trace.best_scalars = Some(w.scalars);
            w
        });
        trace.best_measure = closest.as_ref().map_or(f64::INFINITY, |c| c.fit.measure);
        trace.fits = nfits;
        (winner, closest, trace)
    }
}

/// The order of a bulk family's break removal ([`Search::sweep_bulk`]): the u breaks first
/// (every family's), or the span breaks first (a trailing-edge winner's second sweep,
/// [`super::run_families`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum SweepOrder {
    UFirst,
    VFirst,
}

impl SweepOrder {
    /// For each direction in turn: true along v.
    fn along_v(self) -> [bool; 2] {
        match self {
            SweepOrder::UFirst => [false, true],
            SweepOrder::VFirst => [true, false],
        }
    }
}

/// A family's search as [`Search::run`] ends it: its winner, its closest layout, its trace,
/// a trailing-edge family's grown layout that its winner's break removal started from, and
/// where its span breaks went ([`Family::sites`]); a [`Record`] so that a family searched on
/// another rank arrives as the same bits.
pub(super) struct Searched(
    pub(super) Option<Cand>,
    pub(super) Option<Cand>,
    pub(super) SurfaceFamilyTrace,
    pub(super) Option<Cand>,
    pub(super) SpanBreaks,
);

impl Cand {
    fn write(c: Option<&Self>, out: &mut Writer) {
        let Some(c) = c else {
            out.one(0u8);
            return;
        };
        let design: Vec<[f64; 3]> = c.fit.design.iter().map(|p| p.to_array()).collect();
        out.one(1u8)
            .put(&c.bu)
            .put(&c.bv)
            .put(&design)
            .put(&c.fit.u)
            .put(&c.fit.err)
            .one(c.fit.measure)
            .one(c.scalars as u64)
            .put(&c.coords);
    }

    fn read(from: &mut Reader<'_>) -> Result<Option<Self>> {
        if from.one::<u8>()? == 0 {
            return Ok(None);
        }
        Ok(Some(Cand {
            bu: from.take()?,
            bv: from.take()?,
            fit: Fitted {
                design: from
                    .take::<[f64; 3]>()?
                    .into_iter()
                    .map(DVec3::from_array)
                    .collect(),
                u: from.take()?,
                err: from.take()?,
                measure: from.one()?,
            },
            scalars: from.one::<u64>()? as usize,
            coords: from.take()?,
        }))
    }
}

impl Record for Searched {
    fn write(&self, out: &mut Writer) {
        Cand::write(self.0.as_ref(), out);
        Cand::write(self.1.as_ref(), out);
        let t = &self.2;
        out.put(t.family.as_bytes())
            .one(t.fits as u64)
            .put(&t.best_scalars.map(|n| n as u64).into_iter().collect::<Vec<_>>())
            .one(t.best_measure)
            .put(t.outcome.as_bytes())
            .one(t.seconds);
        Cand::write(self.3.as_ref(), out);
        out.put(self.4.name().as_bytes());
    }

    fn read(from: &mut Reader<'_>) -> Result<Self> {
        let text = |from: &mut Reader<'_>| {
            String::from_utf8(from.take()?)
                .map_err(|_| Error::Numerical("a family's trace is not text".into()))
        };
        Ok(Searched(
            Cand::read(from)?,
            Cand::read(from)?,
            SurfaceFamilyTrace {
                family: text(from)?,
                fits: from.one::<u64>()? as usize,
                best_scalars: from.take::<u64>()?.first().map(|&n| n as usize),
                best_measure: from.one()?,
                outcome: text(from)?,
                seconds: from.one()?,
            },
            Cand::read(from)?,
            text(from)?
                .parse()
                .map_err(|_| Error::Numerical("a family's span-break placement is unknown".into()))?,
        ))
    }
}

/// The stored numbers of a fitted design net on `bu` x `bv` ([`SurfaceEncoding::coords`]);
/// `None` when the layout cannot be built or a chord-rule column's frame is not determined
/// (constant chordwise rows, or a non-finite result).
pub(super) fn store(
    data: &Data<'_>,
    fam: &Family,
    bu: &[f64],
    bv: &[f64],
    design: &[DVec3],
) -> Option<Vec<f64>> {
    match &data.blade {
        Some(sections) => {
            let lu = fam.layout(fam.du, fam.ou, bu)?;
            let lv = fam.layout(fam.dv, fam.ov, bv)?;
            let frames = ColumnFrames::new(&lv, &data.v, sections);
            frames.store(
                &Chordwise::new(&lu, fam.te()),
                [data.axes[0], data.axes[1]],
                design,
            )
        }
        None => Some(
            design
                .iter()
                .flat_map(|p| data.axes.iter().map(move |&a| p[a]))
                .collect(),
        ),
    }
}

pub(super) fn encode(data: &Data<'_>, fam: &Family, c: &Cand) -> SurfaceEncoding {
    let stored = |b: &[f64]| {
        if is_uniform(b) {
            Breaks::Uniform {
                segments: b.len() - 1,
            }
        } else {
            Breaks::Stored(b[1..b.len() - 1].to_vec())
        }
    };
    let coords = c.coords.clone();
    SurfaceEncoding {
        degree: [fam.du, fam.dv],
        joins_u: vec![fam.ou; c.bu.len() - 2],
        joins_v: vec![fam.ov; c.bv.len() - 2],
        breaks_u: stored(&c.bu),
        breaks_v: stored(&c.bv),
        span_rule: data.span,
        chord_rule: data.blade.is_some(),
        te_term: data.blade.is_some() && Chordwise::carries(fam.du, fam.te()),
        coords,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A family searched on another rank arrives with its trace and its breaks' placement.
    #[test]
    fn a_searched_family_travels_whole() {
        for sites in [SpanBreaks::Midway, SpanBreaks::Sections, SpanBreaks::ByDegree] {
            let trace = SurfaceFamilyTrace {
                family: "d5x3 C4xC2 split trailing-edge, span breaks at the sections".into(),
                fits: 17,
                best_scalars: Some(624),
                best_measure: 5.765e-3,
                outcome: "met".into(),
                seconds: 1.25,
            };
            let sent = Searched(None, None, trace.clone(), None, sites);
            let Searched(w, c, t, g, s) = crate::team::round_trip(&sent).unwrap();
            assert!(w.is_none() && c.is_none() && g.is_none());
            assert_eq!(t, trace);
            assert_eq!(s, sites);
        }
    }
}
