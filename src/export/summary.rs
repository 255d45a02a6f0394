//! The readable text the commands print about what they found: a fitted chain or grid, an
//! adapted chain or grid, the table of a tolerance sweep, and the warnings that go with a fit.

use super::adapt_report::{AdaptOutcome, AdaptReport, SurfaceAdaptReport};
use super::bspline::CadShape;
use super::offset_map::{offset_label, Remark};
use super::stamp::Schema;
use crate::adaptive::surface::SectionEnds;
use crate::adaptive::{AdaptedCurve, AdaptedSurface, Breaks, HeldOut, Norm, XStore};
use crate::error::Result;
use crate::fit::report::{FitInfo, OffsetReport};
use crate::fit::{CurveFit, FitOptions, Method, SurfaceFit};
use crate::geometry::{Axes, Blade, Blend, Cloud, Loaded2};
use crate::optim::SolveReport;
use crate::problem::checker::ProjectionCheck;
use crate::problem::Metric;
use glam::{DVec2, DVec3};
use std::fmt::Write as _;
use std::path::Path;
use std::time::Duration;

/// `fit`'s lines: the data, the chain, its closest-point offsets (and corresponding ones), the
/// method's effort and, for the evolutionary methods, the run and its stages.
#[must_use]
pub fn curve_fit(input: &Path, loaded: &Loaded2, fit: &CurveFit<DVec2>) -> String {
    let l = fit.chain.layout();
    let c = &fit.closest;
    let mut s = format!(
        "{}: {} points ({:?}, {})\n",
        input.display(),
        loaded.points.len(),
        loaded.format,
        loaded.name
    );
    s += &format!(
        "chain: degree {}, {} segments, {}: {} design points ({} variables), {} control points\n",
        l.degree(),
        l.segments(),
        l.continuity(),
        l.design_count(),
        2 * l.design_count(),
        l.expanded_count()
    );
    s += &format!(
        "{}: sum_sq {:.4e}  rms {:.3e}  max {:.3e} at ({:.4}, {:.4})  [closest point]\n",
        fit.method, c.sum_sq, c.rms, c.max, c.max_at.x, c.max_at.y
    );
    if fit.metric == Metric::Corresponding {
        s += &format!(
            "corresponding-point sum_sq {:.4e}, max {:.3e}\n",
            fit.offset.sum_sq, fit.offset.max
        );
    }
    let Some(evo) = &fit.evolution else {
        s += &format!(
            "{} iterations, {} evaluations, {:.1} ms\n",
            fit.report.iterations,
            fit.report.evaluations,
            fit.report.seconds * 1e3
        );
        return s;
    };
    let r = &evo.run;
    s += &format!(
        "{}: population {}, {} generations ({}{}), {} individuals, {:.1} s; objective {:.4e} (f64, ends tied)\n",
        evo.stages[0].method,
        r.size,
        r.report.iterations,
        r.stop,
        match r.restarts {
            0 => String::new(),
            1 => ", after 1 restart".to_string(),
            k => format!(", after {k} restarts"),
        },
        r.report.evaluations,
        r.report.seconds,
        r.sum_sq
    );
    s += &format!(
        "backend {}: {:.3e} point evaluations/s ({:.3e} individuals/s) in the evaluator ({:.2} s of {:.2} s)\n",
        r.backend,
        r.evals_per_second,
        r.report.evaluations as f64 / r.eval_seconds.max(1e-12),
        r.eval_seconds,
        r.report.seconds
    );
    for st in &evo.stages[1..] {
        let from = match evo.polish_from_evolved {
            Some(true) => " (the polish of the evolved design won)",
            Some(false) => " (one of lsq's own starts beat the polish of the evolved design)",
            None => "",
        };
        s += &format!(
            "{}: {} iterations, {} evaluations, {:.1} ms{from}\n",
            st.method,
            st.report.iterations,
            st.report.evaluations,
            st.report.seconds * 1e3
        );
    }
    s += &format!("total {:.2} s\n", fit.report.seconds);
    s
}

