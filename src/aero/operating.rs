//! The operating points of a viscous objective and a shape's score on them: each point an
//! angle of attack or a design CL (the angle then solved for) at a Reynolds number, with a
//! weight; the score the weighted mean of `−CL/CD` (`max-ld`, `multipoint`) or of `CD`
//! (`min-cd`). Each point is solved from a neighbour's converged boundary layer when there is
//! one ([`Solved`], the optimisation's start or the centre of its population), else from a
//! cold start. `docs/ARCHITECTURE.md` §2.12 and §5 (the multipoint file).

use super::panel::PanelSolution;
use super::viscous::polar::MAX_ALPHA;
use super::viscous::{Viscous, ViscousOptions, ViscousPoint, Warm};
use crate::error::{Error, Result};
use glam::DVec2;
use std::path::Path;

/// Where an operating point sits.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Condition {
    /// At this angle of attack, degrees.
    Alpha(f64),
    /// At the angle that gives this CL.
    Cl(f64),
}

/// One weighted operating point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OperatingPoint {
    /// Its weight in the mean (> 0).
    pub weight: f64,
    /// The angle or the design CL.
    pub at: Condition,
    /// Chord Reynolds number.
    pub re: f64,
}

/// What each point contributes to the score.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Goal {
    /// `−CL/CD`: the largest lift-to-drag ratio.
    MaxLd,
    /// `CD`: the least drag.
    MinCd,
}

/// A viscous objective: the goal, the points, the critical amplification factor.
#[derive(Clone, Debug, PartialEq)]
pub struct ViscousGoal {
    /// What each point contributes.
    pub goal: Goal,
    /// The operating points (at least one).
    pub points: Vec<OperatingPoint>,
    /// Ncrit of the e^N transition (default 9).
    pub ncrit: f64,
}

/// A design CL is met when the solved CL is within this of it.
pub const CL_TOLERANCE: f64 = 2e-4;
/// Secant steps on α allowed to meet a design CL.
const CL_STEPS: usize = 12;
/// The largest step of α in one secant step, degrees.
const MAX_STEP: f64 = 3.0;

/// A converged point, with its boundary layer to start neighbours from.
#[derive(Clone, Debug)]
pub struct Solved {
    /// The angle of attack, degrees.
    pub alpha: f64,
    /// Lift coefficient.
    pub cl: f64,
    /// Drag coefficient.
    pub cd: f64,
    /// Moment coefficient about the quarter chord.
    pub cm: f64,
    warm: Warm,
}

impl Solved {
    /// The viscous pressure coefficient at the body's `nodes` panel nodes, in their order.
    #[must_use]
    pub fn cp(&self, nodes: usize) -> Vec<f64> {
        self.warm.cp(nodes)
    }
}

impl ViscousGoal {
    /// The solver's options at `point`.
    fn options(&self, point: &OperatingPoint) -> ViscousOptions {
        ViscousOptions {
            re: point.re,
            ncrit: self.ncrit,
            ..ViscousOptions::default()
        }
    }

    /// `Ok` when every point's settings are inside the solver's ranges.
    pub fn check(&self) -> Result<()> {
        if self.points.is_empty() {
            return Err(Error::invalid("a viscous objective needs an operating point"));
        }
        for p in &self.points {
            self.options(p).check()?;
            if let Condition::Alpha(a) = p.at {
                if !(a.abs() <= MAX_ALPHA) {
                    return Err(Error::invalid(format!(
                        "an angle of attack must be between -{MAX_ALPHA} and {MAX_ALPHA} degrees, not {a}"
                    )));
                }
            }
        }
        Ok(())
    }

    /// Solve every point on `nodes`, each from `anchors`' point when it has one (one entry a
    /// point); `None` for a point that does not converge. An error when the panel system of
    /// `nodes` cannot be factored.
    pub fn solve(&self, nodes: &[DVec2], anchors: &[Option<Solved>]) -> Result<Vec<Option<Solved>>> {
        let body = Viscous::new(nodes)?;
        let mut inviscid = None;
        Ok(self
            .points
            .iter()
            .enumerate()
            .map(|(i, p)| {
                let opts = self.options(p);
                let anchor = anchors.get(i).and_then(Option::as_ref);
                match p.at {
                    Condition::Alpha(a) => point(&body, a, &opts, anchor.map(|s| &s.warm)),
                    Condition::Cl(cl) => {
                        let a0 = match anchor {
                            Some(s) => s.alpha,
                            None => *inviscid.get_or_insert_with(|| inviscid_alpha(nodes, cl)),
                        };
                        at_cl(&body, cl, a0, &opts, anchor)
                    }
                }
            })
            .collect())
    }

