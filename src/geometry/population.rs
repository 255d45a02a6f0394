//! Population files: one individual per line, its design variables as numbers (the door for
//! optimisers outside bezchain, `bezchain eval`), read with the shared reader machinery.

use super::io::{self, BadNumber};
use crate::error::{Error, Result};
use std::path::Path;

/// Read a population file: one individual per line, `n_vars` numbers each (the design points
/// flattened `x0,y0,x1,y1,…`), separated as in every reader (blanks, or one comma or semicolon).
/// Blank lines and `#` comments are skipped, and so is a first line that is not numeric (a
/// header). Every value must be finite and fit in an f32. The rows are kept in f64: the
/// population evaluator rounds only their differences from its f64 reference design, so
/// designs far from the origin keep their resolution.
pub fn read_population(path: &Path, n_vars: usize) -> Result<Vec<f64>> {
    parse_population(&io::read_text(path)?, path, n_vars)
}

/// [`read_population`] on text in memory; `path` names the source in errors.
pub fn parse_population(text: &str, path: &Path, n_vars: usize) -> Result<Vec<f64>> {
    let parse_error = |line: usize, message: String| Error::Parse {
        path: path.to_path_buf(),
        line,
        message,
    };
    let mut out = Vec::new();
    let mut seen_row = false;
    let mut fields = Vec::new();
    for (number, line) in io::numbered_lines(text) {
        let line = io::strip_comment(line);
        if line.trim().is_empty() {
            continue;
        }
        io::split_fields(line, &mut fields).map_err(|e| parse_error(number, e))?;
        let values: std::result::Result<Vec<f64>, BadNumber> =
            fields.iter().map(|f| io::parse_number(f)).collect();
        let values = match values {
            Ok(v) => v,
            // A header line before the first individual.
            Err(BadNumber::NotNumeric)
                if !seen_row && fields.iter().any(|f| f.chars().any(char::is_alphabetic)) =>
            {
                continue
            }
            Err(BadNumber::NotNumeric) => {
                return Err(parse_error(
                    number,
                    format!("not a row of numbers: '{}'", io::excerpt(line)),
                ))
            }
            Err(BadNumber::NotFinite) => {
                return Err(parse_error(
                    number,
                    format!("a value is not a finite number: '{}'", io::excerpt(line)),
                ))
            }
        };
        seen_row = true;
        if values.len() != n_vars {
            return Err(parse_error(
                number,
                format!(
                    "{} values, the layout has {n_vars} design variables",
                    values.len()
                ),
            ));
        }
        if let Some(bad) = values.iter().find(|v| v.abs() > f64::from(f32::MAX)) {
            return Err(parse_error(number, format!("{bad} is not a finite f32 number")));
        }
        out.extend_from_slice(&values);
    }
    if out.is_empty() {
        return Err(Error::Input {
            path: path.to_path_buf(),
            message: "no individuals (one row of design variables per individual expected)".into(),
        });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    #[test]
    fn rows_headers_and_errors() {
        let p = Path::new("pop.csv");
        let v = parse_population("x0,y0,x1,y1\n1,2,3,4\n\n# comment\n5 6 7 8\n", p, 4).unwrap();
        assert_eq!(v, vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0]);
        let e = parse_population("1,2,3,4\n1,2,3\n", p, 4)
            .unwrap_err()
            .to_string();
        assert!(e.contains("pop.csv:2") && e.contains("3 values"), "{e}");
        let e = parse_population("1,2,3,4\n1,2,x,4\n", p, 4)
            .unwrap_err()
            .to_string();
        assert!(e.contains("pop.csv:2"), "{e}");
        let e = parse_population("1,2,NaN,4\n", p, 4).unwrap_err().to_string();
        assert!(e.contains("pop.csv:1"), "{e}");
        let e = parse_population("1,2,1e300,4\n", p, 4).unwrap_err().to_string();
        assert!(e.contains("pop.csv:1"), "{e}");
        let e = parse_population("1,,2,4\n", p, 4).unwrap_err().to_string();
        assert!(e.contains("pop.csv:1") && e.contains("empty field"), "{e}");
        assert!(matches!(
            parse_population("# nothing\n", p, 4),
            Err(Error::Input { .. })
        ));
    }
}
