//! windIO blade definitions (YAML): v1 (`components.blade.outer_shape_bem`) and v2
//! (`components.blade.outer_shape` with `components.blade.reference_axis`), read into a
//! [`Blade`] in the windIO blade-root frame ([`Axes::Turbine`]).
//!
//! Every distributed quantity is a `grid`/`values` pair over the normalised span `s ∈ [0, 1]`.
//! The stations are the union of the grids of chord, twist, pitch axis (v1) or
//! `section_offset_y` (v2), `section_offset_x`, relative thickness (v2), the three
//! reference-axis coordinates and the aerofoil positions, within the chord grid's range; each
//! quantity is interpolated there by PCHIP over its own grid (clamped to its end values outside
//! it), as WISDEM does. At a station:
//! - radius = reference axis `z`, prebend = `x` (towards the suction side; negative is
//!   upwind), sweep = `y` (towards the trailing edge), all in metres;
//! - twist: v1 radians, v2 degrees, positive towards feather (leading edge towards the pressure
//!   side); stored negated in degrees (see [`Axes::Turbine`]);
//! - pitch axis: v1 `pitch_axis` (chord fraction from the leading edge); v2
//!   `section_offset_y / chord` (`section_offset_y` is the distance in metres along the chord
//!   from the reference axis to the leading edge); v2 `section_offset_x` (metres, towards the
//!   suction side) is the [`Station::normal_offset`];
//! - shape: the blend of the master aerofoils by relative thickness ([`Blend::Thickness`]);
//!   the station's relative thickness is v2 `rthick`, or in v1 the masters' thickness
//!   interpolated by PCHIP over `airfoil_position.grid`.
//!
//! Sections lie in the planes `z = radius` (not turned normal to a curved reference axis).

use super::blade::{merge_coincident, unit_contour, Aerofoil, Axes, Blade, BladeFormat, Blend, Station};
use super::interp::Pchip;
use crate::error::{Error, Result};
use glam::DVec2;
use serde::Deserialize;
use serde_saphyr::Spanned;
use std::collections::HashMap;
use std::path::Path;

/// The parts of a windIO file the blade needs (everything else is ignored).
#[derive(Deserialize)]
struct Doc {
    #[serde(default)]
    name: Option<String>,
    #[serde(default)]
    components: Option<Components>,
    #[serde(default)]
    airfoils: Option<Vec<YamlAerofoil>>,
}

#[derive(Deserialize)]
struct Components {
    #[serde(default)]
    blade: Option<YamlBlade>,
}

#[derive(Deserialize)]
struct YamlBlade {
    #[serde(default)]
    outer_shape_bem: Option<V1Shape>,
    #[serde(default)]
    outer_shape: Option<V2Shape>,
    #[serde(default)]
    reference_axis: Option<Axis>,
}

#[derive(Deserialize)]
struct V1Shape {
    chord: Curve,
    twist: Curve,
    pitch_axis: Curve,
    reference_axis: Axis,
    airfoil_position: Positions,
}

#[derive(Deserialize)]
struct V2Shape {
    chord: Curve,
    twist: Curve,
    section_offset_y: Curve,
    #[serde(default)]
    section_offset_x: Option<Curve>,
    rthick: Curve,
    airfoils: Vec<V2Aerofoil>,
}

#[derive(Deserialize)]
struct V2Aerofoil {
    name: Spanned<String>,
    spanwise_position: Spanned<f64>,
}

#[derive(Deserialize)]
struct Curve {
    grid: Spanned<Vec<f64>>,
    values: Spanned<Vec<f64>>,
}

#[derive(Deserialize)]
struct Axis {
    x: Curve,
    y: Curve,
    z: Curve,
}

#[derive(Deserialize)]
struct Positions {
    grid: Spanned<Vec<f64>>,
    labels: Spanned<Vec<Spanned<String>>>,
}

#[derive(Deserialize)]
struct YamlAerofoil {
    name: Spanned<String>,
    coordinates: Coordinates,
    #[serde(default)]
    relative_thickness: Option<f64>,
    #[serde(default)]
    rthick: Option<f64>,
}

#[derive(Deserialize)]
struct Coordinates {
    x: Spanned<Vec<f64>>,
    y: Spanned<Vec<f64>>,
}

/// A parse error at `line` of `path`.
fn at(path: &Path, line: u64, message: String) -> Error {
    Error::Parse {
        path: path.to_path_buf(),
        line: usize::try_from(line).unwrap_or(usize::MAX).max(1),
        message,
    }
}

/// A checked `grid`/`values` pair and its PCHIP interpolant.
struct Checked {
    grid: Vec<f64>,
    fun: Pchip,
    /// The line of `values`.
    line: u64,
}

