//! Point files in every supported layout (Selig and Lednicer `.dat`, CSV, XYZ), detected by
//! content and validated, plus the CSV writers for curves and clouds.

use super::dat;
use super::io::{self, BadNumber};
use crate::bezier::Vector;
use crate::error::{Error, Result};
use glam::{DVec2, DVec3};
use std::io::Write;
use std::path::Path;

/// How many dropped-duplicate line numbers a warning lists before it summarises.
const LISTED_LINES: usize = 10;

/// The layout a point file was recognised as.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// A name line, then `x y` rows in contour order (upper TE → LE → lower TE for aerofoils).
    Selig,
    /// A name line, a line of two point counts, then the upper and lower surfaces LE → TE.
    Lednicer,
    /// Rows of numbers under a header naming the columns, or separated by commas/semicolons.
    Csv,
    /// Rows of blank-separated numbers with no header (an optional name line for 3D rows).
    Xyz,
}

/// The structure of an ordered cloud: `sections` cross-sections of `per_section` points each,
/// stored section-major (point `s * per_section + i` is point `i` of section `s`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Grid {
    /// Number of sections (spanwise stations).
    pub sections: usize,
    /// Points in every section.
    pub per_section: usize,
}

/// A 3D point cloud, optionally ordered as a grid of sections.
#[derive(Clone, Debug, PartialEq)]
pub struct Cloud {
    /// The points, section-major when `grid` is set.
    pub points: Vec<DVec3>,
    /// The section structure, `None` for an unordered cloud.
    pub grid: Option<Grid>,
}

/// A validated point file: its points in file order (Selig order for aerofoils).
#[derive(Clone, Debug, PartialEq)]
pub struct Loaded<P> {
    /// The name line of a `.dat` file, otherwise the file stem.
    pub name: String,
    /// The points, at least two, all finite, no two consecutive ones equal (except in a grid).
    pub points: Vec<P>,
    /// The layout the file was recognised as.
    pub format: Format,
    /// Things that were repaired while reading (dropped duplicates, ignored columns), for the
    /// caller to show: the library never prints.
    pub warnings: Vec<String>,
    /// For clouds with `section,index` columns that form a complete section-major grid.
    pub grid: Option<Grid>,
}

/// A 2D curve file (aerofoil contour).
pub type Loaded2 = Loaded<DVec2>;
/// A 3D point-cloud file.
pub type Loaded3 = Loaded<DVec3>;

impl Loaded3 {
    /// The points and grid as a [`Cloud`].
    #[must_use]
    pub fn into_cloud(self) -> Cloud {
        Cloud {
            points: self.points,
            grid: self.grid,
        }
    }
}

/// A point file whose dimension was detected from its rows.
#[derive(Clone, Debug, PartialEq)]
pub enum LoadedPoints {
    /// Two coordinates per row.
    Curve(Loaded2),
    /// Three coordinates per row.
    Cloud(Loaded3),
}

/// Read a 2D curve: Selig or Lednicer `.dat`, or CSV/XYZ rows of `x y` (detected by content).
pub fn read_curve(path: &Path) -> Result<Loaded2> {
    parse_curve(&io::read_text(path)?, path)
}

/// Read a 3D cloud: CSV/XYZ rows of `x y z`, or a header naming `x`, `y`, `z` (and optionally
/// `section`, `index`) in any order.
pub fn read_cloud(path: &Path) -> Result<Loaded3> {
    parse_cloud(&io::read_text(path)?, path)
}

/// Read a point file of either dimension, decided by its rows or header.
pub fn read_points(path: &Path) -> Result<LoadedPoints> {
    parse_points(&io::read_text(path)?, path)
}

/// [`read_curve`] on text already in memory; `path` only names the source in errors.
pub fn parse_curve(text: &str, path: &Path) -> Result<Loaded2> {
    let t = Table::parse(text, path, Want::Two)?;
    t.finish(path, |c| DVec2::new(c[0], c[1]))
}

/// [`read_cloud`] on text already in memory; `path` only names the source in errors.
pub fn parse_cloud(text: &str, path: &Path) -> Result<Loaded3> {
    let t = Table::parse(text, path, Want::Three)?;
    t.finish(path, |c| DVec3::new(c[0], c[1], c[2]))
}

/// [`read_points`] on text already in memory; `path` only names the source in errors.
pub fn parse_points(text: &str, path: &Path) -> Result<LoadedPoints> {
    let t = Table::parse(text, path, Want::Any)?;
    Ok(if t.dims == 2 {
        LoadedPoints::Curve(t.finish(path, |c| DVec2::new(c[0], c[1]))?)
    } else {
        LoadedPoints::Cloud(t.finish(path, |c| DVec3::new(c[0], c[1], c[2]))?)
    })
}

