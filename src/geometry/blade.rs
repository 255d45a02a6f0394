//! The blade model every reader fills: stations (radius, chord, twist, aerofoil, pitch axis,
//! prebend, sweep), the aerofoils they use, the axes and the blending between stations; and the
//! check that puts an aerofoil contour into chord fractions and Selig order. The readers:
//! [`super::blade_read`] (format detection, bezchain's own JSON), [`super::windio`] and
//! [`super::aerodyn`].

use super::naca::{Naca, NacaOptions};
use crate::error::Result;
use glam::DVec2;
use std::path::PathBuf;

/// Pitch-axis position used when a blade file gives none (fraction of the chord from the LE).
pub const DEFAULT_PITCH_AXIS: f64 = 0.25;

/// Points per section of a NACA aerofoil when the caller asks for no particular number.
pub const DEFAULT_NACA_POINTS: usize = 82;

/// The section shape of one or more stations.
#[derive(Clone, Debug, PartialEq)]
pub enum Aerofoil {
    /// A NACA 4- or 5-digit section, generated (82 points unless asked otherwise).
    Naca(Naca),
    /// Points read from a `.dat`/CSV file, Selig order, in chord fractions.
    File {
        /// The file, resolved against the blade file's folder.
        path: PathBuf,
        /// The file's name line (or stem).
        name: String,
        /// The contour, Selig order, unit chord.
        points: Vec<DVec2>,
    },
}

impl Aerofoil {
    /// A short name: `NACA 4413` or the file's name line.
    #[must_use]
    pub fn name(&self) -> String {
        match self {
            Aerofoil::Naca(n) => n.name(),
            Aerofoil::File { name, .. } => name.clone(),
        }
    }

    /// The number of points the aerofoil has of its own: 82 for NACA, the file's count.
    #[must_use]
    pub fn native_points(&self) -> usize {
        match self {
            Aerofoil::Naca(_) => DEFAULT_NACA_POINTS,
            Aerofoil::File { points, .. } => points.len(),
        }
    }

    /// The contour with `n` points, Selig order, unit chord. `alike` asks for the common
    /// arc-length sampling (for blending with other aerofoils); otherwise a NACA section is
    /// regenerated with its own cosine spacing and a file is kept as is when `n` matches it.
    pub(crate) fn sample(&self, n: usize, alike: bool) -> Result<Vec<DVec2>> {
        match self {
            Aerofoil::Naca(naca) if !alike => naca.contour(&NacaOptions {
                points: n,
                ..NacaOptions::default()
            }),
            Aerofoil::Naca(naca) => {
                let dense = naca.contour(&NacaOptions {
                    points: 2001,
                    ..NacaOptions::default()
                })?;
                Ok(super::interp::resample_contour(&dense, n))
            }
            Aerofoil::File { points, .. } if points.len() == n && !alike => Ok(points.clone()),
            Aerofoil::File { points, .. } => Ok(super::interp::resample_contour(points, n)),
        }
    }
}

/// One spanwise station of a blade.
#[derive(Clone, Debug, PartialEq)]
pub struct Station {
    /// Distance from the rotation axis along z (model units, e.g. metres).
    pub radius: f64,
    /// Chord length (model units); 0 collapses the section to a point.
    pub chord: f64,
    /// Twist in degrees; positive raises the leading edge (towards +y).
    pub twist_deg: f64,
    /// Index of the section shape in [`Blade::aerofoils`].
    pub aerofoil: usize,
    /// Pitch-axis position as a fraction of the chord from the leading edge (default 0.25).
    pub pitch_axis: f64,
    /// Offset of the pitch axis along +y (out of the rotor plane), model units (default 0).
    pub prebend: f64,
    /// Offset of the pitch axis along +x (in the rotor plane, towards the trailing edge),
    /// model units (default 0).
    pub sweep: f64,
    /// Offset of the chord line from the pitch axis along the section's thickness direction
    /// (towards the upper surface), model units (default 0): windIO v2 `section_offset_x`, or
    /// an AeroDyn reference point off the chord line.
    pub normal_offset: f64,
}

/// The file format a blade was read from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BladeFormat {
    /// bezchain's JSON blade.
    Json,
    /// windIO v1 (`components.blade.outer_shape_bem`).
    WindIo1,
    /// windIO v2 (`components.blade.outer_shape` and `components.blade.reference_axis`).
    WindIo2,
    /// An OpenFAST AeroDyn 15 primary file with its blade, polar and coordinate files.
    AeroDyn15,
}

impl std::fmt::Display for BladeFormat {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            BladeFormat::Json => "JSON blade",
            BladeFormat::WindIo1 => "windIO v1",
            BladeFormat::WindIo2 => "windIO v2",
            BladeFormat::AeroDyn15 => "AeroDyn 15",
        })
    }
}