/// `blade`'s line: the blade read from `path`, its stations and aerofoils, and the `cloud`
/// lofted from it, written `to`.
#[must_use]
pub fn lofted(path: &Path, blade: &Blade, cloud: &Cloud, to: &str) -> String {
    let shape = match cloud.grid {
        Some(g) => format!("{} sections × {} points", g.sections, g.per_section),
        None => "unordered".to_string(),
    };
    let blend = match blade.blend {
        Blend::Radius => "each station its own aerofoil",
        Blend::Thickness { .. } => "aerofoils blended by relative thickness",
    };
    let axes = match blade.axes {
        Axes::Section => "section axes",
        Axes::Turbine => "blade-root axes",
    };
    format!(
        "{}: {}, {} stations, {blend}, {axes}: {} points ({shape}) → {to}",
        path.display(),
        blade.format,
        blade.stations.len(),
        cloud.points.len()
    )
}

/// The warning for a fitted chain that doubles back on itself (its span ratio above
/// [`FitOptions::max_span_ratio`]'s default), if it does.
#[must_use]
pub fn fold_warning(fit: &CurveFit<DVec2>) -> Option<String> {
    (fit.span_ratio > FitOptions::default().max_span_ratio).then(|| {
        format!(
            "the fitted chain doubles back on itself (span ratio {:.1}): its closest-point offsets are \
             small but neighbouring data points are far apart along the chain; try another degree or \
             number of segments",
            fit.span_ratio
        )
    })
}

/// The warning for an adapted surface whose section ends double back beyond its neighbouring
/// sections' ([`SectionEnds::passes`] false) at tolerance `tol`, if they do: no offset sees
/// it, and the CAD files written from the surface carry it.
#[must_use]
pub fn ends_warning(ends: Option<&SectionEnds>, tol: f64) -> Option<String> {
    ends.filter(|e| !e.passes).map(|e| {
        format!(
            "at tolerance {tol:.3e} the surface doubles back on itself at its sections' end {} near span \
             {:.4}: {:.3e} ({:.2} tol) beyond its neighbouring sections, so the seam overlaps itself there, \
             which no offset sees and a mesher may refuse (the report's `section_ends`; not part of `met`); \
             points closer together at the sections' ends narrow it (for a blade definition, more \
             --points-per-section)",
            e.end,
            e.span,
            e.excess,
            e.excess / tol
        )
    })
}

/// The note for a blade definition whose search joined `added` sections lofted between its
/// stations to the data (over `rounds` searches), `name` the definition; none when it joined
/// none.
#[must_use]
pub fn joined_sections(name: &str, added: usize, rounds: usize) -> Option<String> {
    (added > 0).then(|| {
        format!(
            "note: {name}: {added} section(s) lofted between stations joined the data where the surface \
             (or, before any layout met the stations, a smooth interpolation of them) left the definition \
             between them ({rounds} searches); they are held to {} tolerances, as the surface is between \
             the stations\n",
            crate::adaptive::BETWEEN_FACTOR
        )
    })
}

/// The picture's remark for section ends that double back ([`ends_warning`]): a dotted ring
/// where, labelled with how far.
#[must_use]
pub fn ends_remark(ends: Option<&SectionEnds>, tol: f64) -> Option<Remark> {
    let e = ends.filter(|e| !e.passes)?;
    Some(Remark {
        position: DVec3::from_array(e.at?),
        label: format!(
            "end {} doubles back {} ({:.2} tol), span {:.2}",
            e.end,
            offset_label(e.excess),
            e.excess / tol,
            e.span
        ),
    })
}

/// The title of a fitted chain's plot: the contour's `name`, the layout, the method, the
/// design points and the closest-point offsets.
#[must_use]
pub fn curve_title(name: &str, fit: &CurveFit<DVec2>) -> String {
    let l = fit.chain.layout();
    format!(
        "{name} — degree {}, {} segments, {}, {}: {} design points, sum_sq {:.3e}, max {:.3e}",
        l.degree(),
        l.segments(),
        l.continuity(),
        fit.method,
        l.design_count(),
        fit.closest.sum_sq,
        fit.closest.max
    )
}

/// `, about 1 min 20 s left` after `done` of `total` steps in `elapsed`, at the mean pace so
/// far (nothing before the first step or after the last).
#[must_use]
pub fn time_left(elapsed: Duration, done: u64, total: u64) -> String {
    if done == 0 || done >= total {
        return String::new();
    }
    let left = elapsed.as_secs_f64() / done as f64 * (total - done) as f64;
    let secs = left.round() as u64;
    if secs >= 60 {
        format!(", about {} min {} s left", secs / 60, secs % 60)
    } else {
        format!(", about {secs} s left")
    }
}