/// Write a 2D curve as CSV with an `x,y` header, coordinates in shortest round-trip form.
pub fn write_curve_csv(path: &Path, points: &[DVec2]) -> Result<()> {
    check_finite(points)?;
    io::write_atomic(path, |w| write_csv_to(w, points, None))
}

/// Write a cloud as CSV: header `x,y,z`, plus `section,index` columns when it is ordered.
/// Coordinates are written in shortest round-trip form, so reading them back is exact.
pub fn write_cloud_csv(path: &Path, cloud: &Cloud) -> Result<()> {
    check_finite(&cloud.points)?;
    check_grid(cloud)?;
    io::write_atomic(path, |w| write_csv_to(w, &cloud.points, cloud.grid))
}

/// Write points as CSV to any writer: a header naming the columns, then one row per point
/// (`section,index` appended when `grid` is given; the caller checks it fits the points).
pub fn write_csv_to<W: Write, P: Vector>(w: &mut W, points: &[P], grid: Option<Grid>) -> std::io::Result<()> {
    const NAMES: [&str; 3] = ["x", "y", "z"];
    let header = NAMES[..P::DIM].join(",");
    match grid {
        Some(_) => writeln!(w, "{header},section,index")?,
        None => writeln!(w, "{header}")?,
    }
    let per = grid.map_or(1, |g| g.per_section.max(1));
    let mut row = String::with_capacity(96);
    for (k, p) in points.iter().enumerate() {
        row.clear();
        for i in 0..P::DIM {
            if i > 0 {
                row.push(',');
            }
            push_f64(&mut row, p.coord(i));
        }
        if grid.is_some() {
            use std::fmt::Write as _;
            let _ = write!(row, ",{},{}", k / per, k % per);
        }
        row.push('\n');
        w.write_all(row.as_bytes())?;
    }
    Ok(())
}

/// Append `v` in shortest round-trip decimal form (negative zero written as `0`).
fn push_f64(out: &mut String, v: f64) {
    use std::fmt::Write as _;
    let v = if v == 0.0 { 0.0 } else { v };
    let _ = write!(out, "{v}");
}

/// An error unless every coordinate is finite (a writer must not produce unreadable files).
pub(crate) fn check_finite<P: Vector>(points: &[P]) -> Result<()> {
    match points.iter().position(|p| !p.is_finite_point()) {
        Some(i) => Err(Error::invalid(format!(
            "point {i} is not finite ({:?}); refusing to write it",
            points[i]
        ))),
        None => Ok(()),
    }
}

/// An error unless the cloud's grid, when present, covers exactly its points.
fn check_grid(cloud: &Cloud) -> Result<()> {
    match cloud.grid {
        Some(g) if g.sections.checked_mul(g.per_section) != Some(cloud.points.len()) => {
            Err(Error::invalid(format!(
                "cloud grid {} x {} does not match its {} points",
                g.sections,
                g.per_section,
                cloud.points.len()
            )))
        }
        _ => Ok(()),
    }
}

/// Which dimension the caller needs.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Want {
    Two,
    Three,
    Any,
}

/// Column positions named by a header line.
#[derive(Clone, Debug)]
struct Header {
    /// Number of fields every data row must have.
    fields: usize,
    /// Positions of x, y and (if present) z.
    coords: Vec<usize>,
    /// Positions of `section` and `index` when both are present.
    grid: Option<(usize, usize)>,
    /// Names of the columns that are ignored.
    ignored: Vec<String>,
}

impl Header {
    /// A header if every field is a column name (letters, digits, `_-.()[]/`, optionally
    /// quoted; not a number) and both `x` and `y` are among them.
    fn detect(fields: &[&str]) -> Option<Header> {
        let names: Vec<String> = fields
            .iter()
            .map(|f| f.trim_matches(|c| c == '"' || c == '\'').to_ascii_lowercase())
            .collect();
        let column_name = |n: &String| {
            io::parse_number(n) == Err(BadNumber::NotNumeric)
                && n.chars()
                    .all(|c| c.is_ascii_alphanumeric() || "_-.()[]/".contains(c))
        };
        if !names.iter().all(column_name) {
            return None;
        }
        let find = |n: &str| names.iter().position(|x| x == n);
        let (x, y) = (find("x")?, find("y")?);
        let mut coords = vec![x, y];
        if let Some(z) = find("z") {
            coords.push(z);
        }
        let grid = find("section").zip(find("index"));
        let used = |i: usize| coords.contains(&i) || grid.is_some_and(|(s, k)| s == i || k == i);
        let ignored = (0..names.len())
            .filter(|&i| !used(i))
            .map(|i| names[i].clone())
            .collect();
        Some(Header {
            fields: fields.len(),
            coords,
            grid,
            ignored,
        })
    }
}

