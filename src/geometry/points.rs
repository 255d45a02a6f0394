//! Point files in every supported layout (Selig and Lednicer `.dat`, CSV, XYZ), detected by
//! content and validated, plus the CSV writers for curves and clouds.

use super::io::{self, BadNumber};
use super::lednicer;
use super::scale::{check_scale, Precision};
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

impl Grid {
    /// The largest distance between two points of one section of `points` (section-major,
    /// this grid's shape): the chord `--relative` patch-grid tolerances are fractions of.
    #[must_use]
    pub fn largest_chord(&self, points: &[DVec3]) -> f64 {
        self.chords(points).into_iter().fold(0.0, f64::max)
    }

    /// Every section's chord, in section order: the largest distance between two of its
    /// points (for an aerofoil section, leading edge to trailing edge). The local chord the
    /// surface pictures relate offsets to, and the largest of them is [`largest_chord`].
    ///
    /// [`largest_chord`]: Self::largest_chord
    #[must_use]
    pub fn chords(&self, points: &[DVec3]) -> Vec<f64> {
        points
            .chunks(self.per_section.max(1))
            .map(|s| {
                s.iter()
                    .flat_map(|a| s.iter().map(move |b| (*a - *b).length()))
                    .fold(0.0, f64::max)
            })
            .collect()
    }
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
    /// For clouds whose header names a `section` (or `station`) column in which every section
    /// has the same number of points (ordered by an `index` or `point` column, else by file
    /// order) and no index repeats within a section; the points are then section-major.
    pub grid: Option<Grid>,
}

/// A 2D curve file (aerofoil contour).
pub type Loaded2 = Loaded<DVec2>;
/// A 3D point-cloud file.
pub type Loaded3 = Loaded<DVec3>;

impl Loaded2 {
    /// The largest side of the points' bounding box: the size `--relative` curve tolerances
    /// are fractions of.
    #[must_use]
    pub fn extent(&self) -> f64 {
        let (lo, hi) = self.points.iter().fold(
            (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY)),
            |(lo, hi), &p| (lo.min(p), hi.max(p)),
        );
        (hi - lo).max_element()
    }
}

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

/// Read a 2D curve: Selig or Lednicer `.dat`, or CSV/XYZ rows of `x y` (detected by content),
/// or CSV under a header naming `x` and `y` (and optionally `index` or `point`, which orders
/// the points) case-insensitively in any order, other columns (text too) ignored.
pub fn read_curve(path: &Path) -> Result<Loaded2> {
    parse_curve(&io::read_text(path)?, path)
}

/// Read a 3D cloud: CSV/XYZ rows of `x y z`, or a header naming `x`, `y`, `z` (and optionally
/// `section` or `station`, `index` or `point`) case-insensitively in any order, other columns
/// (text too) ignored.
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
pub fn write_csv_to<W: Write + ?Sized, P: Vector>(
    w: &mut W,
    points: &[P],
    grid: Option<Grid>,
) -> std::io::Result<()> {
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
    /// A delimited header (fields separated by `,` or `;`): its rows are split on those alone,
    /// so text columns may hold blanks. False for a header separated by blanks.
    delimited: bool,
    /// The column names, lower case.
    names: Vec<String>,
    /// Positions of x, y and (if present) z.
    coords: Vec<usize>,
    /// Position of the section column (`section` or `station`), used for 3D clouds.
    section: Option<usize>,
    /// Position of the order column within a section (`index` or `point`).
    index: Option<usize>,
    /// Names of the columns that are ignored.
    ignored: Vec<String>,
}

/// What the first line of a file is, as far as headers go.
enum FirstLine {
    /// A header naming the x and y columns.
    Header(Header),
    /// A delimited line of column names without an x or a y column: the error message.
    NoCoordinates(String),
    /// Not a header: a name line or data.
    Other,
}

/// A column name without the blanks and quotes around it, in lower case.
fn column_name(field: &str) -> String {
    let f = field.trim();
    let unquoted = ['"', '\'']
        .iter()
        .find_map(|&q| f.strip_prefix(q).and_then(|g| g.strip_suffix(q)))
        .unwrap_or(f);
    unquoted.trim().to_ascii_lowercase()
}