/// The warning for a `method` that stopped at its `cap` (its iteration or evaluation limit,
/// [`SolveReport::cap`]) before converging, with the effort `report` says it spent.
#[must_use]
pub fn cap_warning(method: &str, cap: &str, report: &SolveReport) -> String {
    format!(
        "{method} stopped at its {cap} ({} iterations, {} evaluations, {:.1} s) before converging: \
         the result is the best found so far",
        report.iterations, report.evaluations, report.seconds
    )
}

/// The warning for a fitted grid on which the coarse sampled search of outside checkers finds
/// other offsets than the exact ones (`check`), if it does.
#[must_use]
pub fn checker_warning(fit: &SurfaceFit, check: &ProjectionCheck) -> Option<String> {
    (!check.agrees).then(|| {
        format!(
            "a coarse sampled search (7x7 seeds a patch, Gauss-Newton from the 4 nearest) finds rms {:.4e} \
             and max {:.4e} on this surface, not the exact {:.4e} and {:.4e}: overhangs or folds trap it, \
             so simple projection tools will overestimate these offsets",
            check.rms, check.max, fit.stats.rms, fit.stats.max
        )
    })
}

/// `fit-surface`'s lines: the grid, its breaks, its closest-point offsets over the `n` points
/// (by `method`) and the effort; `total` seconds in all.
#[must_use]
pub fn surface_fit(method: Method, fit: &SurfaceFit, n: usize, total: f64) -> String {
    let l = fit.grid.layout();
    let (du, dv) = (l.u.degree(), l.v.degree());
    let (pu, pv) = l.patches();
    let (nu, nv) = l.design_shape();
    let (mu, mv) = l.net_shape();
    let s = &fit.stats;
    let mut out = format!(
        "grid: degree {du}x{dv}, {pu}x{pv} patches, {}x{}: design net {nu}x{nv} ({} variables), control net {mu}x{mv}\n",
        l.u.continuity(),
        l.v.continuity(),
        3 * nu * nv
    );
    out += &format!(
        "breaks u: {}\nbreaks v: {}\n",
        fixed4(l.u.breaks(), " "),
        fixed4(l.v.breaks(), " ")
    );
    out += &format!(
        "{method}: rms {:.4e}  max {:.4e} at ({:.4}, {:.4}, {:.4})  sum_sq {:.4e}  [closest point, {n} points]\n",
        s.rms, s.max, s.max_at.x, s.max_at.y, s.max_at.z, s.sum_sq
    );
    out += &format!(
        "continuity error {:.1e}; parameters {}; {} iterations ({}), fit {:.2} s, total {:.2} s\n",
        fit.grid.continuity_error(),
        fit.param_source,
        fit.report.iterations,
        fit.stages
            .iter()
            .map(|st| format!("{} {} on {} points", st.name, st.report.iterations, st.points))
            .collect::<Vec<_>>()
            .join(", "),
        fit.report.seconds,
        total
    );
    out
}

/// Numbers to 4 decimals, joined by `sep`.
#[must_use]
pub fn fixed4(values: &[f64], sep: &str) -> String {
    values
        .iter()
        .map(|x| format!("{x:.4}"))
        .collect::<Vec<_>>()
        .join(sep)
}

