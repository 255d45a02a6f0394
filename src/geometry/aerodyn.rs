//! OpenFAST AeroDyn 15 blade input, resolved the way OpenFAST resolves it: the primary file's
//! `NumAFfiles` and `AFNames` list the AirfoilInfo (polar) files and `ADBlFile(1)` names the
//! blade file; each polar file's `NumCoords` line holds either the coordinates' count (the
//! rows follow in the same file) or `@"file"`, a coordinates file with its own `NumCoords`
//! line. Every file name is relative to the folder of the file that names it.
//!
//! A coordinates block is `NumCoords` rows: the aerofoil's reference point first, then the
//! contour in chord fractions, in either direction (decided by its signed area).
//!
//! The blade file's table is read by its header names (`BlSpn BlCrvAC BlSwpAC BlTwist BlChord
//! BlAFID`, other columns ignored), `NumBlNds` rows. Node `i` becomes a station with radius
//! `BlSpn`, chord `BlChord`, prebend `BlCrvAC` (downwind, towards the suction side), sweep
//! `BlSwpAC` (towards the trailing edge), twist `-BlTwist` (AeroDyn's twist is positive towards
//! feather; see [`Axes::Turbine`]) and its own aerofoil `BlAFID`, placed so that the aerofoil's
//! reference point lies on the node. AeroDyn interpolates nothing between nodes; sections
//! between them (`--sections`) follow [`Blend::Radius`]. `BlCrvAng` is not applied: sections lie
//! in the planes `z = BlSpn`.

use super::blade::{
    merge_coincident, unit_contour, Aerofoil, Axes, Blade, BladeFormat, Blend, Station, COINCIDENT_SPAN,
};
use super::io;
use crate::error::{Error, Result};
use glam::DVec2;
use std::path::{Path, PathBuf};

/// A parse error at `line` of `path`.
fn at(path: &Path, line: usize, message: impl Into<String>) -> Error {
    Error::Parse {
        path: path.to_path_buf(),
        line,
        message: message.into(),
    }
}

/// True when `text` looks like an AeroDyn 15 primary file (it has a `NumAFfiles` line).
pub(crate) fn is_primary(text: &str) -> bool {
    io::numbered_lines(text).any(|(_, l)| name_of(l).is_some_and(|n| n.eq_ignore_ascii_case("NumAFfiles")))
}

/// The value of an AeroDyn `value  Name  - description` line: the first field, or the quoted
/// string it starts with; `@` before it (a file reference) is reported, not kept. Also the
/// rest of the line after the value.
fn value_of(line: &str) -> Option<(bool, &str, &str)> {
    let t = line.trim_start();
    let (at_sign, t) = match t.strip_prefix('@') {
        Some(r) => (true, r),
        None => (false, t),
    };
    if let Some(r) = t.strip_prefix('"') {
        let end = r.find('"')?;
        Some((at_sign, &r[..end], &r[end + 1..]))
    } else {
        let end = t.find(char::is_whitespace).unwrap_or(t.len());
        if end == 0 {
            return None;
        }
        Some((at_sign, &t[..end], &t[end..]))
    }
}

/// The name (second field) of an AeroDyn `value  Name  - description` line.
fn name_of(line: &str) -> Option<&str> {
    let (_, _, rest) = value_of(line)?;
    rest.split_whitespace().next()
}

/// The line (number, text) whose name is `name`.
fn find<'a>(lines: &[(usize, &'a str)], name: &str) -> Option<(usize, usize, &'a str)> {
    lines
        .iter()
        .enumerate()
        .find(|(_, (_, l))| name_of(l).is_some_and(|n| n.eq_ignore_ascii_case(name)))
        .map(|(i, &(no, l))| (i, no, l))
}

/// A comment or blank line of an AeroDyn input file.
fn is_comment(line: &str) -> bool {
    let t = line.trim_start();
    t.is_empty() || t.starts_with('!') || t.starts_with('#')
}

