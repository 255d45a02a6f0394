//! Lednicer-ordered aerofoil files: the point counts line (`61. 61.`) and the reordering of
//! their two surfaces (both from the leading edge) into Selig order.

use super::io;

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

#[cfg(test)]
mod tests {
    use super::*;

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
