//! Reading blade files: the format detection, and bezchain's own blade JSON (column or
//! station form) with its aerofoil references resolved.

use super::blade::{
    merge_coincident, unit_contour, Aerofoil, Axes, Blade, BladeFormat, Blend, Station, COINCIDENT_SPAN,
    DEFAULT_PITCH_AXIS,
};
use super::io;
use super::naca::Naca;
use super::points::read_curve;
use crate::error::{Error, Result};
use serde_json::{Map, Value};
use std::collections::HashMap;
use std::path::Path;

/// The fields a station has, in both forms.
const STATION_FIELDS: [&str; 7] = [
    "radius",
    "chord",
    "twist_deg",
    "aerofoil",
    "pitch_axis",
    "prebend",
    "sweep",
];

/// Which layout the file used: it decides how fields are named in messages.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Form {
    Columns,
    Stations,
}

/// The station values as read, before aerofoils are resolved.
struct Columns {
    form: Form,
    radius: Vec<f64>,
    chord: Vec<f64>,
    twist_deg: Vec<f64>,
    aerofoil: Vec<String>,
    pitch_axis: Vec<f64>,
    prebend: Vec<f64>,
    sweep: Vec<f64>,
}

impl Columns {
    /// How to name `field` of station `i` in a message: `'chord'` (with ` at index i` added by
    /// [`Columns::at`]) or `'stations[i].chord'`.
    fn field(&self, field: &str, i: usize) -> String {
        match self.form {
            Form::Columns => format!("'{field}'"),
            Form::Stations => format!("'stations[{i}].{field}'"),
        }
    }

    /// ` at index i` in column form, nothing in station form (the field name says it).
    fn at(&self, i: usize) -> String {
        match self.form {
            Form::Columns => format!(" at index {i}"),
            Form::Stations => String::new(),
        }
    }
}

impl Blade {
    /// Read and validate a blade file of any supported format, detected from its content: JSON
    /// (starts with `{`), an AeroDyn 15 primary file (has a `NumAFfiles` line), otherwise
    /// windIO YAML. Files it names are resolved against the folder of the file naming them.
    pub fn from_file(path: &Path) -> Result<Blade> {
        let text = io::read_text(path)?;
        let trimmed = text.trim_start();
        if trimmed.starts_with('{') || trimmed.starts_with('[') {
            Blade::from_json(&text, path)
        } else if super::aerodyn::is_primary(&text) {
            super::aerodyn::read(&text, path)
        } else {
            super::windio::read(&text, path)
        }
    }

    /// Whether `path` names a blade definition rather than a point file: a `.yaml`, `.yml` or
    /// `.json` file, or (another extension but `.csv`, `.txt`, `.xyz` and standard input) an
    /// AeroDyn 15 primary file.
    #[must_use]
    pub fn is_definition(path: &Path) -> bool {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        match ext.as_deref() {
            Some("yaml" | "yml" | "json") => true,
            Some("csv" | "txt" | "xyz") => false,
            _ if io::is_stdin(path) => false,
            _ => io::read_text(path).is_ok_and(|t| super::aerodyn::is_primary(&t)),
        }
    }

