//! Checkpoints of an evolutionary run: everything needed to continue it bit-identically, in a
//! compact versioned binary file written atomically (temporary file, then rename).
//!
//! Layout (little-endian): the 8-byte magic `BZEVOCK\0`, a `u32` format version, the fields
//! in the order of [`Checkpoint`] (numbers as their IEEE bits, vectors as a `u64` length then
//! the elements, strings as UTF-8 with a `u64` length), and last a `u64` FNV-1a checksum of
//! every byte before it. Random numbers need no state: they come from streams derived from
//! the seed, the generation and the individual (see `rng`).

use super::cmaes::CmaesState;
use super::objective::{Fnv, Score};
use super::Progress;
use crate::error::{Error, Result};
use crate::optim::method::Method;
use std::path::Path;

const MAGIC: &[u8; 8] = b"BZEVOCK\0";
/// The format version this build writes and reads.
pub const VERSION: u32 = 2;

/// The state of an evolutionary run after a generation.
#[derive(Clone, Debug, PartialEq)]
pub struct Checkpoint {
    /// Fingerprint of the problem (data, layout, anchors, bounds, start), the method and the
    /// options that shape the run (population, seed, Newton steps, operators); a checkpoint is
    /// only resumed by a run with the same fingerprint.
    pub fingerprint: u64,
    /// The method.
    pub algorithm: Method,
    /// The backend and adapter that ran it (results are bit-identical only on the same one).
    pub backend: String,
    /// Design variables per individual.
    pub dim: usize,
    /// Individuals per generation.
    pub size: usize,
    /// Generations completed.
    pub generation: u64,
    /// Individuals evaluated so far.
    pub evaluations: u64,
    /// Wall-clock seconds so far.
    pub seconds: f64,
    /// Seconds spent in the population evaluator so far.
    pub eval_seconds: f64,
    /// Individual × point evaluations so far.
    pub point_evals: u64,
    /// The evaluator's start parameters, one `(u, v)` per free data point.
    pub params: Vec<[f64; 2]>,
    /// The best individual met so far.
    pub best: Vec<f32>,
    /// Its score.
    pub best_score: Score,
    /// The best sum of squares at the last improvement that counted against stalling.
    pub stall_reference: f64,
    /// The generation of that improvement.
    pub stall_since: u64,
    /// One line per generation so far.
    pub history: Vec<Progress>,
    /// The GA's population (empty for CMA-ES).
    pub population: Vec<f32>,
    /// Its scores.
    pub scores: Vec<Score>,
    /// The CMA-ES strategy (`None` for the GA).
    pub cmaes: Option<CmaesState>,
}

struct Writer(Vec<u8>);

impl Writer {
    fn u64(&mut self, x: u64) {
        self.0.extend_from_slice(&x.to_le_bytes());
    }
    fn f64(&mut self, x: f64) {
        self.u64(x.to_bits());
    }
    fn len(&mut self, n: usize) {
        self.u64(n as u64);
    }
    /// A length, then every item as `put` writes it.
    fn list<T>(&mut self, xs: &[T], mut put: impl FnMut(&mut Self, &T)) {
        self.len(xs.len());
        xs.iter().for_each(|x| put(self, x));
    }
    fn f64s(&mut self, xs: &[f64]) {
        self.list(xs, |w, &x| w.f64(x));
    }
    fn f32s(&mut self, xs: &[f32]) {
        self.len(xs.len());
        for x in xs {
            self.0.extend_from_slice(&x.to_bits().to_le_bytes());
        }
    }
    fn score(&mut self, s: &Score) {
        self.f64(s.sum_sq);
        self.f64(s.max);
    }
}

struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> Reader<'a> {
    fn take(&mut self, n: usize) -> std::result::Result<&'a [u8], String> {
        let end = self
            .at
            .checked_add(n)
            .filter(|&e| e <= self.bytes.len())
            .ok_or_else(|| "the file ends early (truncated?)".to_string())?;
        let s = &self.bytes[self.at..end];
        self.at = end;
        Ok(s)
    }
    fn u64(&mut self) -> std::result::Result<u64, String> {
        let b = self.take(8)?;
        let mut a = [0u8; 8];
        a.copy_from_slice(b);
        Ok(u64::from_le_bytes(a))
    }
    fn f64(&mut self) -> std::result::Result<f64, String> {
        self.u64().map(f64::from_bits)
    }
    /// A length, refused when the rest of the file cannot hold `len · size` bytes.
    fn len(&mut self, size: usize) -> std::result::Result<usize, String> {
        let n = self.u64()?;
        let left = (self.bytes.len() - self.at) as u64;
        if n.checked_mul(size as u64).is_none_or(|b| b > left) {
            return Err(format!("a length of {n} runs past the end of the file"));
        }
        Ok(n as usize)
    }
    /// A length, then that many items of at least `size` bytes each, as `get` reads them.
    fn list<T>(
        &mut self,
        size: usize,
        mut get: impl FnMut(&mut Self) -> std::result::Result<T, String>,
    ) -> std::result::Result<Vec<T>, String> {
        let n = self.len(size)?;
        (0..n).map(|_| get(self)).collect()
    }
    fn f64s(&mut self) -> std::result::Result<Vec<f64>, String> {
        self.list(8, Self::f64)
    }
    fn f32s(&mut self) -> std::result::Result<Vec<f32>, String> {
        let n = self.len(4)?;
        let b = self.take(n * 4)?;
        Ok(b.chunks_exact(4)
            .map(|c| f32::from_bits(u32::from_le_bytes([c[0], c[1], c[2], c[3]])))
            .collect())
    }
    fn score(&mut self) -> std::result::Result<Score, String> {
        Ok(Score {
            sum_sq: self.f64()?,
            max: self.f64()?,
        })
    }
}