/// The leading numbers of a line (as many as parse), at most `max`.
fn numbers(line: &str, max: usize) -> Vec<f64> {
    line.split(|c: char| c.is_whitespace() || c == ',')
        .filter(|f| !f.is_empty())
        .take(max)
        .map_while(|f| io::parse_number(f).ok())
        .collect()
}

/// One aerofoil as AeroDyn gives it: the contour (Selig order) and the reference point.
struct Section {
    points: Vec<DVec2>,
    reference: DVec2,
}

/// Read the `NumCoords` block that starts at line index `start` of `lines` (the `NumCoords`
/// line itself): `count` rows, the reference point first. `whole` says the block is the rest
/// of the file (a coordinates file), so that more rows are an error.
fn coords_block(
    lines: &[(usize, &str)],
    start: usize,
    count: usize,
    whole: bool,
    path: &Path,
) -> Result<Section> {
    let count_line = lines[start].0;
    if count < 4 {
        return Err(at(
            path,
            count_line,
            format!("NumCoords is {count}: the reference point and at least 3 contour points are needed"),
        ));
    }
    let mut rows: Vec<DVec2> = Vec::with_capacity(count);
    let mut last_line = count_line;
    for &(no, l) in &lines[start + 1..] {
        if is_comment(l) {
            continue;
        }
        let v = numbers(l, 2);
        if rows.len() == count {
            if whole && v.len() == 2 {
                return Err(at(
                    path,
                    no,
                    format!("NumCoords says {count} rows (the reference point first), but more rows follow"),
                ));
            }
            break;
        }
        if v.len() < 2 {
            return Err(at(
                path,
                no,
                format!(
                    "expected row {} of NumCoords = {count} ('x/c y/c'), found '{}'",
                    rows.len() + 1,
                    io::excerpt(l)
                ),
            ));
        }
        rows.push(DVec2::new(v[0], v[1]));
        last_line = no;
    }
    if rows.len() < count {
        return Err(at(
            path,
            last_line,
            format!(
                "NumCoords says {count} rows (the reference point first), but the file ends after {}",
                rows.len()
            ),
        ));
    }
    let reference = rows[0];
    let (points, _) =
        unit_contour(rows.split_off(1)).map_err(|m| at(path, count_line, format!("the coordinates: {m}")))?;
    Ok(Section { points, reference })
}

/// Read an AirfoilInfo (polar) file's coordinates: inline, or from its `@"file"`.
fn read_polar(path: &Path) -> Result<Section> {
    let text = io::read_text(path)?;
    let lines: Vec<(usize, &str)> = io::numbered_lines(&text).collect();
    let (i, no, line) = find(&lines, "NumCoords")
        .ok_or_else(|| at(path, 1, "no 'NumCoords' line: not an AirfoilInfo file?"))?;
    let (file_ref, value, _) = value_of(line).ok_or_else(|| at(path, no, "NumCoords: no value"))?;
    if file_ref {
        let coords = path.parent().unwrap_or(Path::new("")).join(value);
        let ctext =
            io::read_text(&coords).map_err(|e| at(path, no, format!("NumCoords @\"{value}\": {e}")))?;
        let clines: Vec<(usize, &str)> = io::numbered_lines(&ctext).collect();
        let (ci, cno, cline) = find(&clines, "NumCoords").ok_or_else(|| {
            at(
                &coords,
                1,
                "no 'NumCoords' line: not an AeroDyn coordinates file?",
            )
        })?;
        let count = value_of(cline)
            .and_then(|(_, v, _)| v.parse::<usize>().ok())
            .ok_or_else(|| {
                at(
                    &coords,
                    cno,
                    format!("NumCoords: expected a count, found '{}'", io::excerpt(cline)),
                )
            })?;
        return coords_block(&clines, ci, count, true, &coords);
    }
    let count = value.parse::<usize>().map_err(|_| {
        at(
            path,
            no,
            format!("NumCoords: expected a count or @\"file\", found '{value}'"),
        )
    })?;
    if count == 0 {
        return Err(at(
            path,
            no,
            "NumCoords is 0: the file gives no aerofoil coordinates",
        ));
    }
    coords_block(&lines, i, count, false, path)
}