    /// Parse blade JSON; `path` names it in errors and anchors relative aerofoil paths.
    pub fn from_json(text: &str, path: &Path) -> Result<Blade> {
        let bad = |message: String| Error::Input {
            path: path.to_path_buf(),
            message,
        };
        let root: Value = serde_json::from_str(text).map_err(|e| Error::Parse {
            path: path.to_path_buf(),
            line: e.line().max(1),
            message: format!("not valid JSON: {e}"),
        })?;
        let obj = root.as_object().ok_or_else(|| {
            bad(format!(
                "expected a JSON object at the top, found {}",
                kind(&root)
            ))
        })?;
        let cols = read_columns(obj).map_err(bad)?;
        validate(&cols).map_err(bad)?;
        let name = match obj.get("name") {
            None => path
                .file_stem()
                .map_or_else(String::new, |s| s.to_string_lossy().into_owned()),
            Some(Value::String(s)) => s.clone(),
            Some(v) => return Err(bad(format!("field 'name': expected a string, found {}", kind(v)))),
        };
        let base = path.parent().unwrap_or(Path::new(""));
        let mut aerofoils: Vec<Aerofoil> = Vec::new();
        let mut index: HashMap<&str, usize> = HashMap::new();
        let mut warnings = Vec::new();
        let mut stations = Vec::with_capacity(cols.radius.len());
        for i in 0..cols.radius.len() {
            let spec = cols.aerofoil[i].as_str();
            let a = match index.get(spec) {
                Some(&a) => a,
                None => {
                    let field = format!("field {}{}", cols.field("aerofoil", i), cols.at(i));
                    let (aerofoil, w) =
                        resolve_aerofoil(spec, base).map_err(|m| bad(format!("{field}: {m}")))?;
                    warnings.extend(w.into_iter().map(|w| format!("aerofoil '{spec}': {w}")));
                    aerofoils.push(aerofoil);
                    index.insert(spec, aerofoils.len() - 1);
                    aerofoils.len() - 1
                }
            };
            stations.push(Station {
                radius: cols.radius[i],
                chord: cols.chord[i],
                twist_deg: cols.twist_deg[i],
                aerofoil: a,
                pitch_axis: cols.pitch_axis[i],
                prebend: cols.prebend[i],
                sweep: cols.sweep[i],
                normal_offset: 0.0,
            });
        }
        let notes = merge_coincident(&mut stations, None, |k| {
            format!("field {}{}", cols.field("radius", k), cols.at(k))
        })
        .map_err(|(_, m)| bad(m))?;
        Ok(Blade {
            name,
            stations,
            aerofoils,
            warnings,
            notes: notes.into_iter().collect(),
            format: BladeFormat::Json,
            axes: Axes::Section,
            blend: Blend::Radius,
        })
    }
}

/// A JSON value's kind, for messages.
fn kind(v: &Value) -> &'static str {
    match v {
        Value::Null => "null",
        Value::Bool(_) => "a boolean",
        Value::Number(_) => "a number",
        Value::String(_) => "a string",
        Value::Array(_) => "an array",
        Value::Object(_) => "an object",
    }
}

/// A finite number or a message naming `field`.
fn number(v: &Value, field: &str) -> std::result::Result<f64, String> {
    v.as_f64()
        .filter(|x| x.is_finite())
        .ok_or_else(|| format!("field '{field}': expected a number, found {}", kind(v)))
}

/// A string or a message naming `field`.
fn string(v: &Value, field: &str) -> std::result::Result<String, String> {
    v.as_str()
        .map(str::to_string)
        .ok_or_else(|| format!("field '{field}': expected a string, found {}", kind(v)))
}

/// A column: an array of `n` values (`n` from `radius`), or one value for every station.
fn column<T>(
    obj: &Map<String, Value>,
    field: &str,
    n: usize,
    default: Option<T>,
    one: impl Fn(&Value, &str) -> std::result::Result<T, String>,
) -> std::result::Result<Vec<T>, String>
where
    T: Clone,
{
    match obj.get(field) {
        None => default
            .map(|d| vec![d; n])
            .ok_or_else(|| format!("field '{field}' is missing")),
        Some(Value::Array(items)) => {
            if items.len() != n {
                return Err(format!(
                    "field '{field}': {} values, but 'radius' has {n}",
                    items.len()
                ));
            }
            items
                .iter()
                .enumerate()
                .map(|(i, v)| one(v, field).map_err(|m| format!("{m} at index {i}")))
                .collect()
        }
        Some(v) => Ok(vec![one(v, field)?; n]),
    }
}

/// Reject any field not in `known`, naming it and the ones allowed.
fn no_unknown(obj: &Map<String, Value>, known: &[&str], prefix: &str) -> std::result::Result<(), String> {
    match obj.keys().find(|k| !known.contains(&k.as_str())) {
        Some(k) => Err(format!(
            "unknown field '{prefix}{k}' (expected one of: {})",
            known.join(", ")
        )),
        None => Ok(()),
    }
}