/// True when a reader takes `line`, as the first line of a file, for a name line (not a
/// comment, a header or a data row).
pub(crate) fn reads_as_name(line: &str) -> bool {
    let content = io::strip_comment(line);
    if content.trim().is_empty() {
        return false;
    }
    let mut fields = Vec::new();
    match io::split_fields(content, &mut fields) {
        Err(_) => true,
        Ok(_) => {
            !fields
                .iter()
                .all(|f| io::parse_number(f) != Err(BadNumber::NotNumeric))
                && Header::detect(&fields).is_none()
        }
    }
}

/// The numeric content of a point file before it becomes points.
struct Table {
    name: Option<String>,
    format: Format,
    /// Coordinates per point (2 or 3).
    dims: usize,
    /// Coordinates, `dims` per row.
    values: Vec<f64>,
    /// 1-based file line of every row.
    lines: Vec<usize>,
    /// `section, index` of every row when the header names them.
    grid_cols: Option<Vec<(f64, f64)>>,
    warnings: Vec<String>,
}

/// Where the reader is in the file.
enum State {
    /// Nothing but blank lines and comments so far.
    Start,
    /// After a name line: a Lednicer counts line or the first row may follow.
    AfterName,
    /// Reading data rows.
    Rows,
}

impl Table {
    /// Classify and read every line of `text`.
    fn parse(text: &str, path: &Path, want: Want) -> Result<Table> {
        let perr = |line: usize, message: String| Error::Parse {
            path: path.to_path_buf(),
            line,
            message,
        };
        let mut t = Table {
            name: None,
            format: Format::Xyz,
            dims: 0,
            values: Vec::new(),
            lines: Vec::new(),
            grid_cols: None,
            warnings: Vec::new(),
        };
        let mut state = State::Start;
        let mut header: Option<Header> = None;
        // Raw fields per row when there is no header (fixed by the first row).
        let mut row_fields = 0;
        let mut counts: Option<dat::LednicerCounts> = None;
        // Lednicer: rows before each blank line that follows some rows.
        let mut blocks: Vec<usize> = Vec::new();
        let mut fields: Vec<&str> = Vec::with_capacity(8);
        let mut vals: Vec<f64> = Vec::with_capacity(8);
        for (no, raw) in io::numbered_lines(text) {
            let content = io::strip_comment(raw);
            if content.trim().is_empty() {
                if counts.is_some() && blocks.last() != Some(&t.lines.len()) && !t.lines.is_empty() {
                    blocks.push(t.lines.len());
                }
                continue;
            }
            let split = io::split_fields(content, &mut fields);
            let numeric_looking = || {
                content
                    .split([' ', '\t', ',', ';'])
                    .filter(|f| !f.is_empty())
                    .all(|f| io::parse_number(f) != Err(BadNumber::NotNumeric))
            };
            if matches!(state, State::Start) && split.is_err() && !numeric_looking() {
                // Only a name line can be this irregular.
                t.name = Some(raw.trim().to_string());
                state = State::AfterName;
                continue;
            }
            let hard = split.map_err(|m| perr(no, m))?;
            match state {
                State::Start => {
                    if fields
                        .iter()
                        .all(|f| io::parse_number(f) != Err(BadNumber::NotNumeric))
                    {
                        t.format = if hard { Format::Csv } else { Format::Xyz };
                        state = State::Rows;
                    } else if let Some(h) = Header::detect(&fields) {
                        t.dims = match (want, h.coords.len()) {
                            (Want::Two, 3) => {
                                return Err(perr(
                                    no,
                                    "the header names a z column: this is a 3D cloud, not a 2D curve".into(),
                                ))
                            }
                            (Want::Three, 2) => {
                                return Err(perr(
                                    no,
                                    "the header names no z column: this is a 2D curve, not a 3D cloud".into(),
                                ))
                            }
                            (_, n) => n,
                        };
                        if !h.ignored.is_empty() {
                            t.warnings.push(format!(
                                "ignored column(s) {} of the header",
                                h.ignored.join(", ")
                            ));
                        }
                        if h.grid.is_some() {
                            t.grid_cols = Some(Vec::new());
                        }
                        t.format = Format::Csv;
                        header = Some(h);
                        state = State::Rows;
                        continue;
                    } else {
                        t.name = Some(raw.trim().to_string());
                        state = State::AfterName;
                        continue;
                    }
                }
                State::AfterName => {
                    if let Some(c) = dat::LednicerCounts::detect(&fields) {
                        if want == Want::Three {
                            return Err(perr(
                                no,
                                "a Lednicer counts line: this is a 2D aerofoil, not a 3D cloud".into(),
                            ));
                        }
                        counts = Some(c.at_line(no));
                        t.format = Format::Lednicer;
                        t.dims = 2;
                        row_fields = 2;
                        state = State::Rows;
                        continue;
                    }
                    t.format = Format::Selig;
                    state = State::Rows;
                }
                State::Rows => {}
            }
            // A data row.
            vals.clear();
            for f in &fields {
                match io::parse_number(f) {
                    Ok(v) => vals.push(v),
                    Err(BadNumber::NotNumeric) => {
                        return Err(perr(
                            no,
                            format!("expected numbers, found '{}'", io::excerpt(content)),
                        ))
                    }
                    Err(BadNumber::NotFinite) => {
                        return Err(perr(no, format!("'{}' is not a finite number", io::excerpt(f))))
                    }
                }
            }
            let expected = header.as_ref().map_or(row_fields, |h| h.fields);
            if expected == 0 {
                // The first row fixes the layout.
                let n = vals.len();
                let ok = match want {
                    Want::Two => n == 2,
                    Want::Three => n == 3,
                    Want::Any => n == 2 || n == 3,
                };
                if !ok {
                    let need = match want {
                        Want::Two => "2 numbers (x y)",
                        Want::Three => "3 numbers (x y z)",
                        Want::Any => "2 or 3 numbers (x y [z])",
                    };
                    return Err(perr(no, format!("expected {need} per row, found {n}")));
                }
                row_fields = n;
                t.dims = n;
                if t.format == Format::Selig && n == 3 {
                    t.format = Format::Xyz;
                }
            } else if vals.len() != expected {
                let what = if header.is_some() {
                    "the header names"
                } else {
                    "the first row has"
                };
                return Err(perr(no, format!("{} fields, but {what} {expected}", vals.len())));
            }
            match &header {
                Some(h) => {
                    t.values.extend(h.coords.iter().map(|&c| vals[c]));
                    if let (Some((s, i)), Some(g)) = (h.grid, t.grid_cols.as_mut()) {
                        g.push((vals[s], vals[i]));
                    }
                }
                None => t.values.extend_from_slice(&vals),
            }
            t.lines.push(no);
        }
        let n = t.lines.len();
        if n == 0 {
            let message = match state {
                State::Start => "empty file: no points".to_string(),
                State::AfterName => "no points after the name line".to_string(),
                State::Rows if header.is_some() => "no data rows after the header".to_string(),
                State::Rows => "no points after the counts line".to_string(),
            };
            return Err(Error::Input {
                path: path.to_path_buf(),
                message,
            });
        }
        if let Some(c) = counts {
            if blocks.last() == Some(&n) {
                blocks.pop();
            }
            c.check(n, &blocks).map_err(|m| perr(c.line, m))?;
            let (values, lines) = dat::lednicer_to_selig(&t.values, &t.lines, c.upper);
            t.values = values;
            t.lines = lines;
        }
        Ok(t)
    }