/// One node of the blade table.
struct Node {
    line: usize,
    span: f64,
    crv: f64,
    swp: f64,
    twist: f64,
    chord: f64,
    af: f64,
}

/// Read the blade file's table.
fn read_blade_file(path: &Path) -> Result<Vec<Node>> {
    let text = io::read_text(path)?;
    let lines: Vec<(usize, &str)> = io::numbered_lines(&text).collect();
    let (i, no, line) = find(&lines, "NumBlNds")
        .ok_or_else(|| at(path, 1, "no 'NumBlNds' line: not an AeroDyn blade file?"))?;
    let n = value_of(line)
        .and_then(|(_, v, _)| v.parse::<usize>().ok())
        .ok_or_else(|| {
            at(
                path,
                no,
                format!("NumBlNds: expected a count, found '{}'", io::excerpt(line)),
            )
        })?;
    let mut rest = lines[i + 1..].iter().filter(|(_, l)| !l.trim().is_empty());
    let &(hno, header) = rest
        .next()
        .ok_or_else(|| at(path, no, "the file ends before the table's header"))?;
    let names: Vec<&str> = header.split_whitespace().collect();
    let col = |want: &str| {
        names
            .iter()
            .position(|n| n.eq_ignore_ascii_case(want))
            .ok_or_else(|| {
                at(
                    path,
                    hno,
                    format!(
                        "the table has no '{want}' column (header: '{}')",
                        io::excerpt(header)
                    ),
                )
            })
    };
    let cols = [
        col("BlSpn")?,
        col("BlCrvAC")?,
        col("BlSwpAC")?,
        col("BlTwist")?,
        col("BlChord")?,
        col("BlAFID")?,
    ];
    let width = cols.iter().max().map_or(0, |m| m + 1);
    // The units line.
    let _ = rest.next();
    let mut nodes = Vec::with_capacity(n);
    let mut last = hno;
    for &(lno, l) in rest {
        let v = numbers(l, names.len().max(width));
        if nodes.len() == n {
            if v.len() >= width {
                return Err(at(
                    path,
                    lno,
                    format!("NumBlNds says {n} nodes, but another row follows"),
                ));
            }
            break;
        }
        if v.len() < width {
            return Err(at(
                path,
                lno,
                format!(
                    "NumBlNds says {n} nodes, but this is not node {} (a row of {width} numbers): '{}'",
                    nodes.len() + 1,
                    io::excerpt(l)
                ),
            ));
        }
        nodes.push(Node {
            line: lno,
            span: v[cols[0]],
            crv: v[cols[1]],
            swp: v[cols[2]],
            twist: v[cols[3]],
            chord: v[cols[4]],
            af: v[cols[5]],
        });
        last = lno;
    }
    if nodes.len() < n {
        return Err(at(
            path,
            last,
            format!("NumBlNds says {n} nodes, but the file ends after {}", nodes.len()),
        ));
    }
    Ok(nodes)
}