/// Read either form into columns.
fn read_columns(obj: &Map<String, Value>) -> std::result::Result<Columns, String> {
    let aerofoil_key = |o: &Map<String, Value>, at: &str| -> std::result::Result<Option<Value>, String> {
        match (o.get("aerofoil"), o.get("airfoil")) {
            (Some(_), Some(_)) => Err(format!("give '{at}aerofoil' or '{at}airfoil', not both")),
            (a, b) => Ok(a.or(b).cloned()),
        }
    };
    if let Some(list) = obj.get("stations") {
        if let Some(f) = STATION_FIELDS[..3].iter().find(|f| obj.contains_key(**f)) {
            return Err(format!(
                "field 'stations': give either a 'stations' list or column arrays such as '{f}', not both"
            ));
        }
        no_unknown(
            obj,
            &["name", "stations", "aerofoil", "airfoil", "pitch_axis"],
            "",
        )?;
        let items = list.as_array().ok_or_else(|| {
            format!(
                "field 'stations': expected an array of objects, found {}",
                kind(list)
            )
        })?;
        let default_aerofoil = aerofoil_key(obj, "")?;
        let default_pitch = match obj.get("pitch_axis") {
            Some(v) => number(v, "pitch_axis")?,
            None => DEFAULT_PITCH_AXIS,
        };
        let mut c = Columns {
            form: Form::Stations,
            radius: Vec::new(),
            chord: Vec::new(),
            twist_deg: Vec::new(),
            aerofoil: Vec::new(),
            pitch_axis: Vec::new(),
            prebend: Vec::new(),
            sweep: Vec::new(),
        };
        let mut station_known: Vec<&str> = STATION_FIELDS.to_vec();
        station_known.push("airfoil");
        for (i, item) in items.iter().enumerate() {
            let at = format!("stations[{i}].");
            let s = item
                .as_object()
                .ok_or_else(|| format!("field 'stations[{i}]': expected an object, found {}", kind(item)))?;
            no_unknown(s, &station_known, &at)?;
            let req = |f: &str| -> std::result::Result<f64, String> {
                let name = format!("{at}{f}");
                s.get(f)
                    .map_or_else(|| Err(format!("field '{name}' is missing")), |v| number(v, &name))
            };
            let opt = |f: &str, d: f64| -> std::result::Result<f64, String> {
                s.get(f).map_or(Ok(d), |v| number(v, &format!("{at}{f}")))
            };
            c.radius.push(req("radius")?);
            c.chord.push(req("chord")?);
            c.twist_deg.push(req("twist_deg")?);
            c.pitch_axis.push(opt("pitch_axis", default_pitch)?);
            c.prebend.push(opt("prebend", 0.0)?);
            c.sweep.push(opt("sweep", 0.0)?);
            let a = aerofoil_key(s, &at)?
                .or_else(|| default_aerofoil.clone())
                .ok_or_else(|| format!("field '{at}aerofoil' is missing (and no top-level 'aerofoil')"))?;
            c.aerofoil.push(string(&a, &format!("{at}aerofoil"))?);
        }
        return Ok(c);
    }
    let mut known: Vec<&str> = STATION_FIELDS.to_vec();
    known.extend(["name", "airfoil", "stations"]);
    no_unknown(obj, &known, "")?;
    let radius = match obj.get("radius") {
        Some(Value::Array(items)) => items
            .iter()
            .enumerate()
            .map(|(i, v)| number(v, "radius").map_err(|m| format!("{m} at index {i}")))
            .collect::<std::result::Result<Vec<f64>, String>>()?,
        Some(v) => {
            return Err(format!(
                "field 'radius': expected an array of numbers, found {}",
                kind(v)
            ))
        }
        None => return Err("field 'radius' is missing (or give a 'stations' list)".into()),
    };
    let n = radius.len();
    let aerofoil_value = aerofoil_key(obj, "")?.ok_or("field 'aerofoil' is missing")?;
    let mut with_aerofoil = obj.clone();
    with_aerofoil.insert("aerofoil".into(), aerofoil_value);
    Ok(Columns {
        form: Form::Columns,
        chord: column(obj, "chord", n, None, number)?,
        twist_deg: column(obj, "twist_deg", n, None, number)?,
        aerofoil: column(&with_aerofoil, "aerofoil", n, None, string)?,
        pitch_axis: column(obj, "pitch_axis", n, Some(DEFAULT_PITCH_AXIS), number)?,
        prebend: column(obj, "prebend", n, Some(0.0), number)?,
        sweep: column(obj, "sweep", n, Some(0.0), number)?,
        radius,
    })
}