/// `adapt`'s lines about one result: `name` and its `points`, the tolerance `tol` on `norm`.
#[must_use]
pub fn adapted_curve(name: &str, points: usize, tol: f64, norm: Norm, r: &AdaptedCurve) -> String {
    let c = &r.count;
    let mut s = String::new();
    let _ = writeln!(s, "{name}: {points} points, tolerance {tol:.3e} ({norm})");
    let _ = writeln!(s, "  met            {}", if r.met { "yes" } else { "NO" });
    let mut kinds = vec![format!("y {}", c.y)];
    if c.x > 0 {
        kinds.insert(0, format!("x {}", c.x));
    }
    if c.rule > 0 {
        kinds.push(format!("aerofoil rule {}", c.rule));
    }
    kinds.push(format!("breaks {}", c.breaks));
    let _ = writeln!(s, "  stored scalars {} ({})", c.total, kinds.join(", "));
    let joins: Vec<String> = r.encoding.joins.iter().map(|k| format!("C{k}")).collect();
    let segments = r.chain.layout().segments();
    let breaks = match &r.encoding.breaks {
        Breaks::Uniform { .. } => format!("{segments} equal segments"),
        Breaks::UniformPerSide { first, second } => {
            format!("{first} + {second} equal segments per surface")
        }
        Breaks::Stored(b) => format!("{segments} segments, stored breaks [{}]", fixed4(b, ", ")),
    };
    let _ = writeln!(
        s,
        "  layout         {}: degree {}, {breaks}, joins [{}]",
        r.family,
        r.encoding.degree,
        joins.join(" ")
    );
    if let XStore::AerofoilRule(theta) = &r.encoding.x {
        let _ = match theta.as_slice() {
            [le, te] => writeln!(s, "  aerofoil rule  x_le {le:.6}, x_te {te:.6} (both surfaces)"),
            [le, a, b] => writeln!(
                s,
                "  aerofoil rule  x_le {le:.6}, x_te {a:.6} (first surface), {b:.6} (second)"
            ),
            _ => Ok(()),
        };
    }
    let _ = writeln!(
        s,
        "  offsets        max {:.3e} at ({:.5}, {:.5}), rms {:.3e}",
        r.offset.max, r.offset.max_at.x, r.offset.max_at.y, r.offset.rms
    );
    if let Some(h) = &r.held_out {
        let m = h.measure(norm);
        let _ = writeln!(
            s,
            "  held-out ratio {:.2} tolerances ({norm}; at most {})",
            m / tol,
            crate::adaptive::HELD_OUT_FACTOR
        );
    }
    if let Some(c) = &r.sign_changes {
        let _ = writeln!(
            s,
            "  curvature      {} sign changes, source {} (spline through the points; |curvature| below {:.3} ignored, scatter {:.1e})",
            c.chain, c.source, c.threshold, c.scatter
        );
    }
    if let Some(f) = &r.follows {
        let _ = writeln!(
            s,
            "  between points {:.3e} from the source spline where it may stray {:.3e} ({} tolerances or its bend), turning {:.0}° (source {:.0}°)",
            f.away, f.allowed, crate::adaptive::fairness::AWAY_FACTOR, f.turning_deg, f.source_turning_deg
        );
    }
    let met = r.trace.iter().filter(|t| t.best_scalars.is_some()).count();
    held_out_and_search(&mut s, r.held_out.as_ref(), r.trace.len(), met, r.fits, r.seconds);
    s
}