/// The axes a blade is lofted in. Both have the span along +z and sections in planes
/// `z = radius`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Axes {
    /// bezchain's section axes (JSON blades): x along the chord (leading edge → trailing edge at
    /// zero twist), y the thickness direction (upper surface towards +y). `sweep` is along +x,
    /// `prebend` along +y, and a positive twist raises the leading edge towards +y.
    #[default]
    Section,
    /// The blade-root frame of windIO and OpenFAST (right-handed): x towards the suction side
    /// (flapwise, downwind; prebend), y towards the trailing edge (edgewise; sweep). The same
    /// section placed in [`Axes::Section`] has its x and y swapped, which mirrors it into the
    /// real blade. Station twists are kept in the [`Axes::Section`] sense, so the readers store
    /// minus the files' twist (positive towards feather: leading edge towards the pressure
    /// side).
    Turbine,
}

/// How section shapes between stations are made.
#[derive(Clone, Debug, Default, PartialEq)]
pub enum Blend {
    /// Each station uses its own aerofoil as is (JSON, AeroDyn); sections between stations
    /// (`--sections`) interpolate point by point over the radius (monotone cubic, PCHIP) between
    /// the stations' shapes, all resampled alike.
    #[default]
    Radius,
    /// windIO's rule, as WISDEM applies it: every section's shape is interpolated point by point
    /// over relative thickness (PCHIP) between the master aerofoils, all resampled alike; the
    /// result's leading edge (smallest x) is moved to the origin and its x extent scaled to 1.
    Thickness {
        /// `(relative thickness, index into Blade::aerofoils)` of the masters used, thickness
        /// strictly increasing (of two masters with the same thickness the first placed along
        /// the span is kept).
        masters: Vec<(f64, usize)>,
        /// The relative thickness at every station.
        rthick: Vec<f64>,
    },
}

/// A blade: stations sorted by radius and the aerofoils they use.
#[derive(Clone, Debug, PartialEq)]
pub struct Blade {
    /// The file's `name`, or its stem.
    pub name: String,
    /// At least two stations, radii strictly increasing.
    pub stations: Vec<Station>,
    /// The distinct section shapes.
    pub aerofoils: Vec<Aerofoil>,
    /// Repairs made while reading aerofoil files, for the caller to show.
    pub warnings: Vec<String>,
    /// What the reader did that changes nothing of the shape (stations merged), for the caller
    /// to show.
    pub notes: Vec<String>,
    /// The format the blade was read from.
    pub format: BladeFormat,
    /// The axes the blade is lofted in.
    pub axes: Axes,
    /// How shapes between stations are made.
    pub blend: Blend,
}

impl Blade {
    /// The largest chord of any station (positive for a validated blade).
    #[must_use]
    pub fn max_chord(&self) -> f64 {
        self.stations.iter().map(|s| s.chord).fold(0.0, f64::max)
    }
}

/// Stations whose radii differ by at most this fraction of the span (the last radius less
/// the first) are one station: blade files list such twins where grids of different
/// quantities meet (windIO grids 6.5e-9 m apart on a 61.5 m blade), and a loft through both
/// would bend between them.
pub const COINCIDENT_SPAN: f64 = 1e-6;