/// True when `line` has a `,` or `;` outside double quotes.
fn is_delimited(line: &str) -> bool {
    let mut quoted = false;
    line.bytes().any(|b| {
        if b == b'"' {
            quoted = !quoted;
        }
        !quoted && (b == b',' || b == b';')
    })
}

/// Split a delimited line on `,` and `;` alone, fields trimmed of blanks. A field that starts
/// with a double quote runs to its closing quote (`""` inside is a quote) and is returned
/// without the quotes, so it may hold separators.
fn split_delimited<'a>(line: &'a str, out: &mut Vec<&'a str>) -> std::result::Result<(), String> {
    out.clear();
    let b = line.as_bytes();
    let blank = |c: u8| c == b' ' || c == b'\t';
    let is_sep = |c: u8| c == b',' || c == b';';
    let trim = |f: &'a str| f.trim_matches(|c| c == ' ' || c == '\t');
    if !b.contains(&b'"') {
        // The common case, a row of numbers: one pass over the bytes.
        let mut start = 0;
        for (i, &c) in b.iter().enumerate() {
            if is_sep(c) {
                out.push(trim(&line[start..i]));
                start = i + 1;
            }
        }
        out.push(trim(&line[start..]));
        return Ok(());
    }
    let mut i = 0;
    loop {
        while i < b.len() && blank(b[i]) {
            i += 1;
        }
        if i < b.len() && b[i] == b'"' {
            let start = i + 1;
            let mut j = start;
            loop {
                match b[j..].iter().position(|&c| c == b'"') {
                    Some(k) if b.get(j + k + 1) == Some(&b'"') => j += k + 2,
                    Some(k) => {
                        j += k;
                        break;
                    }
                    None => return Err(format!("unclosed quote in '{}'", io::excerpt(line))),
                }
            }
            out.push(&line[start..j]);
            i = j + 1;
            while i < b.len() && blank(b[i]) {
                i += 1;
            }
            if i < b.len() && !is_sep(b[i]) {
                return Err(format!("text after a closing quote in '{}'", io::excerpt(line)));
            }
        } else {
            let start = i;
            while i < b.len() && !is_sep(b[i]) {
                i += 1;
            }
            out.push(line[start..i].trim_matches(|c| c == ' ' || c == '\t'));
        }
        if i >= b.len() {
            return Ok(());
        }
        i += 1; // the separator
    }
}

impl Header {
    /// Classify the first line of a file (comment removed). A delimited line (`,` or `;`) of
    /// two or more fields that are not numbers is a header when it names `x` and `y`
    /// (case-insensitive, any order, any other columns); when it names neither and its fields are
    /// single words it is a header without coordinates. A blank-separated line is a header when
    /// every field is a column name (letters, digits, `_-.()[]/`) and two of them are `x` and `y`.
    fn classify(content: &str) -> FirstLine {
        let not_number = |f: &str| io::parse_number(f.trim()) == Err(BadNumber::NotNumeric);
        let mut fields = Vec::new();
        let delimited = is_delimited(content) && split_delimited(content, &mut fields).is_ok();
        if !delimited {
            let plain = |f: &&str| {
                f.chars()
                    .all(|c| c.is_ascii_alphanumeric() || "_-.()[]/".contains(c))
            };
            if io::split_fields(content, &mut fields).is_err()
                || !fields
                    .iter()
                    .all(|f| not_number(&column_name(f)) && plain(&column_name(f).as_str()))
            {
                return FirstLine::Other;
            }
        } else if fields.len() < 2 || !fields.iter().all(|f| !f.trim().is_empty() && not_number(f)) {
            return FirstLine::Other;
        }
        let names: Vec<String> = fields.iter().map(|f| column_name(f)).collect();
        let find = |alias: &[&str]| alias.iter().find_map(|a| names.iter().position(|n| n == a));
        let (Some(x), Some(y)) = (find(&["x"]), find(&["y"])) else {
            let words = fields.iter().all(|f| !f.trim().contains([' ', '\t']));
            return if delimited && words {
                let missing: Vec<&str> = [("x", find(&["x"])), ("y", find(&["y"]))]
                    .iter()
                    .filter(|(_, at)| at.is_none())
                    .map(|(n, _)| *n)
                    .collect();
                FirstLine::NoCoordinates(format!(
                    "the header '{}' names no {} column (columns are found by name, \
                     case-insensitively: x, y, optional z, section or station, index or point)",
                    io::excerpt(content),
                    missing.join(" and no ")
                ))
            } else {
                FirstLine::Other
            };
        };
        let mut coords = vec![x, y];
        if let Some(z) = find(&["z"]) {
            coords.push(z);
        }
        FirstLine::Header(Header {
            fields: names.len(),
            delimited,
            coords,
            section: find(&["section", "station"]),
            index: find(&["index", "point"]),
            ignored: Vec::new(),
            names,
        })
    }