/// Read an AeroDyn 15 primary file and everything it names; `path` names it in messages and
/// anchors the relative file names.
pub(crate) fn read(text: &str, path: &Path) -> Result<Blade> {
    let base = path.parent().unwrap_or(Path::new(""));
    let lines: Vec<(usize, &str)> = io::numbered_lines(text).collect();
    let (i, no, line) = find(&lines, "NumAFfiles").ok_or_else(|| at(path, 1, "no 'NumAFfiles' line"))?;
    let count = value_of(line)
        .and_then(|(_, v, _)| v.parse::<usize>().ok())
        .filter(|&c| c > 0)
        .ok_or_else(|| {
            at(
                path,
                no,
                format!(
                    "NumAFfiles: expected a positive count, found '{}'",
                    io::excerpt(line)
                ),
            )
        })?;
    // AFNames: NumAFfiles file names, one a line, starting on the line after NumAFfiles.
    let mut names: Vec<(usize, PathBuf)> = Vec::with_capacity(count);
    for &(lno, l) in lines[i + 1..].iter().take(count) {
        let t = l.trim_start();
        let name = value_of(l)
            .filter(|_| !(t.starts_with("==") || t.starts_with("--")))
            .map(|(_, v, _)| v);
        match name {
            Some(v) => names.push((lno, base.join(v))),
            None => {
                return Err(at(
                    path,
                    lno,
                    format!(
                        "NumAFfiles says {count}, but this line is not an aerofoil file name (AFNames has {}): '{}'",
                        names.len(),
                        io::excerpt(l)
                    ),
                ))
            }
        }
    }
    if names.len() < count {
        return Err(at(
            path,
            no,
            format!(
                "NumAFfiles says {count}, but the file ends after {} names",
                names.len()
            ),
        ));
    }
    let (_, bno, bline) = find(&lines, "ADBlFile(1)").ok_or_else(|| at(path, 1, "no 'ADBlFile(1)' line"))?;
    let blade_file = value_of(bline)
        .map(|(_, v, _)| base.join(v))
        .ok_or_else(|| at(path, bno, "ADBlFile(1): no file name"))?;

    let mut aerofoils = Vec::with_capacity(count);
    let mut references = Vec::with_capacity(count);
    for (k, (lno, file)) in names.iter().enumerate() {
        let section = read_polar(file).map_err(|e| match e {
            // The file itself could not be read: say which AFNames entry named it.
            Error::Io { .. } => at(path, *lno, format!("AFNames entry {}: {e}", k + 1)),
            other => other,
        })?;
        aerofoils.push(Aerofoil::File {
            path: file.clone(),
            name: file
                .file_stem()
                .map_or_else(String::new, |s| s.to_string_lossy().into_owned()),
            points: section.points,
        });
        references.push(section.reference);
    }

    let nodes = read_blade_file(&blade_file).map_err(|e| match e {
        Error::Io { .. } => at(path, bno, format!("ADBlFile(1): {e}")),
        other => other,
    })?;
    if nodes.len() < 2 {
        return Err(at(
            &blade_file,
            1,
            format!("NumBlNds is {}: at least 2 nodes are needed", nodes.len()),
        ));
    }
    // Spans within this of their predecessor are twins, merged below.
    let twins = COINCIDENT_SPAN * (nodes[nodes.len() - 1].span - nodes[0].span).abs();
    let mut stations = Vec::with_capacity(nodes.len());
    for (k, nd) in nodes.iter().enumerate() {
        if k > 0 && nodes[k - 1].span - nd.span > twins {
            return Err(at(
                &blade_file,
                nd.line,
                format!(
                    "BlSpn: the span does not increase ({} after {})",
                    nd.span,
                    nodes[k - 1].span
                ),
            ));
        }
        if nd.chord < 0.0 {
            return Err(at(
                &blade_file,
                nd.line,
                format!("BlChord {} is negative", nd.chord),
            ));
        }
        if !(nd.af.fract() == 0.0 && nd.af >= 1.0 && nd.af <= count as f64) {
            return Err(at(
                &blade_file,
                nd.line,
                format!("BlAFID {}: unknown aerofoil (NumAFfiles is {count})", nd.af),
            ));
        }
        let a = nd.af as usize - 1;
        let r = references[a];
        stations.push(Station {
            radius: nd.span,
            chord: nd.chord,
            twist_deg: -nd.twist,
            aerofoil: a,
            pitch_axis: r.x,
            prebend: nd.crv,
            sweep: nd.swp,
            normal_offset: -r.y * nd.chord,
        });
    }
    if stations.iter().all(|s| s.chord == 0.0) {
        return Err(at(&blade_file, nodes[0].line, "BlChord: every chord is zero"));
    }
    let notes = merge_coincident(&mut stations, None, |k| {
        format!("node {} (line {})", k + 1, nodes[k].line)
    })
    .map_err(|(k, m)| at(&blade_file, nodes[k].line, m))?;
    Ok(Blade {
        name: path
            .file_stem()
            .map_or_else(String::new, |s| s.to_string_lossy().into_owned()),
        stations,
        aerofoils,
        warnings: Vec::new(),
        notes: notes.into_iter().collect(),
        format: BladeFormat::AeroDyn15,
        axes: Axes::Turbine,
        blend: Blend::Radius,
    })
}
