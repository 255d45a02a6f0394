//! Aerofoil `.dat` files: the Lednicer counts line and its reordering into Selig order, and
//! the Selig writer.

use super::io;
use super::points::{check_finite, reads_as_name};
use crate::error::{Error, Result};
use glam::DVec2;
use std::io::Write;
use std::path::Path;

/// Decimal places of the Selig writer: a round trip is exact to 5e-13 in model units, and
/// the last digit is far enough from f64 noise that regenerated files compare equal.
pub const SELIG_DECIMALS: usize = 12;

/// The Lednicer point counts line (`61. 61.`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct LednicerCounts {
    /// Points on the upper surface.
    pub upper: usize,
    /// Points on the lower surface.
    pub lower: usize,
    /// 1-based line of the counts in the file.
    pub line: usize,
}

impl LednicerCounts {
    /// Counts if `fields` are exactly two whole numbers of at least 2 (no aerofoil coordinate
    /// row in chord fractions looks like that).
    pub fn detect(fields: &[&str]) -> Option<LednicerCounts> {
        let count = |f: &str| {
            let v = io::parse_number(f).ok()?;
            (v.fract() == 0.0 && (2.0..=1e9).contains(&v)).then_some(v as usize)
        };
        match fields {
            [u, l] => Some(LednicerCounts {
                upper: count(u)?,
                lower: count(l)?,
                line: 0,
            }),
            _ => None,
        }
    }

    /// The same counts, found at `line`.
    pub fn at_line(self, line: usize) -> LednicerCounts {
        LednicerCounts { line, ..self }
    }

    /// Check the counts against the `rows` that followed and the row counts before each blank
    /// line between rows (`blocks`).
    pub fn check(&self, rows: usize, blocks: &[usize]) -> std::result::Result<(), String> {
        let total = self.upper + self.lower;
        if rows != total {
            return Err(format!(
                "the Lednicer counts line says {} upper + {} lower = {total} points, but {rows} rows follow",
                self.upper, self.lower
            ));
        }
        match blocks {
            [split] if *split != self.upper => Err(format!(
                "the Lednicer counts line says {} upper-surface points, but the blank line comes after {split} rows",
                self.upper
            )),
            _ => Ok(()),
        }
    }
}

/// Reorder Lednicer rows (upper LE → TE, then lower LE → TE; `upper` rows in the first part)
/// into Selig order (upper TE → LE → lower TE), merging the shared leading-edge point.
/// `values` holds two coordinates per row; `lines` the file line of each row.
pub(crate) fn lednicer_to_selig(values: &[f64], lines: &[usize], upper: usize) -> (Vec<f64>, Vec<usize>) {
    let n = lines.len();
    debug_assert!(
        upper <= n && values.len() == 2 * n,
        "counts were checked against the rows"
    );
    let row = |k: usize| [values[2 * k], values[2 * k + 1]];
    let shared_le = upper > 0 && upper < n && row(0) == row(upper);
    let lower_start = if shared_le { upper + 1 } else { upper };
    let order: Vec<usize> = (0..upper).rev().chain(lower_start..n).collect();
    let out_values = order.iter().flat_map(|&k| row(k)).collect();
    let out_lines = order.iter().map(|&k| lines[k]).collect();
    (out_values, out_lines)
}

/// Write a Selig `.dat` file atomically: a name line, then one `x y` row per point with
/// [`SELIG_DECIMALS`] decimals.
pub fn write_selig(path: &Path, name: &str, points: &[DVec2]) -> Result<()> {
    check_finite(points)?;
    if points.len() < 2 {
        return Err(Error::invalid(format!(
            "{}: a Selig file needs at least 2 points (got {})",
            path.display(),
            points.len()
        )));
    }
    io::write_atomic(path, |w| write_selig_to(w, name, points))
}