    /// Settle which columns are used for points of `dims` coordinates (the section column only
    /// in 3D) and list the others as ignored.
    fn settle(&mut self, dims: usize) {
        if dims < 3 {
            self.section = None;
        }
        let used = |i: usize| self.coords.contains(&i) || self.section == Some(i) || self.index == Some(i);
        self.ignored = (0..self.names.len())
            .filter(|&i| !used(i))
            .map(|i| self.names[i].clone())
            .collect();
    }

    /// Split one data row into `fields` and read the used ones: the coordinates into `coords`,
    /// and the section and index values.
    fn row<'a>(
        &self,
        content: &'a str,
        fields: &mut Vec<&'a str>,
        coords: &mut Vec<f64>,
    ) -> std::result::Result<(Option<f64>, Option<f64>), String> {
        if self.delimited {
            split_delimited(content, fields)?;
            // A single trailing separator is tolerated.
            if fields.len() == self.fields + 1 && fields.last().is_some_and(|f| f.is_empty()) {
                fields.pop();
            }
        } else {
            io::split_fields(content, fields)?;
        }
        if fields.len() != self.fields {
            let empty = if fields.iter().any(|f| f.is_empty()) {
                format!("empty field in '{}': ", io::excerpt(content))
            } else {
                String::new()
            };
            return Err(format!(
                "{empty}{} fields, but the header names {}",
                fields.len(),
                self.fields
            ));
        }
        let number = |c: usize| match io::parse_number(fields[c]) {
            Ok(v) => Ok(v),
            Err(BadNumber::NotNumeric) => Err(format!(
                "expected a number in column '{}', found '{}'",
                self.names[c],
                io::excerpt(fields[c])
            )),
            Err(BadNumber::NotFinite) => Err(format!(
                "'{}' in column '{}' is not a finite number",
                io::excerpt(fields[c]),
                self.names[c]
            )),
        };
        for &c in &self.coords {
            coords.push(number(c)?);
        }
        Ok((
            self.section.map(number).transpose()?,
            self.index.map(number).transpose()?,
        ))
    }
}