/// `adapt-surface`'s lines about one result: `name` and its `points`, the tolerance `tol` on
/// `norm`.
#[must_use]
pub fn adapted_surface(name: &str, points: usize, tol: f64, norm: Norm, r: &AdaptedSurface) -> String {
    let c = &r.count;
    let e = &r.encoding;
    let (nu, nv) = r
        .encoding
        .layouts()
        .map(|(u, v)| (u.design_count(), v.design_count()))
        .unwrap_or((0, 0));
    let describe = |b: &Breaks| match b {
        Breaks::Uniform { segments } => format!("{segments} equal"),
        Breaks::Stored(v) => format!("{} at [{}]", v.len() + 1, fixed4(v, ", ")),
        Breaks::UniformPerSide { first, second } => format!("{first} + {second} equal"),
    };
    let mut s = String::new();
    let _ = writeln!(s, "{name}: {points} points, tolerance {tol:.3e} ({norm})");
    let _ = writeln!(s, "  met            {}", if r.met { "yes" } else { "NO" });
    let _ = writeln!(
        s,
        "  stored scalars {} (net {}{}, span rule {}, breaks {})",
        c.total,
        c.coords,
        if e.chord_rule {
            format!(", chord-rule frames {}", c.frames)
        } else {
            String::new()
        },
        c.rule,
        c.breaks
    );
    let _ = writeln!(
        s,
        "  layout         {}: design net {nu} x {nv}, degrees {} x {}, patches u {}, v {}",
        r.family,
        e.degree[0],
        e.degree[1],
        describe(&e.breaks_u),
        describe(&e.breaks_v)
    );
    if let Some(rule) = e.span_rule {
        let _ = writeln!(
            s,
            "  span rule      {} of design column j = {:.6} + g_j ({:.6} - {:.6})",
            ["x", "y", "z"][rule.axis.min(2)],
            rule.ends[0],
            rule.ends[1],
            rule.ends[0]
        );
    }
    let at: DVec3 = r.offset.max_at;
    let _ = writeln!(
        s,
        "  offsets        max {:.3e} at ({:.5}, {:.5}, {:.5}), rms {:.3e}",
        r.offset.max, at.x, at.y, at.z, r.offset.rms
    );
    let _ = writeln!(
        s,
        "  checker        max {:.3e}, rms {:.3e} (the coarse sampled search of outside checkers: 7 x 7 seeds a patch)",
        r.checked.max, r.checked.rms
    );
    let _ = writeln!(
        s,
        "  fold check     normal turns at most {:.1}° between neighbouring samples (at u {:.4}, v {:.4}; {} a patch each way; {}); checker/exact max {:.3}",
        r.fold.max_turn_deg,
        r.fold.at[0],
        r.fold.at[1],
        r.fold.per_patch,
        if r.fold.passes { "no fold" } else { "FOLDS" },
        r.agreement
    );
    if let Some(e) = &r.ends {
        let _ = writeln!(
            s,
            "  section ends   {} cuts: {}",
            e.cuts,
            if e.excess > 0.0 {
                format!(
                    "worst doubles back {:.3e} ({:.2} tol) beyond its neighbouring sections at span {:.4}, end {}: {}",
                    e.excess,
                    e.excess / tol,
                    e.span,
                    e.end,
                    if e.passes {
                        "within the allowance".to_string()
                    } else {
                        format!("DOUBLES BACK (more than {} tol; reported, not part of met)", crate::adaptive::surface::END_SLACK)
                    }
                )
            } else {
                "none doubles back beyond its neighbouring sections".to_string()
            }
        );
    }
    match &r.fairness {
        Some(f) => {
            let _ = writeln!(
                s,
                "  mid-stations   {} cut: worst {} {:.2} of its allowance (span {:.4}; chord and thickness within the neighbours' ± {:.0} % of the chord + tol, centroid within {:.0} %): {}",
                f.stations,
                f.measure,
                f.worst,
                f.span,
                100.0 * crate::adaptive::FAIR_SHAPE,
                100.0 * crate::adaptive::FAIR_CENTROID,
                if f.passes { "fair" } else { "NOT FAIR" }
            );
        }
        None => {
            let _ = writeln!(
                s,
                "  mid-stations   not cut (the sections are not planes of one axis)"
            );
        }
    }
    if let Some(b) = &r.between {
        let skipped = if b.skipped > 0 {
            format!(", {} could not be refitted without them", b.skipped)
        } else {
            String::new()
        };
        let _ = writeln!(
            s,
            "  between        max {:.3e} ({:.2} tol) at span {:.4}, rms {:.3e} ({}: {} sections, {} points{skipped})",
            b.max,
            b.max / tol,
            b.span,
            b.rms,
            b.method,
            b.sections,
            b.points
        );
    }
    if let Some(j) = &r.joined {
        let _ = writeln!(
            s,
            "  joined         {} section(s) lofted between stations, held to {} tol: max {:.3e} ({:.2} tol) at span {:.4}; the stations' max {:.3e} ({:.2} tol)",
            j.sections,
            crate::adaptive::BETWEEN_FACTOR,
            j.max,
            j.max / tol,
            j.span,
            j.stations_max,
            j.stations_max / tol
        );
    }
    if let Some(sc) = &r.scatter {
        let _ = writeln!(
            s,
            "  data scatter   {:.2e} ({:.1e} of the chord, section {}){}",
            sc.sigma,
            sc.relative,
            sc.section,
            if sc.above_tolerance {
                format!(
                    ": the tolerance is below {} times it, so a surface that meets it follows the data's noise",
                    crate::adaptive::SCATTER_FACTOR
                )
            } else {
                String::new()
            }
        );
    }
    let met = r.trace.iter().filter(|t| t.best_scalars.is_some()).count();
    held_out_and_search(&mut s, r.held_out.as_ref(), r.trace.len(), met, r.fits, r.seconds);
    s
}