impl Checked {
    fn eval(&self, s: f64) -> f64 {
        self.fun.eval(s)
    }
}

/// Check one distributed quantity: equal lengths, at least two, finite, grid strictly
/// increasing inside [0, 1]. `field` names it in messages.
fn check(curve: &Curve, field: &str, path: &Path) -> Result<Checked> {
    let (g, v) = (&curve.grid.value, &curve.values.value);
    let gl = curve.grid.referenced.line();
    if g.len() != v.len() {
        return Err(at(
            path,
            gl,
            format!(
                "field '{field}': the grids differ in length ('grid' has {} values, 'values' {})",
                g.len(),
                v.len()
            ),
        ));
    }
    if g.len() < 2 {
        return Err(at(
            path,
            gl,
            format!("field '{field}': at least 2 values are needed (got {})", g.len()),
        ));
    }
    if let Some(i) = g.iter().position(|x| !(x.is_finite() && (0.0..=1.0).contains(x))) {
        return Err(at(
            path,
            gl,
            format!(
                "field '{field}.grid': value {} at index {i} is outside [0, 1]",
                g[i]
            ),
        ));
    }
    if let Some(i) = (1..g.len()).find(|&i| g[i] <= g[i - 1]) {
        return Err(at(
            path,
            gl,
            format!(
                "field '{field}.grid': the span does not increase ({} after {} at index {i})",
                g[i],
                g[i - 1]
            ),
        ));
    }
    if let Some(i) = v.iter().position(|x| !x.is_finite()) {
        return Err(at(
            path,
            curve.values.referenced.line(),
            format!("field '{field}.values': value at index {i} is not finite"),
        ));
    }
    Ok(Checked {
        grid: g.clone(),
        fun: Pchip::new(g, v),
        line: curve.values.referenced.line(),
    })
}