    /// Build points, the grid and the duplicate warnings.
    fn finish<P: Vector>(mut self, path: &Path, make: impl Fn(&[f64]) -> P) -> Result<Loaded<P>> {
        let dims = self.dims;
        let mut points: Vec<P> = self.values.chunks_exact(dims).map(make).collect();
        let mut dropped = Vec::new();
        let grid = self.grid_cols.take().and_then(|cols| {
            let g = grid_of(&cols);
            if g.is_none() {
                self.warnings.push(
                    "the section/index columns do not form a complete section-major grid; ignored".into(),
                );
            }
            g
        });
        if grid.is_none() {
            let mut keep = 0;
            for k in 0..points.len() {
                if keep > 0 && points[k] == points[keep - 1] {
                    dropped.push(self.lines[k]);
                } else {
                    points[keep] = points[k];
                    keep += 1;
                }
            }
            points.truncate(keep);
            if !dropped.is_empty() {
                let listed: Vec<String> = dropped.iter().take(LISTED_LINES).map(|l| l.to_string()).collect();
                let more = if dropped.len() > LISTED_LINES {
                    format!(" and {} more", dropped.len() - LISTED_LINES)
                } else {
                    String::new()
                };
                self.warnings.push(format!(
                    "dropped {} point(s) equal to the point before them (line {}{more})",
                    dropped.len(),
                    listed.join(", ")
                ));
            }
        }
        if points.len() < 2 {
            let left = if dropped.is_empty() {
                ""
            } else {
                " left after dropping duplicates"
            };
            let s = if points.len() == 1 { "" } else { "s" };
            return Err(Error::Input {
                path: path.to_path_buf(),
                message: format!("only {} point{s}{left}; at least 2 are needed", points.len()),
            });
        }
        let name = self.name.unwrap_or_else(|| {
            path.file_stem()
                .map_or_else(String::new, |s| s.to_string_lossy().into_owned())
        });
        Ok(Loaded {
            name,
            points,
            format: self.format,
            warnings: self.warnings,
            grid,
        })
    }
}