/// Merge the stations of `stations` (sorted by radius, each no further below its predecessor
/// than the tolerance) that coincide with their predecessor within [`COINCIDENT_SPAN`] of the
/// span, keeping the first of each run; `rthick`, where the blend keeps one value a station,
/// is merged alike. Twins must describe the same section: chord, pitch axis, prebend, sweep,
/// normal offset and the twist's swing at the chord (`chord × Δtwist`) within the tolerance,
/// the same aerofoil (the same relative thickness within 1e-6 when `rthick` is given).
/// Otherwise the error is the second twin's index and a message naming both, through `name`
/// (a station in the file's terms). Returns the note line to show when any were merged.
pub(crate) fn merge_coincident(
    stations: &mut Vec<Station>,
    rthick: Option<&mut Vec<f64>>,
    name: impl Fn(usize) -> String,
) -> std::result::Result<Option<String>, (usize, String)> {
    let (Some(first), Some(last)) = (stations.first(), stations.last()) else {
        return Ok(None);
    };
    let tol = COINCIDENT_SPAN * (last.radius - first.radius).abs();
    let mut keep = vec![true; stations.len()];
    let mut kept = 0;
    for k in 1..stations.len() {
        let (a, b) = (&stations[kept], &stations[k]);
        if b.radius - a.radius > tol {
            kept = k;
            continue;
        }
        let swing = 0.5 * (a.chord + b.chord) * (a.twist_deg - b.twist_deg).abs().to_radians();
        let lengths = [
            ("chord", a.chord, b.chord),
            ("pitch axis", a.pitch_axis * a.chord, b.pitch_axis * b.chord),
            ("prebend", a.prebend, b.prebend),
            ("sweep", a.sweep, b.sweep),
            ("normal offset", a.normal_offset, b.normal_offset),
        ];
        let differ = lengths
            .iter()
            .find(|(_, x, y)| (x - y).abs() > tol)
            .map(|(what, x, y)| format!("{what} {x} against {y}"))
            .or_else(|| {
                (swing > tol).then(|| format!("twist {} against {} degrees", a.twist_deg, b.twist_deg))
            })
            .or_else(|| match rthick.as_deref() {
                Some(t) if (t[kept] - t[k]).abs() > 1e-6 => {
                    Some(format!("relative thickness {} against {}", t[kept], t[k]))
                }
                None if a.aerofoil != b.aerofoil => Some("different aerofoils".to_string()),
                _ => None,
            });
        if let Some(d) = differ {
            return Err((
                k,
                format!(
                    "{} (r = {}) and {} (r = {}) lie at the same span (within {COINCIDENT_SPAN:e} of it) but \
                 differ: {d}",
                    name(kept),
                    a.radius,
                    name(k),
                    b.radius
                ),
            ));
        }
        keep[k] = false;
    }
    let merged: Vec<f64> = (0..stations.len())
        .filter(|&k| !keep[k])
        .map(|k| stations[k].radius)
        .collect();
    if merged.is_empty() {
        return Ok(None);
    }
    let mut flags = keep.iter();
    stations.retain(|_| *flags.next().unwrap_or(&true));
    if let Some(t) = rthick {
        let mut flags = keep.iter();
        t.retain(|_| *flags.next().unwrap_or(&true));
    }
    let shown: Vec<String> = merged.iter().take(4).map(|r| format!("{r}")).collect();
    let more = if merged.len() > 4 { ", …" } else { "" };
    Ok(Some(format!(
        "merged {} station(s) into the one before, within {COINCIDENT_SPAN:e} of the span (r = {}{more})",
        merged.len(),
        shown.join(", ")
    )))
}

/// An aerofoil contour in chord fractions, checked and put into Selig order (trailing edge →
/// upper surface → leading edge → lower surface → trailing edge): the orientation is decided by
/// the signed area of the closed contour (counter-clockwise is Selig order), never assumed;
/// a clockwise contour is reversed (the returned flag says so). Fails, with a message, when
/// the x range is not chord fractions or the contour encloses no area.
pub(crate) fn unit_contour(mut points: Vec<DVec2>) -> std::result::Result<(Vec<DVec2>, bool), String> {
    if points.len() < 3 {
        return Err(format!(
            "an aerofoil needs at least 3 points (got {})",
            points.len()
        ));
    }
    if let Some(p) = points.iter().find(|p| !p.is_finite()) {
        return Err(format!("a point is not finite ({p})"));
    }
    let (lo, hi) = points
        .iter()
        .fold((f64::MAX, f64::MIN), |(lo, hi), p| (lo.min(p.x), hi.max(p.x)));
    if !(-0.1..=0.1).contains(&lo) || !(0.9..=1.1).contains(&hi) {
        return Err(format!(
            "x runs from {lo} to {hi}; expected chord fractions (leading edge near 0, trailing edge near 1)"
        ));
    }
    let area = super::twice_signed_area(&points);
    if area.abs() <= 1e-12 {
        return Err("the contour encloses no area (is it a camber line or one surface only?)".into());
    }
    let reversed = area < 0.0;
    if reversed {
        points.reverse();
    }
    Ok((points, reversed))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn orientation_is_decided_by_the_signed_area() {
        // Selig order of a thin symmetric lens: upper TE → LE → lower TE, counter-clockwise.
        let selig: Vec<DVec2> = (0..=20)
            .map(|i| {
                let t = std::f64::consts::TAU * i as f64 / 20.0;
                DVec2::new(0.5 + 0.5 * t.cos(), 0.06 * t.sin())
            })
            .collect();
        let (same, flipped) = unit_contour(selig.clone()).unwrap();
        assert!(!flipped);
        assert_eq!(same, selig);
        let mut reversed = selig.clone();
        reversed.reverse();
        let (back, flipped) = unit_contour(reversed).unwrap();
        assert!(flipped);
        assert_eq!(back, selig);
        // Upper surface first means +y right after the trailing edge.
        assert!(back[3].y > 0.0);
        let flat: Vec<DVec2> = (0..5)
            .map(|i| DVec2::new(1.0 - i as f64 / 4.0, 0.0))
            .chain([DVec2::X])
            .collect();
        assert!(unit_contour(flat).unwrap_err().contains("no area"));
    }
}