/// Check the station values, naming the field of the first problem.
fn validate(c: &Columns) -> std::result::Result<(), String> {
    let n = c.radius.len();
    if n < 2 {
        let f = match c.form {
            Form::Columns => "'radius'",
            Form::Stations => "'stations'",
        };
        return Err(format!("field {f}: at least 2 stations are needed (got {n})"));
    }
    // Radii within this of their predecessor are twins, merged after reading.
    let twins = COINCIDENT_SPAN * (c.radius[n - 1] - c.radius[0]).abs();
    for i in 0..n {
        let r = c.radius[i];
        if r < 0.0 {
            return Err(format!(
                "field {}: radius {r}{} is negative",
                c.field("radius", i),
                c.at(i)
            ));
        }
        if i > 0 && c.radius[i - 1] - r > twins {
            return Err(format!(
                "field {}: values must increase ({r} after {}{})",
                c.field("radius", i),
                c.radius[i - 1],
                c.at(i)
            ));
        }
        if c.chord[i] < 0.0 {
            return Err(format!(
                "field {}: chord {}{} is negative",
                c.field("chord", i),
                c.chord[i],
                c.at(i)
            ));
        }
        let p = c.pitch_axis[i];
        if !(0.0..=1.0).contains(&p) {
            return Err(format!(
                "field {}: {p}{} is outside [0, 1] (a fraction of the chord)",
                c.field("pitch_axis", i),
                c.at(i)
            ));
        }
    }
    if c.chord.iter().all(|&x| x == 0.0) {
        let f = match c.form {
            Form::Columns => "'chord'",
            Form::Stations => "'stations[..].chord'",
        };
        return Err(format!("field {f}: every chord is zero"));
    }
    Ok(())
}

