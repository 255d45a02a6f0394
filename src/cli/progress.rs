//! Progress of a run that counts its steps (generations of `fit`, `fit-surface` and `compare`
//! with an evolutionary method and of `optimise`; the families of `adapt-surface`): a bar on a
//! terminal, a line every few seconds when the standard error is a file or a pipe (CI logs),
//! nothing with `--quiet`.

use bezchain::export::summary;
use indicatif::{ProgressBar, ProgressStyle};
use std::io::IsTerminal;
use std::time::{Duration, Instant};

/// Seconds between plain progress lines.
const LINE_EVERY: Duration = Duration::from_secs(5);

/// The step counter on the terminal (generations unless said).
pub struct Generations {
    bar: Option<ProgressBar>,
    quiet: bool,
    plain: bool,
    /// When the current pass began (the counter made, or its count started again), for the
    /// estimate of the time left on plain lines.
    started: Instant,
    last_line: Instant,
    /// The last step shown, its total and when: a count that goes back or a new total is a
    /// new pass (`adapt-surface`'s chord-rule and plain passes, a blade's later searches).
    last: (u64, u64, Instant),
    /// What a step is called on a plain line, and on the bar.
    unit: (&'static str, &'static str),
}

impl Generations {
    /// Under `--quiet`: shows nothing. Otherwise plain lines when standard error is not a
    /// terminal, and a bar (once [`Generations::start`] is called) when it is.
    pub fn new() -> Self {
        Self::counting(("generation", "gen"))
    }

    /// As [`Generations::new`], counting steps called `unit` (a plain line's word, the bar's).
    pub fn counting(unit: (&'static str, &'static str)) -> Self {
        let quiet = super::output::quiet();
        Generations {
            bar: None,
            quiet,
            plain: !quiet && !std::io::stderr().is_terminal(),
            started: Instant::now(),
            last_line: Instant::now(),
            last: (0, 0, Instant::now()),
            unit,
        }
    }

    /// Record step `step` of `total` done at `now`; true when it begins a new pass (the count
    /// went back, or the total changed), which then counts from the step before it, so that
    /// the estimate of the time left is this pass's, not the whole run's. The same step shown
    /// again (a status update between generations) is not a new pass.
    fn record(&mut self, step: u64, total: u64, now: Instant) -> bool {
        let (last_step, last_total, last_at) = self.last;
        let new_pass = last_total != 0 && (step < last_step || total != last_total);
        if new_pass {
            self.started = last_at;
        }
        self.last = (step, total, now);
        new_pass
    }

    /// Whether a bar is showing.
    pub fn started(&self) -> bool {
        self.bar.is_some()
    }

    /// Show the bar of a run called `name`, at generation `at` of `total` (a terminal only).
    pub fn start(&mut self, name: &str, at: u64, total: u64) {
        if self.quiet || self.plain {
            return;
        }
        let bar = ProgressBar::new(total);
        bar.set_style(
            ProgressStyle::with_template(&format!(
                "{{prefix}} [{{elapsed_precise}}] {{bar:30}} {} {{pos}}/{{len}} (about {{eta}} left) {{msg}}",
                self.unit.1
            ))
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
        bar.set_prefix(name.to_string());
        bar.set_position(at);
        bar.enable_steady_tick(Duration::from_millis(250));
        self.bar = Some(bar);
    }

    /// Generation `generation` of `total` of the run `name` is done; `msg` says how it stands.
    pub fn show(&mut self, name: &str, generation: u64, total: u64, msg: String) {
        let new_pass = self.record(generation, total, Instant::now());
        if let Some(bar) = &self.bar {
            if new_pass {
                bar.reset();
            }
            if bar.length() != Some(total) {
                bar.set_length(total);
            }
            bar.set_position(generation);
            bar.set_message(msg);
        } else if self.plain && (self.last_line.elapsed() >= LINE_EVERY || generation == 1) {
            eprintln!(
                "{name} {} {generation}/{total}{}: {msg}",
                self.unit.0,
                summary::time_left(self.started.elapsed(), generation, total)
            );
            self.last_line = Instant::now();
        }
    }

    /// Clear the bar.
    pub fn finish(&mut self) {
        if let Some(bar) = self.bar.take() {
            bar.finish_and_clear();
        }
    }
}

/// A spinner drawn with indicatif's `template`; hidden under `--quiet`, or when `hidden` (a run
/// that shows its progress otherwise).
pub fn spinner(template: &str, hidden: bool) -> ProgressBar {
    let bar = if hidden || super::output::quiet() {
        ProgressBar::hidden()
    } else {
        ProgressBar::new_spinner()
    };
    bar.set_style(
        ProgressStyle::with_template(template).unwrap_or_else(|_| ProgressStyle::default_spinner()),
    );
    bar
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_count_that_starts_again_is_timed_from_its_own_start() {
        let mut g = Generations::counting(("family", "family"));
        let t0 = Instant::now();
        let at = |s: u64| t0 + Duration::from_secs(s);
        // The chord-rule pass: 3 families, one a second.
        assert!(!g.record(1, 3, at(1)));
        assert!(!g.record(2, 3, at(2)));
        assert!(!g.record(3, 3, at(3)));
        // The plain pass begins: its first family ended at 13 s, timed from 3 s.
        assert!(g.record(1, 40, at(13)));
        assert_eq!(g.started, at(3));
        assert!(!g.record(2, 40, at(14)));
        assert_eq!(g.started, at(3));
        // The same step again is a status update, not a new pass.
        assert!(!g.record(2, 40, at(15)));
        assert_eq!(g.started, at(3));
        // A later search of the same passes counts again from 1.
        assert!(g.record(1, 40, at(20)));
        assert_eq!(g.started, at(15));
    }
}