    /// The score of solved points: the weighted mean of each point's term; `None` when one
    /// did not converge.
    #[must_use]
    pub fn objective(&self, solved: &[Option<Solved>]) -> Option<f64> {
        let (mut sum, mut weights) = (0.0, 0.0);
        for (p, s) in self.points.iter().zip(solved) {
            let s = s.as_ref()?;
            let term = match self.goal {
                Goal::MaxLd => -s.cl / s.cd,
                Goal::MinCd => s.cd,
            };
            sum += p.weight * term;
            weights += p.weight;
        }
        Some(sum / weights)
    }
}

/// The angle whose inviscid CL is `cl` on `nodes` (CL is `A sin α + B cos α` there); 0 when
/// the panel system cannot be solved.
fn inviscid_alpha(nodes: &[DVec2], cl: f64) -> f64 {
    let Ok(sol) = PanelSolution::solve(nodes) else {
        return 0.0;
    };
    let b = sol.coefficients(0.0).cl;
    let a = sol.coefficients(90.0).cl;
    // A sin α + B cos α = R sin(α + φ).
    let r = a.hypot(b);
    if !(r > cl.abs()) {
        return 0.0;
    }
    ((cl / r).asin() - b.atan2(a))
        .to_degrees()
        .clamp(-MAX_ALPHA, MAX_ALPHA)
}

/// Where a ramp to an angle that fails from a cold start begins: cold starts at these
/// fractions of the angle, tried in turn.
const RAMP_FROM: [f64; 2] = [0.5, 0.0];
/// The largest step of α along a ramp, degrees.
const RAMP_STEP: f64 = 1.0;

/// One point at `alpha`, from `warm`; when that fails, from a cold start; when that fails too,
/// along a ramp: a cold start at a smaller angle ([`RAMP_FROM`]), then steps of at most
/// [`RAMP_STEP`] each from the last (as a polar's continuation reaches angles a cold start
/// does not).
fn point(body: &Viscous, alpha: f64, opts: &ViscousOptions, warm: Option<&Warm>) -> Option<Solved> {
    let solve = |a: f64, w: Option<&Warm>| {
        let (p, w): (ViscousPoint, Option<Warm>) = body.point(a, opts, w);
        Some(Solved {
            alpha: a,
            cl: p.cl?,
            cd: p.cd?,
            cm: p.cm?,
            warm: w?,
        })
    };
    if let Some(s) = solve(alpha, warm) {
        return Some(s);
    }
    if warm.is_some() {
        if let Some(s) = solve(alpha, None) {
            return Some(s);
        }
    }
    RAMP_FROM.iter().find_map(|&f| {
        let mut cur = solve(f * alpha, None)?;
        let from = cur.alpha;
        let steps = ((alpha - from).abs() / RAMP_STEP).ceil().max(1.0) as usize;
        for k in 1..=steps {
            let a = if k == steps {
                alpha
            } else {
                from + (alpha - from) * k as f64 / steps as f64
            };
            cur = solve(a, Some(&cur.warm))?;
        }
        Some(cur)
    })
}

/// The point whose CL is `cl`: secant steps on α from `alpha0`, each from the last converged
/// point (a step that fails is halved, twice); `None` when CL is not met within
/// [`CL_TOLERANCE`].
fn at_cl(
    body: &Viscous,
    cl: f64,
    alpha0: f64,
    opts: &ViscousOptions,
    anchor: Option<&Solved>,
) -> Option<Solved> {
    let mut cur = point(body, alpha0, opts, anchor.map(|s| &s.warm))?;
    let mut prev: Option<(f64, f64)> = None;
    for _ in 0..CL_STEPS {
        let miss = cur.cl - cl;
        if miss.abs() <= CL_TOLERANCE {
            return Some(cur);
        }
        // A lift slope between 0.02 and 0.2 per degree (thin-aerofoil theory: 0.11).
        let slope = match prev {
            Some((a, c)) if (cur.alpha - a).abs() > 1e-9 => ((cur.cl - c) / (cur.alpha - a)).clamp(0.02, 0.2),
            _ => 0.11,
        };
        let mut step = (-miss / slope).clamp(-MAX_STEP, MAX_STEP);
        let mut next = None;
        for _ in 0..3 {
            let a = (cur.alpha + step).clamp(-MAX_ALPHA, MAX_ALPHA);
            if let Some(s) = point(body, a, opts, Some(&cur.warm)) {
                next = Some(s);
                break;
            }
            step *= 0.5;
        }
        let next = next?;
        prev = Some((cur.alpha, cur.cl));
        cur = next;
    }
    ((cur.cl - cl).abs() <= CL_TOLERANCE).then_some(cur)
}