impl Checkpoint {
    /// The file's bytes.
    #[must_use]
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut w = Writer(Vec::with_capacity(
            64 + 4 * self.population.len() + 16 * self.scores.len(),
        ));
        w.0.extend_from_slice(MAGIC);
        w.0.extend_from_slice(&VERSION.to_le_bytes());
        w.u64(self.fingerprint);
        // A run's stage is one of the evolutionary methods: 0 the GA, 1 CMA-ES.
        w.0.push(u8::from(self.algorithm == Method::Cmaes));
        w.len(self.backend.len());
        w.0.extend_from_slice(self.backend.as_bytes());
        w.len(self.dim);
        w.len(self.size);
        w.u64(self.generation);
        w.u64(self.evaluations);
        w.f64(self.seconds);
        w.f64(self.eval_seconds);
        w.u64(self.point_evals);
        w.list(&self.params, |w, p| {
            w.f64(p[0]);
            w.f64(p[1]);
        });
        w.f32s(&self.best);
        w.score(&self.best_score);
        w.f64(self.stall_reference);
        w.u64(self.stall_since);
        w.list(&self.history, |w, h| {
            w.u64(h.generation);
            w.f64(h.best);
            w.f64(h.mean);
            w.u64(h.evaluations);
            w.f64(h.seconds);
        });
        w.f32s(&self.population);
        w.list(&self.scores, Writer::score);
        match &self.cmaes {
            None => w.0.push(0),
            Some(c) => {
                w.0.push(1);
                w.f64s(&c.mean);
                w.f64(c.sigma);
                w.f64s(&c.cov);
                w.f64s(&c.basis);
                w.f64s(&c.scales);
                w.f64s(&c.path_c);
                w.f64s(&c.path_sigma);
                w.u64(c.generation);
                w.u64(c.decomposed_at);
                w.f64s(&c.recent);
                w.f64s(&c.origin);
                w.f64(c.initial_sigma);
                w.u64(c.restarts);
                w.f64s(&c.kept_mean);
                w.f64(c.kept_sum_sq);
            }
        }
        let mut h = Fnv::new();
        h.bytes(&w.0);
        let sum = h.finish();
        w.u64(sum);
        w.0
    }

    /// Read a checkpoint from its bytes; the error says what is wrong.
    pub fn from_bytes(bytes: &[u8]) -> std::result::Result<Self, String> {
        if bytes.len() < MAGIC.len() + 4 + 8 || &bytes[..MAGIC.len()] != MAGIC {
            return Err("not a bezchain checkpoint".into());
        }
        let body = &bytes[..bytes.len() - 8];
        let mut tail = [0u8; 8];
        tail.copy_from_slice(&bytes[bytes.len() - 8..]);
        let mut h = Fnv::new();
        h.bytes(body);
        let version = u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]);
        if version != VERSION {
            return Err(format!(
                "checkpoint format version {version}; this build reads version {VERSION}"
            ));
        }
        if h.finish() != u64::from_le_bytes(tail) {
            return Err("the checksum does not match (the file is truncated or damaged)".into());
        }
        let mut r = Reader { bytes: body, at: 12 };
        let fingerprint = r.u64()?;
        let algorithm = match r.take(1)?[0] {
            0 => Method::Ga,
            1 => Method::Cmaes,
            a => return Err(format!("unknown method code {a}")),
        };
        let n = r.len(1)?;
        let backend = String::from_utf8(r.take(n)?.to_vec()).map_err(|_| "the backend name is not UTF-8")?;
        let dim = r.u64()? as usize;
        let size = r.u64()? as usize;
        let generation = r.u64()?;
        let evaluations = r.u64()?;
        let seconds = r.f64()?;
        let eval_seconds = r.f64()?;
        let point_evals = r.u64()?;
        let params = r.list(16, |r| Ok([r.f64()?, r.f64()?]))?;
        let best = r.f32s()?;
        let best_score = r.score()?;
        let stall_reference = r.f64()?;
        let stall_since = r.u64()?;
        let history = r.list(40, |r| {
            Ok(Progress {
                generation: r.u64()?,
                best: r.f64()?,
                mean: r.f64()?,
                evaluations: r.u64()?,
                seconds: r.f64()?,
            })
        })?;
        let population = r.f32s()?;
        let scores = r.list(16, Reader::score)?;
        let cmaes = match r.take(1)?[0] {
            0 => None,
            1 => Some(CmaesState {
                mean: r.f64s()?,
                sigma: r.f64()?,
                cov: r.f64s()?,
                basis: r.f64s()?,
                scales: r.f64s()?,
                path_c: r.f64s()?,
                path_sigma: r.f64s()?,
                generation: r.u64()?,
                decomposed_at: r.u64()?,
                recent: r.f64s()?,
                origin: r.f64s()?,
                initial_sigma: r.f64()?,
                restarts: r.u64()?,
                kept_mean: r.f64s()?,
                kept_sum_sq: r.f64()?,
            }),
            c => return Err(format!("unknown strategy code {c}")),
        };
        if r.at != body.len() {
            return Err("unexpected bytes after the last field".into());
        }
        let ck = Checkpoint {
            fingerprint,
            algorithm,
            backend,
            dim,
            size,
            generation,
            evaluations,
            seconds,
            eval_seconds,
            point_evals,
            params,
            best,
            best_score,
            stall_reference,
            stall_since,
            history,
            population,
            scores,
            cmaes,
        };
        ck.check_values()?;
        ck.check_shapes()?;
        Ok(ck)
    }

    /// The sizes agree with each other.
    fn check_shapes(&self) -> std::result::Result<(), String> {
        if self.best.len() != self.dim {
            return Err(format!(
                "the best individual has {} variables, the checkpoint says {}",
                self.best.len(),
                self.dim
            ));
        }
        match (self.algorithm, &self.cmaes) {
            (Method::Ga, None) => {
                if Some(self.population.len()) != self.size.checked_mul(self.dim)
                    || self.scores.len() != self.size
                {
                    return Err("the GA population does not match its size".into());
                }
            }
            (Method::Cmaes, Some(c)) => c.check(self.dim).map_err(|e| e.to_string())?,
            _ => return Err("the strategy does not match the method".into()),
        }
        Ok(())
    }

    /// Every value is one a run can hold: design variables, the scorer's state and the
    /// strategy's numbers finite, the step size positive, scores finite or `+∞` (an
    /// unevaluated or penalised individual; an objective may be negative, `−CL`), times
    /// finite. What the scorer's state means is the objective's to check when it resumes
    /// (the fitting problem: parameters in `[0, 1]`). A
    /// checksum only proves the file is the one written; this proves the state is usable, so a
    /// damaged or hand-edited checkpoint is refused before a run resumes from it.
    pub fn check_values(&self) -> std::result::Result<(), String> {
        fn finite<T: Into<f64> + Copy>(what: &str, xs: &[T]) -> std::result::Result<(), String> {
            match xs.iter().position(|&x| !x.into().is_finite()) {
                Some(i) => Err(format!("{what}[{i}] is {} (not finite)", xs[i].into())),
                None => Ok(()),
            }
        }
        fn score(what: &str, x: f64) -> std::result::Result<(), String> {
            if x.is_nan() || x == f64::NEG_INFINITY {
                Err(format!("{what} is {x} (a score is finite or +inf)"))
            } else {
                Ok(())
            }
        }
        if self.dim == 0 || self.size == 0 {
            return Err(format!(
                "{} design variables and {} individuals per generation (both must be ≥ 1)",
                self.dim, self.size
            ));
        }
        for (what, t) in [("seconds", self.seconds), ("eval_seconds", self.eval_seconds)] {
            if !(t.is_finite() && t >= 0.0) {
                return Err(format!("{what} is {t} (a time is finite and ≥ 0)"));
            }
        }
        finite("best", &self.best)?;
        score("best_score.sum_sq", self.best_score.sum_sq)?;
        score("best_score.max", self.best_score.max)?;
        score("stall_reference", self.stall_reference)?;
        if self.stall_since > self.generation {
            return Err(format!(
                "stall_since {} is after generation {}",
                self.stall_since, self.generation
            ));
        }
        // One history line a generation, from 0 to the checkpoint's: a resumed run appends to
        // them, and a run resumed after its last generation writes its outputs from them.
        if let Some((i, h)) = self
            .history
            .iter()
            .enumerate()
            .find(|(i, h)| h.generation != *i as u64)
        {
            return Err(format!(
                "history[{i}] is of generation {} (line i is of generation i)",
                h.generation
            ));
        }
        if self.history.len() as u64 != self.generation.saturating_add(1) {
            return Err(format!(
                "the history has {} lines for generation {} (one a generation from 0)",
                self.history.len(),
                self.generation
            ));
        }
        if let Some(i) = self.params.iter().flatten().position(|t| !t.is_finite()) {
            return Err(format!(
                "params[{}][{}] is {} (not finite)",
                i / 2,
                i % 2,
                self.params[i / 2][i % 2]
            ));
        }
        for (i, h) in self.history.iter().enumerate() {
            score(&format!("history[{i}].best"), h.best)?;
            score(&format!("history[{i}].mean"), h.mean)?;
            if !(h.seconds.is_finite() && h.seconds >= 0.0) {
                return Err(format!("history[{i}].seconds is {} (not a time)", h.seconds));
            }
        }
        finite("population", &self.population)?;
        for (i, s) in self.scores.iter().enumerate() {
            score(&format!("scores[{i}].sum_sq"), s.sum_sq)?;
            score(&format!("scores[{i}].max"), s.max)?;
        }
        if let Some(c) = &self.cmaes {
            finite("cmaes.mean", &c.mean)?;
            finite("cmaes.cov", &c.cov)?;
            finite("cmaes.basis", &c.basis)?;
            finite("cmaes.scales", &c.scales)?;
            finite("cmaes.path_c", &c.path_c)?;
            finite("cmaes.path_sigma", &c.path_sigma)?;
            finite("cmaes.origin", &c.origin)?;
            finite("cmaes.kept_mean", &c.kept_mean)?;
            if !c.kept_mean.is_empty() {
                score("cmaes.kept_sum_sq", c.kept_sum_sq)?;
            }
            for (name, sigma) in [("sigma", c.sigma), ("initial_sigma", c.initial_sigma)] {
                if !(sigma.is_finite() && sigma > 0.0) {
                    return Err(format!("cmaes.{name} is {sigma} (a step size is finite and > 0)"));
                }
            }
            if let Some(i) = c.scales.iter().position(|&d| d < 0.0) {
                return Err(format!(
                    "cmaes.scales[{i}] is {} (a square root is ≥ 0)",
                    c.scales[i]
                ));
            }
            for (i, &r) in c.recent.iter().enumerate() {
                score(&format!("cmaes.recent[{i}]"), r)?;
            }
        }
        Ok(())
    }

    /// Every individual the checkpoint holds (the best, and the GA's population) lies inside
    /// the run's box `bounds` (one `[lo, hi]` per design variable): a checkpoint whose
    /// fingerprint matches but whose values were edited is refused.
    pub fn check_bounds(&self, bounds: &[[f64; 2]]) -> std::result::Result<(), String> {
        if bounds.len() != self.dim {
            return Err(format!(
                "{} design variables, the problem has {}",
                self.dim,
                bounds.len()
            ));
        }
        let rows = std::iter::once(("best", 0, self.best.as_slice())).chain(
            self.population
                .chunks_exact(self.dim)
                .enumerate()
                .map(|(k, r)| ("population row", k, r)),
        );
        for (what, k, row) in rows {
            for (j, (&x, &[lo, hi])) in row.iter().zip(bounds).enumerate() {
                let x = f64::from(x);
                if !(lo..=hi).contains(&x) {
                    let which = if what == "best" {
                        "the best individual".to_string()
                    } else {
                        format!("{what} {k}")
                    };
                    return Err(format!(
                        "variable {j} of {which} is {x}, outside the run's bounds [{lo}, {hi}]"
                    ));
                }
            }
        }
        Ok(())
    }

    /// Write the checkpoint to `path` atomically: a temporary file beside it, then a rename,
    /// so an interrupted write leaves the previous checkpoint whole.
    pub fn write(&self, path: &Path) -> Result<()> {
        let bytes = self.to_bytes();
        crate::geometry::write_atomic(path, |w| std::io::Write::write_all(w, &bytes))
    }

    /// Read a checkpoint file; a missing, unreadable or damaged file is an [`Error::Input`]
    /// naming it.
    pub fn read(path: &Path) -> Result<Self> {
        let bytes = crate::geometry::read_bytes(path).map_err(|e| match e {
            Error::Io { path, source } => Error::Input {
                path,
                message: format!("cannot read the checkpoint: {source}"),
            },
            e => e,
        })?;
        Self::from_bytes(&bytes).map_err(|message| Error::Input {
            path: path.to_path_buf(),
            message: format!("unreadable checkpoint: {message}"),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(algorithm: Method) -> Checkpoint {
        let cmaes = (algorithm == Method::Cmaes).then(|| {
            // A restarted state: the restart count and the kept mean go through too.
            let mut c = CmaesState::new(&[0.5, -1.0], 0.1).restarted(3e-6);
            c.path_c = vec![1e-300, f64::MIN_POSITIVE];
            c
        });
        let (population, scores) = match algorithm {
            Method::Ga => (
                vec![1.0, 2.0, -0.0, f32::MIN_POSITIVE, 3.5, 1e-30],
                vec![
                    Score {
                        sum_sq: 1.0,
                        max: 0.5,
                    },
                    Score::WORST,
                    Score {
                        sum_sq: 2.0e-9,
                        max: 1e-5,
                    },
                ],
            ),
            _ => (Vec::new(), Vec::new()),
        };
        Checkpoint {
            fingerprint: 0xdead_beef_0123_4567,
            algorithm,
            backend: "cpu: test ✓".into(),
            dim: 2,
            size: 3,
            generation: 50,
            evaluations: 51 * 3,
            seconds: 1.25,
            eval_seconds: 0.5,
            point_evals: 12345,
            params: vec![[0.1, 0.0], [0.9, 0.3]],
            best: vec![0.25, -0.125],
            best_score: Score {
                sum_sq: 3e-7,
                max: f64::INFINITY,
            },
            stall_reference: 3e-7,
            stall_since: 44,
            history: (0..=50)
                .map(|g| Progress {
                    generation: g,
                    best: 1.0 / (g + 1) as f64,
                    mean: f64::INFINITY,
                    evaluations: 3 * (g + 1),
                    seconds: 0.025 * g as f64,
                })
                .collect(),
            population,
            scores,
            cmaes,
        }
    }

    #[test]
    fn round_trips_bit_for_bit() {
        for a in [Method::Ga, Method::Cmaes] {
            let c = sample(a);
            let back = Checkpoint::from_bytes(&c.to_bytes()).unwrap();
            assert_eq!(back.to_bytes(), c.to_bytes());
            assert_eq!(back.best_score.max, f64::INFINITY);
            assert_eq!(
                back.population.iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
                c.population.iter().map(|x| x.to_bits()).collect::<Vec<_>>()
            );
        }
    }

    #[test]
    fn damaged_files_are_refused_with_a_reason() {
        let bytes = sample(Method::Ga).to_bytes();
        let e = Checkpoint::from_bytes(&bytes[..bytes.len() - 3]).unwrap_err();
        assert!(e.contains("checksum"), "{e}");
        let mut flipped = bytes.clone();
        flipped[40] ^= 1;
        assert!(Checkpoint::from_bytes(&flipped).unwrap_err().contains("checksum"));
        assert!(Checkpoint::from_bytes(b"hello")
            .unwrap_err()
            .contains("not a bezchain"));
        let mut other = bytes.clone();
        other[8] = VERSION as u8 + 1;
        let e = Checkpoint::from_bytes(&other).unwrap_err();
        assert!(e.contains(&format!("version {}", VERSION + 1)), "{e}");
        assert!(Checkpoint::from_bytes(&[]).is_err());
    }

    #[test]
    fn values_a_run_cannot_hold_are_refused_despite_a_valid_checksum() {
        type Damage = Box<dyn Fn(&mut Checkpoint)>;
        let cases: Vec<(Damage, &str)> = vec![
            (Box::new(|c| c.best[0] = f32::INFINITY), "best[0] is inf"),
            (Box::new(|c| c.best[1] = f32::NAN), "best[1] is NaN"),
            (Box::new(|c| c.population[4] = f32::NEG_INFINITY), "population[4]"),
            (Box::new(|c| c.scores[1].sum_sq = f64::NAN), "scores[1].sum_sq"),
            (
                Box::new(|c| c.best_score.sum_sq = f64::NEG_INFINITY),
                "best_score.sum_sq",
            ),
            (Box::new(|c| c.params[1][0] = f64::NAN), "params[1][0]"),
            (Box::new(|c| c.seconds = f64::INFINITY), "seconds"),
            (Box::new(|c| c.stall_since = 51), "stall_since"),
            (Box::new(|c| c.history[0].best = f64::NAN), "history[0].best"),
            (Box::new(|c| c.history.clear()), "0 lines for generation 50"),
            (Box::new(|c| c.history.truncate(50)), "50 lines for generation 50"),
            (
                Box::new(|c| c.generation = u64::MAX),
                "for generation 18446744073709551615",
            ),
            (
                Box::new(|c| c.history[3].generation = 4),
                "history[3] is of generation 4",
            ),
        ];
        for (edit, want) in cases {
            let mut c = sample(Method::Ga);
            edit(&mut c);
            let e = Checkpoint::from_bytes(&c.to_bytes()).unwrap_err();
            assert!(e.contains(want), "{want}: {e}");
        }
        let mut c = sample(Method::Cmaes);
        c.cmaes.as_mut().unwrap().sigma = 0.0;
        let e = Checkpoint::from_bytes(&c.to_bytes()).unwrap_err();
        assert!(e.contains("cmaes.sigma"), "{e}");
        let mut c = sample(Method::Cmaes);
        c.cmaes.as_mut().unwrap().cov[3] = f64::INFINITY;
        let e = Checkpoint::from_bytes(&c.to_bytes()).unwrap_err();
        assert!(e.contains("cmaes.cov[3]"), "{e}");
        let mut c = sample(Method::Cmaes);
        c.cmaes.as_mut().unwrap().initial_sigma = -1.0;
        let e = Checkpoint::from_bytes(&c.to_bytes()).unwrap_err();
        assert!(e.contains("cmaes.initial_sigma"), "{e}");
        let mut c = sample(Method::Cmaes);
        c.cmaes.as_mut().unwrap().kept_sum_sq = f64::NAN;
        let e = Checkpoint::from_bytes(&c.to_bytes()).unwrap_err();
        assert!(e.contains("cmaes.kept_sum_sq"), "{e}");
    }

    #[test]
    fn individuals_outside_the_bounds_are_refused() {
        let c = sample(Method::Ga);
        // best = [0.25, -0.125]; population rows [1, 2], [-0, tiny], [3.5, 1e-30].
        assert!(c.check_bounds(&[[-1.0, 4.0], [-1.0, 2.0]]).is_ok());
        let e = c.check_bounds(&[[-1.0, 3.0], [-1.0, 2.0]]).unwrap_err();
        assert!(e.contains("population row 2"), "{e}");
        let e = c.check_bounds(&[[0.5, 4.0], [-1.0, 2.0]]).unwrap_err();
        assert!(e.contains("the best individual"), "{e}");
        assert!(c.check_bounds(&[[0.0, 1.0]]).is_err());
    }

    #[test]
    fn files_are_written_atomically_and_read_back() {
        let dir = std::env::temp_dir().join(format!("bezchain-ckpt-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("run.ckpt");
        let c = sample(Method::Cmaes);
        c.write(&path).unwrap();
        assert_eq!(Checkpoint::read(&path).unwrap(), c);
        // Nothing but the checkpoint is left beside it.
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);
        std::fs::write(&path, b"garbage").unwrap();
        let e = Checkpoint::read(&path).unwrap_err();
        assert!(
            matches!(e, Error::Input { .. }) && e.to_string().contains("run.ckpt"),
            "{e}"
        );
        assert!(matches!(
            Checkpoint::read(&dir.join("missing")),
            Err(Error::Input { .. })
        ));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