/// The `held out` and `search` lines of an adaptive search's summary.
fn held_out_and_search(
    s: &mut String,
    held_out: Option<&HeldOut>,
    families: usize,
    met: usize,
    fits: usize,
    seconds: f64,
) {
    match held_out {
        Some(h) => {
            let _ = writeln!(
                s,
                "  held out       max {:.3e}, rms {:.3e} (refitted on {} points, measured on the other {})",
                h.max, h.rms, h.fitted, h.measured
            );
        }
        None => {
            let _ = writeln!(s, "  held out       not possible (too few points for the layout)");
        }
    }
    let _ = writeln!(
        s,
        "  search         {families} families ({met} met the tolerance), {fits} fits, {seconds:.3} s"
    );
}

/// One row of a `--sweep` table.
#[derive(Clone, Debug, PartialEq)]
pub struct SweepRow<'a> {
    tol: f64,
    met: bool,
    scalars: usize,
    max: f64,
    rms: f64,
    held_out_max: Option<f64>,
    seconds: f64,
    family: &'a str,
    /// Why the tolerance does not hold, when it does not (the error says it, not the table).
    pub failure: Option<&'a str>,
}

impl<'a> SweepRow<'a> {
    /// The row of a report whose shape report has `offset` and `fit`, with `outcome` and
    /// `held_out` from its adapt block.
    fn new<C, E>(
        outcome: &'a AdaptOutcome<C, E>,
        offset: &OffsetReport,
        fit: &FitInfo,
        held_out: Option<HeldOut>,
    ) -> Self {
        SweepRow {
            tol: outcome.tol,
            met: outcome.met,
            scalars: outcome.stored_scalars,
            max: offset.max,
            rms: offset.rms,
            held_out_max: held_out.map(|h| h.max),
            seconds: fit.seconds,
            family: &outcome.family,
            failure: outcome.message.as_deref(),
        }
    }
}

/// The `--sweep` table of `adapt` and `adapt-surface`: stored scalars against tolerance, for
/// the `points` of `name`, the tolerances bounding `norm`.
#[must_use]
pub fn sweep_table(name: &str, points: usize, norm: Norm, rows: &[SweepRow<'_>]) -> String {
    let mut s = format!("{name}: {points} points, stored scalars against tolerance ({norm})\n");
    let _ = writeln!(
        s,
        "{:>10} {:>4} {:>8} {:>11} {:>11} {:>13} {:>8}  layout",
        "tol", "met", "scalars", "max", "rms", "held-out max", "seconds"
    );
    for r in rows {
        let held = r.held_out_max.map_or("n/a".to_string(), |m| format!("{m:.3e}"));
        let _ = writeln!(
            s,
            "{:>10.3e} {:>4} {:>8} {:>11.3e} {:>11.3e} {:>13} {:>8.3}  {}",
            r.tol,
            if r.met { "yes" } else { "NO" },
            r.scalars,
            r.max,
            r.rms,
            held,
            r.seconds,
            r.family
        );
    }
    s
}

/// The report of an adapted chain or patch grid, as `adapt` and `adapt-surface` write it.
pub trait Adapted: serde::Serialize {
    /// Its row of the `--sweep` table.
    fn row(&self) -> SweepRow<'_>;
    /// The shape for the STEP and IGES files.
    fn cad_shape(&self) -> Result<CadShape>;
    /// The schema of its JSON report.
    const SCHEMA: Schema;
}

impl Adapted for AdaptReport {
    const SCHEMA: Schema = Schema::Curve;
    fn row(&self) -> SweepRow<'_> {
        SweepRow::new(
            &self.adapt.outcome,
            &self.curve.offset,
            &self.curve.fit,
            self.adapt.held_out,
        )
    }
    fn cad_shape(&self) -> Result<CadShape> {
        CadShape::from_adapt_report(self)
    }
}

