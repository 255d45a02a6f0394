//! The Selig `.dat` writer: a name line that reads back as a name, then `x y` rows.

use super::io;
use super::points::{check_finite, reads_as_name};
use crate::error::{Error, Result};
use glam::DVec2;
use std::io::Write;
use std::path::Path;

/// Decimal places of the Selig writer: a round trip is exact to 5e-13 in model units, and
/// the last digit is far enough from f64 noise that regenerated files compare equal.
pub const SELIG_DECIMALS: usize = 12;

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
    fn names_written_by_the_selig_writer_read_back_as_names() {
        for name in [
            "NACA 4413",
            "x,y",
            "station,point",
            "S1223 (Selig, high lift)",
            "x y",
        ] {
            let header_like = !reads_as_name(name);
            let mut buf = Vec::new();
            write_selig_to(&mut buf, name, &[DVec2::X, DVec2::ZERO]).unwrap();
            let back = parse_curve(std::str::from_utf8(&buf).unwrap(), Path::new("t.csv")).unwrap();
            assert_eq!(back.format, Format::Selig, "{name}");
            assert_eq!(back.name.starts_with("aerofoil: "), header_like, "{name}");
        }
    }
}