/// Read a multipoint file: one point a line, `WEIGHT, alpha=A | cl=C, RE` (commas or
/// whitespace between the fields; `#` starts a comment; blank lines skipped). An error names
/// the file and the line.
pub fn read_points(path: &Path) -> Result<Vec<OperatingPoint>> {
    let text = std::fs::read_to_string(path).map_err(|source| Error::Io {
        path: path.into(),
        source,
    })?;
    let mut points = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let line = raw.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let bad = |message: String| Error::Parse {
            path: path.into(),
            line: i + 1,
            message,
        };
        let fields: Vec<&str> = line
            .split(|c: char| c == ',' || c.is_whitespace())
            .filter(|f| !f.is_empty())
            .collect();
        let [w, at, re] = fields[..] else {
            return Err(bad(format!(
                "expected WEIGHT, alpha=A or cl=C, RE (three fields), found {}",
                fields.len()
            )));
        };
        let number = |what: &str, s: &str| {
            s.parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| bad(format!("{what} '{s}' is not a number")))
        };
        let weight = number("the weight", w)?;
        if !(weight > 0.0) {
            return Err(bad(format!("the weight must be positive, not {weight}")));
        }
        let at = match at.split_once('=') {
            Some((k, v)) if k.eq_ignore_ascii_case("alpha") => Condition::Alpha(number("alpha", v)?),
            Some((k, v)) if k.eq_ignore_ascii_case("cl") => Condition::Cl(number("cl", v)?),
            _ => return Err(bad(format!("expected alpha=A or cl=C, not '{at}'"))),
        };
        let re = number("the Reynolds number", re)?;
        let p = OperatingPoint { weight, at, re };
        ViscousGoal {
            goal: Goal::MaxLd,
            points: vec![p],
            ncrit: ViscousOptions::default().ncrit,
        }
        .check()
        .map_err(|e| bad(e.to_string()))?;
        points.push(p);
    }
    if points.is_empty() {
        return Err(Error::Input {
            path: path.into(),
            message: "no operating points (one a line: WEIGHT, alpha=A or cl=C, RE)".into(),
        });
    }
    Ok(points)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn naca4412() -> Vec<DVec2> {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/airfoils/naca4412.dat");
        let (_, a) =
            crate::aero::Aerofoil::analyse(&path, &crate::aero::Paneling::default(), "", &mut |_, _| {})
                .unwrap();
        a.solution.nodes().to_vec()
    }

    /// A design CL is met by the secant steps, from a cold start and from a converged
    /// solution (the same point, to within the CL tolerance's effect on CD).
    #[test]
    fn a_design_cl_is_met() {
        let nodes = naca4412();
        let goal = ViscousGoal {
            goal: Goal::MinCd,
            points: vec![OperatingPoint {
                weight: 1.0,
                at: Condition::Cl(0.8),
                re: 1e6,
            }],
            ncrit: 9.0,
        };
        let cold = goal.solve(&nodes, &[None]).unwrap();
        let s = cold[0].as_ref().expect("converged");
        assert!((s.cl - 0.8).abs() <= CL_TOLERANCE, "{s:?}");
        assert!(s.alpha > 1.0 && s.alpha < 5.0, "{s:?}");
        let warm = goal.solve(&nodes, &cold).unwrap();
        let w = warm[0].as_ref().expect("converged");
        assert!(
            (w.cl - 0.8).abs() <= CL_TOLERANCE && (w.cd - s.cd).abs() < 1e-5,
            "{w:?}"
        );
        assert_eq!(goal.objective(&warm), Some(w.cd));
    }

    #[test]
    fn multipoint_files_are_read_and_bad_lines_named() {
        let dir = std::env::temp_dir().join(format!("bezchain-mp-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let good = dir.join("good.txt");
        std::fs::write(
            &good,
            "# weight, point, Re\n1, alpha=4, 1e6\n\n0.5 cl=0.8 3e5 # cruise\n",
        )
        .unwrap();
        let p = read_points(&good).unwrap();
        assert_eq!(p.len(), 2);
        assert_eq!(p[1].at, Condition::Cl(0.8));
        assert_eq!(p[1].weight, 0.5);
        for (text, line, says) in [
            ("1, alpha=4, 1e6\n1, beta=4, 1e6\n", 2, "expected alpha=A or cl=C"),
            ("1, alpha=4\n", 1, "three fields"),
            ("-1, alpha=4, 1e6\n", 1, "positive"),
            ("\n1, alpha=4, 10\n", 2, "Reynolds number"),
            ("1, alpha=x, 1e6\n", 1, "not a number"),
        ] {
            let f = dir.join("bad.txt");
            std::fs::write(&f, text).unwrap();
            let e = read_points(&f).unwrap_err().to_string();
            assert!(e.starts_with(&format!("{}:{line}: ", f.display())), "{e}");
            assert!(e.contains(says), "{e}");
        }
        std::fs::remove_dir_all(&dir).ok();
    }
}