impl Adapted for SurfaceAdaptReport {
    const SCHEMA: Schema = Schema::Surface;
    fn row(&self) -> SweepRow<'_> {
        SweepRow::new(
            &self.adapt.outcome,
            &self.surface.offset,
            &self.surface.fit,
            self.adapt.held_out,
        )
    }
    fn cad_shape(&self) -> Result<CadShape> {
        CadShape::from_surface_adapt_report(self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Sections joined between stations get one note with how many and how they are held;
    /// none joined, no note.
    #[test]
    fn joined_sections_are_noted_only_when_there_are_some() {
        assert_eq!(joined_sections("b.yaml", 0, 1), None);
        let note = joined_sections("b.yaml", 4, 2).unwrap();
        assert!(
            note.starts_with("note: b.yaml: 4 section(s) lofted between stations"),
            "{note}"
        );
        assert!(
            note.contains("(2 searches)") && note.contains("held to 3 tolerances"),
            "{note}"
        );
    }

    /// Only section ends beyond the allowance warn, with where and how far in tolerances.
    #[test]
    fn only_ends_that_double_back_warn() {
        let ends = |excess: f64, passes: bool| SectionEnds {
            cuts: 465,
            excess,
            span: 11.341_836,
            end: 1,
            at: Some([0.886, 3.044, 11.342]),
            passes,
        };
        assert_eq!(ends_warning(None, 1e-3), None);
        assert_eq!(ends_warning(Some(&ends(3e-4, true)), 1e-3), None);
        let w = ends_warning(Some(&ends(1.729e-2, false)), 5.765e-3).unwrap();
        let r = ends_remark(Some(&ends(1.729e-2, false)), 5.765e-3).unwrap();
        assert_eq!(r.position, DVec3::new(0.886, 3.044, 11.342));
        assert_eq!(r.label, "end 1 doubles back 1.73e-2 (3.00 tol), span 11.34");
        assert_eq!(ends_remark(Some(&ends(3e-4, true)), 1e-3), None);
        assert!(
            w.contains("end 1 near span 11.3418: 1.729e-2 (3.00 tol)")
                && w.contains("section_ends")
                && w.contains("--points-per-section"),
            "{w}"
        );
    }

    /// The sweep table lines its columns up and says where a tolerance is not met.
    #[test]
    fn the_sweep_table_has_a_row_per_tolerance() {
        let row = |tol: f64, met: bool| SweepRow {
            tol,
            met,
            scalars: 9,
            max: 9.02e-4,
            rms: 6.094e-4,
            held_out_max: met.then_some(1.074e-3),
            seconds: 0.01,
            family: "aerofoil d3 C2 uniform",
            failure: None,
        };
        let t = sweep_table("a.dat", 82, Norm::Max, &[row(1e-2, true), row(1e-3, false)]);
        let lines: Vec<&str> = t.lines().collect();
        assert_eq!(
            lines[0],
            "a.dat: 82 points, stored scalars against tolerance (max)"
        );
        assert_eq!(
            lines[2],
            "  1.000e-2  yes        9    9.020e-4    6.094e-4      1.074e-3    0.010  aerofoil d3 C2 uniform"
        );
        assert!(
            lines[3].contains("  NO ") && lines[3].contains("n/a"),
            "{}",
            lines[3]
        );
        assert_eq!(fixed4(&[0.0, 0.8, 1.0], " "), "0.0000 0.8000 1.0000");
    }

    /// The estimate is the mean pace so far times the steps left, in minutes past a minute,
    /// and nothing before the first step or after the last.
    #[test]
    fn the_time_left_is_the_mean_pace_times_the_steps_left() {
        let s = Duration::from_secs;
        assert_eq!(time_left(s(10), 1, 4), ", about 30 s left");
        assert_eq!(time_left(s(30), 3, 10), ", about 1 min 10 s left");
        assert_eq!(time_left(s(30), 0, 10), "");
        assert_eq!(time_left(s(30), 10, 10), "");
    }

    #[test]
    fn a_capped_method_says_its_cap_and_effort() {
        let report = SolveReport {
            iterations: 200,
            evaluations: 4100,
            seconds: 1.26,
            stop: crate::optim::StopReason::MaxIterations,
        };
        assert_eq!(
            cap_warning("bfgs", "iteration limit", &report),
            "bfgs stopped at its iteration limit (200 iterations, 4100 evaluations, 1.3 s) before \
             converging: the result is the best found so far"
        );
    }
}