/// Write Selig text to any writer (see [`write_selig`]). A name that a reader would take for
/// data, a header or a comment is prefixed with `aerofoil: ` so the file reads back the same.
pub fn write_selig_to<W: Write + ?Sized>(w: &mut W, name: &str, points: &[DVec2]) -> std::io::Result<()> {
    writeln!(w, "{}", selig_name(name))?;
    let d = SELIG_DECIMALS;
    // Values that round to zero are written as 0, never as -0.
    let tidy = |v: f64| {
        if v.abs() < 0.5 * 10f64.powi(-(d as i32)) {
            0.0
        } else {
            v
        }
    };
    for p in points {
        writeln!(w, "{:>w$.d$} {:>w$.d$}", tidy(p.x), tidy(p.y), w = d + 4)?;
    }
    Ok(())
}

/// The name line written for `name`: one line, and one a reader takes for a name.
fn selig_name(name: &str) -> String {
    let one_line = name.replace(['\n', '\r'], " ");
    let trimmed = one_line.trim();
    if reads_as_name(trimmed) {
        trimmed.to_string()
    } else {
        format!("aerofoil: {trimmed}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::points::{parse_curve, Format};

    fn selig_text(name: &str, points: &[DVec2]) -> String {
        let mut buf = Vec::new();
        write_selig_to(&mut buf, name, points).unwrap();
        String::from_utf8(buf).unwrap()
    }

    #[test]
    fn selig_round_trip_is_exact_to_1e12() {
        let pts: Vec<DVec2> = (0..50)
            .map(|i| {
                let t = i as f64 / 49.0 * std::f64::consts::TAU;
                DVec2::new(0.5 + 0.5 * t.cos(), 0.1 * t.sin() - 1e-15)
            })
            .collect();
        let text = selig_text("ROUND TRIP", &pts);
        let back = parse_curve(&text, Path::new("r.dat")).unwrap();
        assert_eq!(back.name, "ROUND TRIP");
        assert_eq!(back.format, Format::Selig);
        assert_eq!(back.points.len(), pts.len());
        for (a, b) in pts.iter().zip(&back.points) {
            assert!((*a - *b).abs().max_element() <= 5e-13, "{a} {b}");
        }
        assert!(!text.contains("-0.000000000000"));
    }

    #[test]
    fn names_that_would_not_read_back_are_protected() {
        let pts = [DVec2::new(1.0, 0.0), DVec2::new(0.0, 0.0)];
        for name in ["4413", "x y", "# comment", "", "1 2", "a\nb"] {
            let back = parse_curve(&selig_text(name, &pts), Path::new("n.dat")).unwrap();
            assert_eq!(back.points.len(), 2, "{name:?}");
            assert!(
                back.name.contains(name.replace('\n', " ").trim()),
                "{name:?} -> {}",
                back.name
            );
        }
    }

    #[test]
    fn lednicer_rows_become_selig_with_one_leading_edge() {
        // upper: (0,0) (0.5,0.1) (1,0); lower: (0,0) (0.5,-0.1) (1,0)
        let v = [0.0, 0.0, 0.5, 0.1, 1.0, 0.0, 0.0, 0.0, 0.5, -0.1, 1.0, 0.0];
        let (out, lines) = lednicer_to_selig(&v, &[3, 4, 5, 7, 8, 9], 3);
        assert_eq!(out, vec![1.0, 0.0, 0.5, 0.1, 0.0, 0.0, 0.5, -0.1, 1.0, 0.0]);
        assert_eq!(lines, vec![5, 4, 3, 8, 9]);
    }

    #[test]
    fn counts_line_detection() {
        assert!(LednicerCounts::detect(&["61.", "61."]).is_some());
        assert!(LednicerCounts::detect(&["61.0", "35"]).is_some());
        assert!(LednicerCounts::detect(&["1.000000", "0.000599"]).is_none());
        assert!(LednicerCounts::detect(&["61", "61", "1"]).is_none());
        assert!(LednicerCounts::detect(&["1e300", "5"]).is_none());
    }
}