/// The grid described by `(section, index)` pairs, if they enumerate a complete section-major
/// grid `0..sections × 0..per_section` in order.
fn grid_of(cols: &[(f64, f64)]) -> Option<Grid> {
    let per = cols.iter().map(|&(_, i)| i).fold(0.0, f64::max);
    if !(per >= 0.0 && per.fract() == 0.0 && per < cols.len() as f64) {
        return None;
    }
    let per = per as usize + 1;
    if !cols.len().is_multiple_of(per) {
        return None;
    }
    let ok = cols
        .iter()
        .enumerate()
        .all(|(k, &(s, i))| s == (k / per) as f64 && i == (k % per) as f64);
    ok.then_some(Grid {
        sections: cols.len() / per,
        per_section: per,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p() -> &'static Path {
        Path::new("t.csv")
    }

    #[test]
    fn csv_with_header_in_any_order() {
        let l = parse_cloud("# scan\nz;id;x;y\n3;7;1;2\n6;8;4;5 # tail\n", p()).unwrap();
        assert_eq!(
            l.points,
            vec![DVec3::new(1.0, 2.0, 3.0), DVec3::new(4.0, 5.0, 6.0)]
        );
        assert_eq!(l.format, Format::Csv);
        assert_eq!(l.name, "t");
        assert!(l.warnings.iter().any(|w| w.contains("id")), "{:?}", l.warnings);
    }

    #[test]
    fn xyz_rows_without_header() {
        let l = parse_points("0 0\t1\n1 1 1\n", p()).unwrap();
        match l {
            LoadedPoints::Cloud(c) => {
                assert_eq!(c.points.len(), 2);
                assert_eq!(c.format, Format::Xyz);
            }
            LoadedPoints::Curve(_) => panic!("3 columns are a cloud"),
        }
    }

    #[test]
    fn consecutive_duplicates_are_dropped_with_a_warning() {
        let l = parse_curve("a\n1 0\n1 0\n0.5 0.1\n0 0\n0.5 0.1\n0.5 0.1\n1 0\n", p()).unwrap();
        assert_eq!(l.points.len(), 5);
        assert_eq!(l.format, Format::Selig);
        assert_eq!(l.warnings.len(), 1);
        assert!(l.warnings[0].contains("line 3, 7"), "{}", l.warnings[0]);
    }

    #[test]
    fn grid_columns_round_trip() {
        let cloud = Cloud {
            points: (0..6)
                .map(|k| DVec3::new(k as f64 * 0.1, -1.0 / 3.0, 0.0))
                .collect(),
            grid: Some(Grid {
                sections: 2,
                per_section: 3,
            }),
        };
        let mut buf = Vec::new();
        write_csv_to(&mut buf, &cloud.points, cloud.grid).unwrap();
        let text = String::from_utf8(buf).unwrap();
        assert!(text.starts_with("x,y,z,section,index\n0,"), "{text}");
        let back = parse_cloud(&text, p()).unwrap();
        assert_eq!(back.points, cloud.points);
        assert_eq!(back.grid, cloud.grid);
        assert!(back.warnings.is_empty());
    }

    #[test]
    fn broken_grid_columns_are_ignored_with_a_warning() {
        let l = parse_cloud("x,y,z,section,index\n0,0,0,0,1\n1,0,0,0,0\n", p()).unwrap();
        assert_eq!(l.grid, None);
        assert_eq!(l.warnings.len(), 1);
    }

    #[test]
    fn writers_refuse_non_finite_points() {
        let dir = std::env::temp_dir();
        let bad = [DVec2::new(0.0, f64::NAN), DVec2::ONE];
        assert!(write_curve_csv(&dir.join("never-written.csv"), &bad).is_err());
        let cloud = Cloud {
            points: vec![DVec3::ZERO; 5],
            grid: Some(Grid {
                sections: 2,
                per_section: 3,
            }),
        };
        assert!(write_cloud_csv(&dir.join("never-written.csv"), &cloud).is_err());
    }
}