/// Read a windIO blade (v1 or v2) from YAML text; `path` names the file in messages.
pub(crate) fn read(text: &str, path: &Path) -> Result<Blade> {
    let doc: Doc = serde_saphyr::from_str(text).map_err(|e| {
        let line = e.location().map_or(1, |l| l.line());
        let message = e.without_snippet().to_string();
        let what = if text.lines().any(|l| l.starts_with("components:")) {
            "not a windIO blade"
        } else {
            "not a blade file (JSON, windIO YAML or an AeroDyn 15 primary file)"
        };
        at(
            path,
            line,
            format!("{what}: {}", message.lines().next().unwrap_or("").trim()),
        )
    })?;
    let bad = |message: String| Error::Input {
        path: path.to_path_buf(),
        message,
    };
    let blade = doc
        .components
        .and_then(|c| c.blade)
        .ok_or_else(|| bad("no 'components.blade': not a windIO turbine file".into()))?;
    let yaml_aerofoils = doc
        .airfoils
        .ok_or_else(|| bad("field 'airfoils' is missing (the aerofoil coordinates)".into()))?;
    let name = doc.name.unwrap_or_else(|| {
        path.file_stem()
            .map_or_else(String::new, |s| s.to_string_lossy().into_owned())
    });

    // The shape quantities and where the master aerofoils sit, per version.
    struct Shape {
        format: BladeFormat,
        prefix: &'static str,
        chord: Checked,
        twist_deg: Checked,
        pitch: Checked,
        offset_x: Option<Checked>,
        rthick: Option<Checked>,
        axis: [Checked; 3],
        /// (span position, label, line)
        placed: Vec<(f64, String, u64)>,
        /// How the span positions of the aerofoils are named in messages.
        placed_field: String,
    }
    let shape = match (blade.outer_shape_bem, blade.outer_shape) {
        (Some(v1), _) => {
            let p = "components.blade.outer_shape_bem";
            let twist_rad = check(&v1.twist, &format!("{p}.twist"), path)?;
            let twist_deg = Checked {
                fun: Pchip::new(
                    &twist_rad.grid,
                    &v1.twist
                        .values
                        .value
                        .iter()
                        .map(|t| t.to_degrees())
                        .collect::<Vec<_>>(),
                ),
                ..twist_rad
            };
            let pos = &v1.airfoil_position;
            let (g, labels) = (&pos.grid.value, &pos.labels.value);
            if g.len() != labels.len() {
                return Err(at(
                    path,
                    pos.grid.referenced.line(),
                    format!(
                        "field '{p}.airfoil_position': the grids differ in length ('grid' has {} values, 'labels' {})",
                        g.len(),
                        labels.len()
                    ),
                ));
            }
            Shape {
                format: BladeFormat::WindIo1,
                prefix: p,
                chord: check(&v1.chord, &format!("{p}.chord"), path)?,
                twist_deg,
                pitch: check(&v1.pitch_axis, &format!("{p}.pitch_axis"), path)?,
                offset_x: None,
                rthick: None,
                axis: [
                    check(&v1.reference_axis.x, &format!("{p}.reference_axis.x"), path)?,
                    check(&v1.reference_axis.y, &format!("{p}.reference_axis.y"), path)?,
                    check(&v1.reference_axis.z, &format!("{p}.reference_axis.z"), path)?,
                ],
                placed_field: format!("{p}.airfoil_position.grid"),
                placed: g
                    .iter()
                    .zip(labels)
                    .map(|(&s, l)| (s, l.value.clone(), l.referenced.line()))
                    .collect(),
            }
        }
        (None, Some(v2)) => {
            let p = "components.blade.outer_shape";
            let axis = blade
                .reference_axis
                .ok_or_else(|| bad("field 'components.blade.reference_axis' is missing".into()))?;
            let offset_x = match &v2.section_offset_x {
                Some(c) => Some(check(c, &format!("{p}.section_offset_x"), path)?),
                None => None,
            };
            Shape {
                format: BladeFormat::WindIo2,
                prefix: p,
                chord: check(&v2.chord, &format!("{p}.chord"), path)?,
                twist_deg: check(&v2.twist, &format!("{p}.twist"), path)?,
                pitch: check(&v2.section_offset_y, &format!("{p}.section_offset_y"), path)?,
                offset_x,
                rthick: Some(check(&v2.rthick, &format!("{p}.rthick"), path)?),
                axis: [
                    check(&axis.x, "components.blade.reference_axis.x", path)?,
                    check(&axis.y, "components.blade.reference_axis.y", path)?,
                    check(&axis.z, "components.blade.reference_axis.z", path)?,
                ],
                placed_field: format!("{p}.airfoils[..].spanwise_position"),
                placed: v2
                    .airfoils
                    .iter()
                    .map(|a| {
                        (
                            a.spanwise_position.value,
                            a.name.value.clone(),
                            a.name.referenced.line(),
                        )
                    })
                    .collect(),
            }
        }
        (None, None) => {
            return Err(bad(
                "components.blade has neither 'outer_shape_bem' (windIO v1) nor 'outer_shape' (windIO v2)"
                    .into(),
            ))
        }
    };
    let p = shape.prefix;
    if shape.placed.is_empty() {
        return Err(bad(format!(
            "field '{p}': no aerofoils are placed along the span"
        )));
    }
    for w in shape.placed.windows(2) {
        if w[1].0.partial_cmp(&w[0].0) != Some(std::cmp::Ordering::Greater) {
            return Err(at(
                path,
                w[1].2,
                format!(
                    "field '{}': the span does not increase ({} after {}, aerofoil '{}')",
                    shape.placed_field, w[1].0, w[0].0, w[1].1
                ),
            ));
        }
    }

    // The master aerofoils the span uses, in order of first use.
    let by_name: HashMap<&str, &YamlAerofoil> = yaml_aerofoils
        .iter()
        .map(|a| (a.name.value.as_str(), a))
        .collect();
    let mut aerofoils: Vec<Aerofoil> = Vec::new();
    let mut thickness: Vec<f64> = Vec::new();
    let mut index: HashMap<String, usize> = HashMap::new();
    let mut placed_index = Vec::with_capacity(shape.placed.len());
    for (_, label, line) in &shape.placed {
        if let Some(&k) = index.get(label) {
            placed_index.push(k);
            continue;
        }
        let a = by_name.get(label.as_str()).ok_or_else(|| {
            let mut known: Vec<&str> = by_name.keys().copied().collect();
            known.sort_unstable();
            at(
                path,
                *line,
                format!(
                    "unknown aerofoil label '{label}' (the file's 'airfoils' are: {})",
                    known.join(", ")
                ),
            )
        })?;
        let (x, y) = (&a.coordinates.x, &a.coordinates.y);
        let field = format!("airfoils '{label}'.coordinates");
        if x.value.len() != y.value.len() {
            return Err(at(
                path,
                x.referenced.line(),
                format!(
                    "field {field}: the grids differ in length ('x' has {} values, 'y' {})",
                    x.value.len(),
                    y.value.len()
                ),
            ));
        }
        let points: Vec<DVec2> = x
            .value
            .iter()
            .zip(&y.value)
            .map(|(&x, &y)| DVec2::new(x, y))
            .collect();
        let (points, _) =
            unit_contour(points).map_err(|m| at(path, x.referenced.line(), format!("field {field}: {m}")))?;
        let t = a.relative_thickness.or(a.rthick).ok_or_else(|| {
            at(
                path,
                a.name.referenced.line(),
                format!(
                    "aerofoil '{label}': no relative thickness ('relative_thickness' in v1, 'rthick' in v2)"
                ),
            )
        })?;
        if !(t.is_finite() && t > 0.0) {
            return Err(at(
                path,
                a.name.referenced.line(),
                format!("aerofoil '{label}': relative thickness {t} is not positive"),
            ));
        }
        aerofoils.push(Aerofoil::File {
            path: path.to_path_buf(),
            name: label.clone(),
            points,
        });
        thickness.push(t);
        index.insert(label.clone(), aerofoils.len() - 1);
        placed_index.push(aerofoils.len() - 1);
    }

    // Stations: the union of every grid, inside the chord grid's range.
    let (lo, hi) = (shape.chord.grid[0], shape.chord.grid[shape.chord.grid.len() - 1]);
    let mut s: Vec<f64> = [&shape.chord, &shape.twist_deg, &shape.pitch]
        .into_iter()
        .chain(shape.axis.iter())
        .chain(shape.offset_x.iter())
        .chain(shape.rthick.iter())
        .flat_map(|c| c.grid.iter().copied())
        .chain(shape.placed.iter().map(|p| p.0))
        .filter(|&x| (lo..=hi).contains(&x))
        .collect();
    s.sort_by(f64::total_cmp);
    s.dedup_by(|a, b| (*a - *b).abs() <= 1e-12);

    // Relative thickness along the span.
    let rthick_fn = match shape.rthick {
        Some(c) => c.fun,
        None if shape.placed.len() >= 2 => Pchip::new(
            &shape.placed.iter().map(|p| p.0).collect::<Vec<_>>(),
            &placed_index.iter().map(|&k| thickness[k]).collect::<Vec<_>>(),
        ),
        None => Pchip::new(&[0.0, 1.0], &[thickness[placed_index[0]]; 2]),
    };
    // The masters by thickness: unique thickness, the first placed kept.
    let mut masters: Vec<(f64, usize)> = Vec::new();
    for &k in &placed_index {
        if !masters.iter().any(|m| m.0 == thickness[k]) {
            masters.push((thickness[k], k));
        }
    }
    masters.sort_by(|a, b| a.0.total_cmp(&b.0));

    let mut stations = Vec::with_capacity(s.len());
    let mut rthick = Vec::with_capacity(s.len());
    for &si in &s {
        let chord = shape.chord.eval(si);
        if chord < 0.0 {
            return Err(at(
                path,
                shape.chord.line,
                format!("field '{p}.chord': chord {chord} at span {si} is negative"),
            ));
        }
        let pitch_axis = match shape.format {
            BladeFormat::WindIo2 if chord > 0.0 => shape.pitch.eval(si) / chord,
            BladeFormat::WindIo2 => 0.5,
            _ => shape.pitch.eval(si),
        };
        let t = rthick_fn.eval(si);
        let nearest = masters
            .iter()
            .min_by(|a, b| (a.0 - t).abs().total_cmp(&(b.0 - t).abs()))
            .map_or(0, |m| m.1);
        rthick.push(t);
        stations.push(Station {
            radius: shape.axis[2].eval(si),
            chord,
            twist_deg: -shape.twist_deg.eval(si),
            aerofoil: nearest,
            pitch_axis,
            prebend: shape.axis[0].eval(si),
            sweep: shape.axis[1].eval(si),
            normal_offset: shape.offset_x.as_ref().map_or(0.0, |c| c.eval(si)),
        });
    }
    let notes = merge_coincident(&mut stations, Some(&mut rthick), |k| {
        format!("the station at s = {}", s[k])
    })
    .map_err(|(_, m)| at(path, shape.axis[2].line, format!("field 'reference_axis.z': {m}")))?;
    if stations.len() < 2 {
        return Err(bad(format!("field '{p}.chord': at least 2 stations are needed")));
    }
    for w in stations.windows(2) {
        if w[1].radius.partial_cmp(&w[0].radius) != Some(std::cmp::Ordering::Greater) {
            return Err(at(
                path,
                shape.axis[2].line,
                format!(
                    "field 'reference_axis.z': the span does not increase (z = {} after {})",
                    w[1].radius, w[0].radius
                ),
            ));
        }
    }
    if stations.iter().all(|st| st.chord == 0.0) {
        return Err(bad(format!("field '{p}.chord': every chord is zero")));
    }
    Ok(Blade {
        name,
        stations,
        aerofoils,
        warnings: Vec::new(),
        notes: notes.into_iter().collect(),
        format: shape.format,
        axes: Axes::Turbine,
        blend: Blend::Thickness { masters, rthick },
    })
}