/// True when a reader takes `line`, as the first line of a file, for a name line (not a
/// comment, a header or a data row).
pub(crate) fn reads_as_name(line: &str) -> bool {
    let content = io::strip_comment(line);
    if content.trim().is_empty() || !matches!(Header::classify(content), FirstLine::Other) {
        return false;
    }
    let mut fields = Vec::new();
    match io::split_fields(content, &mut fields) {
        Err(_) => true,
        Ok(_) => !fields
            .iter()
            .all(|f| io::parse_number(f) != Err(BadNumber::NotNumeric)),
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
    /// The section and index values of every row, when the header names those columns.
    sections: Option<Vec<f64>>,
    indices: Option<Vec<f64>>,
    /// The names of the section and index columns, for warnings.
    key_names: (String, String),
    warnings: Vec<String>,
}

/// Whether every field of `content` (split on blanks, commas and semicolons) reads as a
/// number, finite or not: a line that looks like a row.
fn numeric_looking(content: &str) -> bool {
    content
        .split([' ', '\t', ',', ';'])
        .filter(|f| !f.is_empty())
        .all(|f| io::parse_number(f) != Err(BadNumber::NotNumeric))
}

/// Whether a line of `text` after line `no` looks like a row of numbers.
fn rows_after(text: &str, no: usize) -> bool {
    io::numbered_lines(text).filter(|(n, _)| *n > no).any(|(_, raw)| {
        let content = io::strip_comment(raw);
        !content.trim().is_empty() && numeric_looking(content)
    })
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
            sections: None,
            indices: None,
            key_names: (String::new(), String::new()),
            warnings: Vec::new(),
        };
        let mut state = State::Start;
        let mut header: Option<Header> = None;
        // Raw fields per row when there is no header (fixed by the first row).
        let mut row_fields = 0;
        let mut counts: Option<lednicer::LednicerCounts> = None;
        // Lednicer: rows before each blank line that follows some rows.
        let mut blocks: Vec<usize> = Vec::new();
        let mut fields: Vec<&str> = Vec::with_capacity(8);
        let mut vals: Vec<f64> = Vec::with_capacity(8);
        'lines: for (no, raw) in io::numbered_lines(text) {
            let content = io::strip_comment(raw);
            if content.trim().is_empty() {
                if counts.is_some() && blocks.last() != Some(&t.lines.len()) && !t.lines.is_empty() {
                    blocks.push(t.lines.len());
                }
                continue;
            }
            if let Some(h) = &header {
                let (section, index) = h
                    .row(content, &mut fields, &mut t.values)
                    .map_err(|m| perr(no, m))?;
                if let (Some(v), Some(all)) = (section, t.sections.as_mut()) {
                    all.push(v);
                }
                if let (Some(v), Some(all)) = (index, t.indices.as_mut()) {
                    all.push(v);
                }
                t.lines.push(no);
                continue;
            }
            if matches!(state, State::Start) {
                match Header::classify(content) {
                    FirstLine::Header(mut h) => {
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
                        h.settle(t.dims);
                        if !h.ignored.is_empty() {
                            t.warnings.push(format!(
                                "ignored column(s) {} of the header",
                                h.ignored.join(", ")
                            ));
                        }
                        let name = |c: Option<usize>| c.map_or_else(String::new, |c| h.names[c].clone());
                        t.key_names = (name(h.section), name(h.index));
                        t.sections = h.section.map(|_| Vec::new());
                        t.indices = h.index.map(|_| Vec::new());
                        t.format = Format::Csv;
                        header = Some(h);
                        state = State::Rows;
                        continue;
                    }
                    FirstLine::NoCoordinates(message) => return Err(perr(no, message)),
                    FirstLine::Other => {}
                }
            }
            let split = io::split_fields(content, &mut fields);
            if matches!(state, State::Start) && split.is_err() && !numeric_looking(content) {
                // Only a name line can be this irregular.
                t.name = Some(raw.trim().to_string());
                state = State::AfterName;
                continue;
            }
            if matches!(state, State::AfterName) && !numeric_looking(content) {
                // A name of two lines (a title, then the aerofoil's designation): one name.
                let name = t.name.take().unwrap_or_default();
                t.name = Some(format!("{name} {}", raw.trim()));
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
                    } else {
                        t.name = Some(raw.trim().to_string());
                        state = State::AfterName;
                        continue;
                    }
                }
                State::AfterName => {
                    if let Some(c) = lednicer::LednicerCounts::detect(&fields) {
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
            // A data row without a header: numbers only.
            vals.clear();
            for f in &fields {
                match io::parse_number(f) {
                    Ok(v) => vals.push(v),
                    Err(BadNumber::NotNumeric) if !t.lines.is_empty() && !rows_after(text, no) => {
                        // Notes after the coordinates (a source, a URL: one UIUC file in six
                        // ends so): the coordinates end here, and a warning says so.
                        t.warnings.push(format!(
                            "line {no} and after ignored: text after the coordinates ('{}')",
                            io::excerpt(content)
                        ));
                        break 'lines;
                    }
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
            if row_fields == 0 {
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
            } else if vals.len() != row_fields {
                return Err(perr(
                    no,
                    format!("{} fields, but the first row has {row_fields}", vals.len()),
                ));
            }
            t.values.extend_from_slice(&vals);
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
            let (values, lines) = lednicer::lednicer_to_selig(&t.values, &t.lines, c.upper);
            t.values = values;
            t.lines = lines;
        }
        Ok(t)
    }

    /// Put the rows in the order their section and index columns give: sections by ascending
    /// section value, points within a section by ascending index (file order without an index
    /// column). Returns the section structure when every section has the same number of points
    /// and no index repeats within a section; otherwise the rows keep file order and a warning
    /// says why the columns were ignored.
    fn arrange(&mut self) -> Option<Grid> {
        let (sections, indices) = (self.sections.take(), self.indices.take());
        let (s_name, i_name) = std::mem::take(&mut self.key_names);
        let n = self.lines.len();
        let mut order: Vec<usize> = (0..n).collect();
        let by_index = |a: &usize, b: &usize| {
            indices
                .as_ref()
                .map_or(std::cmp::Ordering::Equal, |i| i[*a].total_cmp(&i[*b]))
        };
        let repeated = |order: &[usize], same_group: &dyn Fn(usize, usize) -> bool| {
            let i = indices.as_ref()?;
            order
                .windows(2)
                .find(|w| same_group(w[0], w[1]) && i[w[0]] == i[w[1]])
                .map(|w| (self.lines[w[0]], self.lines[w[1]]))
        };
        let grid = match &sections {
            Some(s) => {
                order.sort_by(|a, b| s[*a].total_cmp(&s[*b]).then_with(|| by_index(a, b)));
                let mut runs: Vec<(f64, usize)> = Vec::new();
                for &k in &order {
                    match runs.last_mut() {
                        Some((v, len)) if *v == s[k] => *len += 1,
                        _ => runs.push((s[k], 1)),
                    }
                }
                let per = runs[0].1;
                if let Some((a, b)) = repeated(&order, &|a, b| s[a] == s[b]) {
                    self.warnings.push(format!(
                        "the {s_name}/{i_name} columns are ignored: lines {a} and {b} repeat a point of one {s_name}"
                    ));
                    None
                } else if let Some(&(v, len)) = runs.iter().find(|r| r.1 != per) {
                    self.warnings.push(format!(
                        "the {s_name} column is ignored: {s_name} {} has {per} points, {s_name} {v} has {len}",
                        runs[0].0
                    ));
                    None
                } else {
                    Some(Grid {
                        sections: runs.len(),
                        per_section: per,
                    })
                }
            }
            None => {
                order.sort_by(by_index);
                if let Some((a, b)) = repeated(&order, &|_, _| true) {
                    self.warnings.push(format!(
                        "the {i_name} column is ignored: lines {a} and {b} have the same {i_name}"
                    ));
                    order.sort();
                }
                None
            }
        };
        if (sections.is_some() && grid.is_none()) || order.iter().enumerate().all(|(k, &o)| k == o) {
            return grid;
        }
        let d = self.dims;
        self.values = order
            .iter()
            .flat_map(|&k| self.values[k * d..(k + 1) * d].iter().copied())
            .collect();
        self.lines = order.iter().map(|&k| self.lines[k]).collect();
        grid
    }

    /// Build points, the grid and the duplicate warnings: consecutive duplicates are dropped,
    /// and so are the copies of a contour listed again (see [`repeated_block`]); coordinates
    /// whose squared distances f64 cannot hold are refused at their line.
    fn finish<P: Vector>(mut self, path: &Path, make: impl Fn(&[f64]) -> P) -> Result<Loaded<P>> {
        let grid = self.arrange();
        let dims = self.dims;
        let mut points: Vec<P> = self.values.chunks_exact(dims).map(make).collect();
        if let Err((at, message)) = check_scale(&points, Precision::F64) {
            return Err(match at {
                Some(k) => Error::Parse {
                    path: path.to_path_buf(),
                    line: self.lines[k],
                    message,
                },
                None => Error::Input {
                    path: path.to_path_buf(),
                    message,
                },
            });
        }
        let mut dropped = Vec::new();
        if grid.is_none() {
            let mut keep = 0;
            for k in 0..points.len() {
                if keep > 0 && points[k] == points[keep - 1] {
                    dropped.push(self.lines[k]);
                } else {
                    points[keep] = points[k];
                    self.lines[keep] = self.lines[k];
                    keep += 1;
                }
            }
            points.truncate(keep);
            self.lines.truncate(keep);
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
            if let Some(block) = repeated_block(&points) {
                let n = points.len();
                let l = &self.lines;
                self.warnings.push(format!(
                    "lines {}-{} list the points of lines {}-{} again ({:.1} times in all): \
                     only the first copy is kept",
                    l[block],
                    l[n - 1],
                    l[0],
                    l[block - 1],
                    n as f64 / block as f64
                ));
                // A closed contour keeps its closing point (the first point again).
                let keep = if (n - 1).is_multiple_of(block) {
                    block + 1
                } else {
                    block
                };
                points.truncate(keep);
                self.lines.truncate(keep);
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

/// The length `p` of a block of points that the whole list repeats (`points[i] ==
/// points[i - p]` for every `i ≥ p`, with at least one whole copy after the first): a contour
/// listed again, which would only cost time. The smallest such `p ≥ 2`, or `None`.
fn repeated_block<P: PartialEq>(points: &[P]) -> Option<usize> {
    let n = points.len();
    (2..=n / 2)
        .filter(|&p| points[p] == points[0])
        .find(|&p| (p..n).all(|i| points[i] == points[i - p]))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p() -> &'static Path {
        Path::new("t.csv")
    }

    /// Asserts that `err` is a parse error at line `line` whose message says `says`.
    fn refused_at(err: &Error, line: usize, says: &str) {
        assert!(matches!(err, Error::Parse { line: l, .. } if *l == line), "{err}");
        assert!(err.to_string().contains(says), "{err}");
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
    fn a_contour_listed_again_is_kept_once_with_a_warning() {
        let open: Vec<String> = (0..10).map(|i| format!("{} {}", i, (i * i) % 7)).collect();
        // Open: 20 copies; closed (last point = first): 3 copies, the joins merged.
        let text = format!("name\n{}\n", vec![open.join("\n"); 20].join("\n"));
        let l = parse_curve(&text, p()).unwrap();
        assert_eq!(l.points.len(), 10);
        let w = l.warnings.join("; ");
        assert!(
            w.contains("lines 12-201 list the points of lines 2-11 again (20.0 times"),
            "{w}"
        );
        let mut closed = open.clone();
        closed.push(open[0].clone());
        let text = format!("name\n{}\n", vec![closed.join("\n"); 3].join("\n"));
        let l = parse_curve(&text, p()).unwrap();
        assert_eq!(l.points.len(), 11);
        assert_eq!(l.points[0], l.points[10]);
        // One closed contour alone is left as it is.
        let l = parse_curve(&format!("name\n{}\n", closed.join("\n")), p()).unwrap();
        assert_eq!(l.points.len(), 11);
        assert!(l.warnings.is_empty(), "{:?}", l.warnings);
    }

    #[test]
    fn coordinates_whose_squares_overflow_are_refused_at_their_line() {
        let e = parse_curve("a\n1 0\n0.5 1e200\n0 0\n", p()).unwrap_err();
        refused_at(&e, 3, "overflow f64");
        let e = parse_curve("1e-300 0\n0 1e-301\n0 0\n", p()).unwrap_err();
        assert!(e.to_string().contains("underflow"), "{e}");
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
        // Sections of 2 and 1 points: no grid, file order kept.
        let l = parse_cloud("x,y,z,section,index\n0,0,0,0,1\n1,0,0,0,0\n2,0,0,1,0\n", p()).unwrap();
        assert_eq!(l.grid, None);
        assert_eq!(l.points[0], DVec3::ZERO);
        assert_eq!(l.warnings.len(), 1);
        assert!(
            l.warnings[0].contains("section 0 has 2 points, section 1 has 1"),
            "{:?}",
            l.warnings
        );
        // An index repeated within a section.
        let l = parse_cloud("x,y,z,section,index\n0,0,0,0,0\n1,0,0,0,0\n", p()).unwrap();
        assert_eq!(l.grid, None);
        assert!(l.warnings[0].contains("lines 2 and 3"), "{:?}", l.warnings);
    }

    /// The blade cloud people have: named columns in their own order, text and extra columns,
    /// stations and points instead of sections and indices.
    const STATIONS: &str = "Station,Point,radius,chord,twist_deg,airfoil,X,Y,Z\n\
        0,0,1.5,3.5,13.3,Cylinder1_coords.txt,1,0,1.5\n\
        0,1,1.5,3.5,13.3,Cylinder1_coords.txt,0,1,1.5\n\
        0,2,1.5,3.5,13.3,Cylinder1_coords.txt,-1,0,1.5\n\
        1,0,2.5,3.4,12.0,\"FFA-W3-301, blended\",1,0,2.5\n\
        1,1,2.5,3.4,12.0,\"FFA-W3-301, blended\",0,1,2.5\n\
        1,2,2.5,3.4,12.0,\"FFA-W3-301, blended\",-1,0,2.5\n";

    #[test]
    fn stations_and_points_give_the_grid() {
        let l = parse_cloud(STATIONS, p()).unwrap();
        assert_eq!(
            l.grid,
            Some(Grid {
                sections: 2,
                per_section: 3
            })
        );
        assert_eq!(l.points[1], DVec3::new(0.0, 1.0, 1.5));
        assert_eq!(l.points[5], DVec3::new(-1.0, 0.0, 2.5));
        assert_eq!(l.format, Format::Csv);
        assert_eq!(
            l.warnings,
            ["ignored column(s) radius, chord, twist_deg, airfoil of the header"]
        );
    }

    #[test]
    fn rows_in_any_order_are_sorted_by_section_and_index() {
        // The rows of STATIONS reversed: the same cloud.
        let mut lines: Vec<&str> = STATIONS.lines().collect();
        lines[1..].reverse();
        let l = parse_cloud(&lines.join("\n"), p()).unwrap();
        assert_eq!(l, parse_cloud(STATIONS, p()).unwrap());
        // Sections without an index column keep their file order within a section.
        let l = parse_cloud("section,x,y,z\n5,0,0,1\n2,0,0,0\n5,1,0,1\n2,1,0,0\n", p()).unwrap();
        assert_eq!(l.grid.map(|g| (g.sections, g.per_section)), Some((2, 2)));
        let x: Vec<f64> = l.points.iter().map(|q| q.x + 10.0 * q.z).collect();
        assert_eq!(x, [0.0, 1.0, 10.0, 11.0]);
    }

    #[test]
    fn a_2d_header_in_any_order_with_text_columns() {
        let l = parse_curve("label,y,x\nte,0,1\nle,0.1,0\n\"lower, te\",-0.01,1\n", p()).unwrap();
        assert_eq!(
            l.points,
            [DVec2::new(1.0, 0.0), DVec2::new(0.0, 0.1), DVec2::new(1.0, -0.01)]
        );
        assert_eq!(l.warnings, ["ignored column(s) label of the header"]);
        // An index (or point) column orders a curve.
        let l = parse_curve("point;X;Y\n2;0;1\n0;2;0\n1;1;1\n", p()).unwrap();
        assert_eq!(
            l.points,
            [DVec2::new(2.0, 0.0), DVec2::new(1.0, 1.0), DVec2::new(0.0, 1.0)]
        );
        // Text columns may hold blanks, and commas in quotes.
        let l = parse_curve("name; x; y\n\"NACA 4413, upper\"; 1; 0\nle, 0; 0\n", p()).unwrap();
        assert_eq!(l.points, [DVec2::new(1.0, 0.0), DVec2::ZERO]);
    }

    #[test]
    fn a_header_without_x_and_y_names_its_line() {
        for (text, missing) in [
            ("station,point,radius,chord\n0,0,1,2\n", "no x and no y column"),
            ("# scan\nX,z\n0,1\n", "no y column"),
        ] {
            let err = parse_cloud(text, p()).unwrap_err();
            let line = if text.starts_with('#') { 2 } else { 1 };
            refused_at(&err, line, missing);
            assert!(err.to_string().starts_with("t.csv:"), "{err}");
        }
        // A name line with commas and blanks is still a name.
        let l = parse_curve("S1223 (Selig, high lift)\n1 0\n0 0\n", p()).unwrap();
        assert_eq!(l.name, "S1223 (Selig, high lift)");
        assert_eq!(l.format, Format::Selig);
    }

    #[test]
    fn bad_values_in_named_columns_name_the_column_and_line() {
        let err = parse_cloud("x,y,z,note\n0,0,0,a\n1,?,0,b\n", p()).unwrap_err();
        refused_at(&err, 3, "column 'y'");
        let err = parse_cloud("x,y,z,note\n0,0,0\n", p()).unwrap_err();
        assert!(
            err.to_string().contains("3 fields, but the header names 4"),
            "{err}"
        );
        let err = parse_curve("x,y,note\n0,0,\"open\n", p()).unwrap_err();
        assert!(err.to_string().contains("unclosed quote"), "{err}");
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