/// A NACA code (4 or 5 digits, optionally after `NACA`, `naca`, `NACA-`: `NACA 4413`,
/// `naca0012`, `23012`) or else a file resolved against `base`; also the warnings of reading
/// the file.
fn resolve_aerofoil(spec: &str, base: &Path) -> std::result::Result<(Aerofoil, Vec<String>), String> {
    let t = spec.trim();
    let code = match t.get(..4) {
        Some(p) if p.eq_ignore_ascii_case("naca") => t[4..].trim_start_matches([' ', '-']),
        _ => t,
    };
    if (4..=5).contains(&code.len()) && code.chars().all(|c| c.is_ascii_digit()) {
        let naca = Naca::parse(code).map_err(|e| e.to_string())?;
        return Ok((Aerofoil::Naca(naca), Vec::new()));
    }
    if t.is_empty() {
        return Err("empty aerofoil name".into());
    }
    let path = base.join(t);
    if !path.is_file() {
        return Err(format!(
            "'{t}' is neither a NACA 4/5-digit code nor an existing file ({})",
            path.display()
        ));
    }
    let loaded = read_curve(&path).map_err(|e| e.to_string())?;
    let mut warnings = loaded.warnings;
    let (points, reversed) = unit_contour(loaded.points).map_err(|m| format!("{}: {m}", path.display()))?;
    if reversed {
        warnings.push("the points run clockwise (lower surface first); reversed into Selig order".into());
    }
    Ok((
        Aerofoil::File {
            path,
            name: loaded.name,
            points,
        },
        warnings,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn err(json: &str) -> String {
        Blade::from_json(json, Path::new("b.json"))
            .unwrap_err()
            .to_string()
    }

    #[test]
    fn both_forms_give_the_same_blade() {
        let a = Blade::from_json(
            r#"{"radius": [1, 2], "chord": [0.2, 0.1], "twist_deg": [5, 1], "aerofoil": "NACA 4413",
                "sweep": [0, 0.01]}"#,
            Path::new("b.json"),
        )
        .unwrap();
        let b = Blade::from_json(
            r#"{"aerofoil": "naca4413", "stations": [
                {"radius": 1, "chord": 0.2, "twist_deg": 5},
                {"radius": 2, "chord": 0.1, "twist_deg": 1, "sweep": 0.01, "pitch_axis": 0.25}]}"#,
            Path::new("b.json"),
        )
        .unwrap();
        assert_eq!(a.stations, b.stations);
        assert_eq!(a.aerofoils.len(), 1);
        assert_eq!(a.aerofoils[0].name(), "NACA 4413");
        assert_eq!(a.name, "b");
        assert_eq!(a.max_chord(), 0.2);
    }

    #[test]
    fn messages_name_the_field() {
        let base = r#""chord": [0.2, 0.1, 0.1], "twist_deg": 0, "aerofoil": "4413""#;
        let cases = [
            (format!(r#"{{"radius": [1, 3, 2], {base}}}"#), "field 'radius': values must increase (2 after 3 at index 2)"),
            (r#"{"radius": [1, 2], "chord": [1], "twist_deg": 0, "aerofoil": "4413"}"#.into(), "field 'chord': 1 values, but 'radius' has 2"),
            (r#"{"radius": [1, 2, 3], "chord": [0.2, -0.1, 0], "twist_deg": 0, "aerofoil": "4413"}"#.into(), "field 'chord': chord -0.1 at index 1 is negative"),
            (r#"{"radius": [1], "chord": [1], "twist_deg": 0, "aerofoil": "4413"}"#.into(), "field 'radius': at least 2 stations are needed (got 1)"),
            (format!(r#"{{"radius": [1, 2, 3], {}}}"#, base.replace("4413", "NACA 44x3")), "field 'aerofoil' at index 0:"),
            (format!(r#"{{"radius": [1, 2, 3], {}}}"#, base.replace("4413", "nope.dat")), "'nope.dat' is neither a NACA 4/5-digit code nor an existing file"),
            (format!(r#"{{"radius": [1, 2, 3], "twist": 1, {base}}}"#), "unknown field 'twist'"),
            (format!(r#"{{"radius": [1, 2, 3], "pitch_axis": 2, {base}}}"#), "field 'pitch_axis': 2 at index 0 is outside [0, 1]"),
            (r#"{"radius": [1, 2], "chord": 0, "twist_deg": 0, "aerofoil": "4413"}"#.into(), "field 'chord': every chord is zero"),
            (r#"{"radius": [1, 2], "chord": "big", "twist_deg": 0, "aerofoil": "4413"}"#.into(), "field 'chord': expected a number, found a string"),
            (r#"{"radius": [1, 2], "chord": 1, "aerofoil": "4413"}"#.into(), "field 'twist_deg' is missing"),
            (r#"{"stations": [{"radius": 1, "chord": 1, "twist_deg": 0, "aerofoil": "4413"}, {"radius": 0.5, "chord": 1, "twist_deg": 0, "aerofoil": "4413"}]}"#.into(), "field 'stations[1].radius': values must increase (0.5 after 1)"),
            (r#"{"stations": [{"radius": 1, "chord": 1, "twist_deg": 0}]}"#.into(), "field 'stations[0].aerofoil' is missing"),
            ("[1, 2]".into(), "expected a JSON object"),
            ("{\"radius\": [1,\n 2,]}".into(), "b.json:2: not valid JSON"),
        ];
        for (json, needle) in cases {
            let e = err(&json);
            assert!(e.contains(needle), "{json}\n  gave: {e}\n  want: {needle}");
            assert!(e.starts_with("b.json"), "{e}");
        }
    }
}
