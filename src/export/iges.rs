//! IGES 5.3 text: every curve a rational B-spline curve entity (type 126, polynomial: all
//! weights 1) and every surface a rational B-spline surface entity (type 128), each an
//! independent entity, in the fixed 80-column layout (Start, Global, Directory Entry,
//! Parameter Data and Terminate sections).

use super::bspline::{BsplineCurve, BsplineSurface, CadShape, CadUnit};
use super::step::real;
use crate::error::{Error, Result};

/// An IGES Hollerith string (`nHtext`), printable ASCII only (others become `_`).
fn hollerith(s: &str) -> String {
    let t: String = s
        .chars()
        .map(|c| if (' '..='~').contains(&c) { c } else { '_' })
        .collect();
    format!("{}H{t}", t.len())
}

/// Lay out `fields` (delimited by `,`, the last followed by `;`) in lines of at most `width`
/// characters, breaking only after a delimiter.
fn wrap(fields: &[String], width: usize) -> Vec<String> {
    let mut lines = Vec::new();
    let mut line = String::new();
    for (k, f) in fields.iter().enumerate() {
        let piece = format!("{f}{}", if k + 1 == fields.len() { ';' } else { ',' });
        if !line.is_empty() && line.len() + piece.len() > width {
            lines.push(std::mem::take(&mut line));
        }
        line.push_str(&piece);
    }
    if !line.is_empty() {
        lines.push(line);
    }
    lines
}

fn curve_params(c: &BsplineCurve) -> Vec<String> {
    let planar = c.ctrl.iter().all(|p| p.z == 0.0);
    let mut f = vec![
        "126".to_string(),
        (c.ctrl.len() - 1).to_string(),
        c.degree.to_string(),
        u8::from(planar).to_string(),
        "0".into(),
        "1".into(),
        "0".into(),
    ];
    f.extend(c.knots.iter().map(|k| real(*k)));
    f.extend(c.ctrl.iter().map(|_| "1.".to_string()));
    for p in &c.ctrl {
        f.extend([real(p.x), real(p.y), real(p.z)]);
    }
    f.extend([real(c.knots[0]), real(c.knots[c.knots.len() - 1])]);
    let normal = if planar {
        ["0.", "0.", "1."]
    } else {
        ["0.", "0.", "0."]
    };
    f.extend(normal.iter().map(ToString::to_string));
    f
}

fn surface_params(s: &BsplineSurface) -> Vec<String> {
    let mut f = vec![
        "128".to_string(),
        (s.count[0] - 1).to_string(),
        (s.count[1] - 1).to_string(),
        s.degree[0].to_string(),
        s.degree[1].to_string(),
        "0".into(),
        "0".into(),
        "1".into(),
        "0".into(),
        "0".into(),
    ];
    f.extend(s.knots_u.iter().map(|k| real(*k)));
    f.extend(s.knots_v.iter().map(|k| real(*k)));
    f.extend(s.ctrl.iter().map(|_| "1.".to_string()));
    // The first (u) index runs fastest.
    for j in 0..s.count[1] {
        for i in 0..s.count[0] {
            let p = s.at(i, j);
            f.extend([real(p.x), real(p.y), real(p.z)]);
        }
    }
    f.extend([
        real(s.knots_u[0]),
        real(s.knots_u[s.knots_u.len() - 1]),
        real(s.knots_v[0]),
        real(s.knots_v[s.knots_v.len() - 1]),
    ]);
    f
}

/// The IGES file of `shapes` (in metres) in `unit`, named `name`, dated `timestamp`
/// (`YYYY-MM-DDThh:mm:ss`).
pub fn iges_text(shapes: &[CadShape], unit: CadUnit, name: &str, timestamp: &str) -> Result<String> {
    let shapes: Vec<CadShape> = shapes.iter().map(|s| s.in_unit(unit)).collect();
    if shapes.is_empty() {
        return Err(Error::invalid("nothing to export"));
    }
    let date: String = timestamp.chars().filter(char::is_ascii_digit).collect::<String>();
    let date = if date.len() == 14 {
        format!("{}.{}", &date[..8], &date[8..])
    } else {
        "19700101.000000".to_string()
    };
    let largest = shapes
        .iter()
        .flat_map(|s| match s {
            CadShape::Curve(c) => c.ctrl.clone(),
            CadShape::Surface(s) => s.ctrl.clone(),
        })
        .map(|p| p.abs().max_element())
        .fold(0.0, f64::max);
    let (flag, unit_name) = match unit {
        CadUnit::Metre => ("6", "M"),
        CadUnit::Millimetre => ("2", "MM"),
    };
    let version = format!("bezchain {}", env!("CARGO_PKG_VERSION"));
    let global: Vec<String> = vec![
        "1H,".into(),
        "1H;".into(),
        hollerith(name),
        hollerith(&format!("{name}.igs")),
        hollerith(&version),
        hollerith(&version),
        "32".into(),
        "38".into(),
        "6".into(),
        "308".into(),
        "15".into(),
        hollerith(name),
        "1.".into(),
        flag.into(),
        hollerith(unit_name),
        "1".into(),
        "1.".into(),
        hollerith(&date),
        real(unit.resolution()),
        real(largest),
        hollerith("bezchain"),
        String::new(),
        "11".into(),
        "0".into(),
        hollerith(&date),
        String::new(),
    ];

    let mut out = String::new();
    let line = |out: &mut String, data: &str, section: char, seq: usize| {
        out.push_str(&format!("{data:<72}{section}{seq:07}\n"));
    };
    line(&mut out, "bezchain B-spline export", 'S', 1);
    let global_lines = wrap(&global, 72);
    for (k, l) in global_lines.iter().enumerate() {
        line(&mut out, l, 'G', k + 1);
    }
    // Parameter data first (its line numbers go into the directory entries).
    let mut params: Vec<(u32, Vec<String>)> = Vec::with_capacity(shapes.len());
    for s in &shapes {
        params.push(match s {
            CadShape::Curve(c) => (126, wrap(&curve_params(c), 64)),
            CadShape::Surface(s) => (128, wrap(&surface_params(s), 64)),
        });
    }
    let mut p_start = 1;
    let mut d_lines = Vec::with_capacity(2 * shapes.len());
    for (k, (kind, lines)) in params.iter().enumerate() {
        d_lines.push(format!(
            "{kind:>8}{p_start:>8}{:>8}{:>8}{:>8}{:>8}{:>8}{:>8}{}",
            0, 0, 0, 0, 0, 0, "00000000"
        ));
        d_lines.push(format!(
            "{kind:>8}{:>8}{:>8}{:>8}{:>8}{:>8}{:>8}{:>8}{:>8}",
            0,
            0,
            lines.len(),
            0,
            "",
            "",
            if *kind == 126 { "BSPLINE" } else { "BSURFACE" },
            k + 1
        ));
        p_start += lines.len();
    }
    for (k, l) in d_lines.iter().enumerate() {
        line(&mut out, l, 'D', k + 1);
    }
    let mut seq = 0;
    for (k, (_, lines)) in params.iter().enumerate() {
        let de = 2 * k + 1;
        for l in lines {
            seq += 1;
            out.push_str(&format!("{l:<64} {de:>7}P{seq:07}\n"));
        }
    }
    let t = format!(
        "S{:>7}G{:>7}D{:>7}P{:>7}",
        1,
        global_lines.len(),
        d_lines.len(),
        seq
    );
    line(&mut out, &t, 'T', 1);
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    /// Read back the parameters of every entity: `(type, numbers)`, from the fixed layout.
    fn read_back(text: &str) -> Vec<(u32, Vec<f64>)> {
        let lines: Vec<&str> = text.lines().collect();
        assert!(lines.iter().all(|l| l.len() == 80), "every line is 80 columns");
        let d: Vec<&str> = lines.iter().filter(|l| &l[72..73] == "D").copied().collect();
        let p: Vec<&str> = lines.iter().filter(|l| &l[72..73] == "P").copied().collect();
        d.chunks(2)
            .map(|de| {
                let kind: u32 = de[0][0..8].trim().parse().unwrap();
                let start: usize = de[0][8..16].trim().parse().unwrap();
                let count: usize = de[1][24..32].trim().parse().unwrap();
                let data: String = p[start - 1..start - 1 + count].iter().map(|l| &l[..64]).collect();
                let data = data.trim().trim_end_matches(';');
                let nums: Vec<f64> = data.split(',').map(|f| f.trim().parse().unwrap()).collect();
                assert_eq!(nums[0] as u32, kind);
                (kind, nums)
            })
            .collect()
    }

    #[test]
    fn a_curve_and_a_surface_read_back_from_the_fixed_layout() {
        let curve = BsplineCurve {
            degree: 2,
            knots: vec![0.0, 0.0, 0.0, 0.5, 1.0, 1.0, 1.0],
            ctrl: vec![
                DVec3::ZERO,
                DVec3::new(1.0, 2.0, 0.0),
                DVec3::new(2.0, -1.0, 0.0),
                DVec3::new(3.0, 0.1, 0.0),
            ],
        };
        let surface = BsplineSurface {
            degree: [1, 1],
            knots_u: vec![0.0, 0.0, 1.0, 1.0],
            knots_v: vec![0.0, 0.0, 0.5, 1.0, 1.0],
            count: [2, 3],
            ctrl: (0..6)
                .map(|k| DVec3::new((k / 3) as f64, (k % 3) as f64, 0.1 * k as f64))
                .collect(),
        };
        let text = iges_text(
            &[CadShape::Curve(curve.clone()), CadShape::Surface(surface.clone())],
            CadUnit::Metre,
            "test",
            "2026-01-02T03:04:05",
        )
        .unwrap();
        assert!(text.contains("15H20260102.030405"));
        let back = read_back(&text);
        assert_eq!(back.len(), 2);
        let c = &back[0].1;
        assert_eq!(
            (c[1], c[2], c[3], c[5]),
            (3.0, 2.0, 1.0, 1.0),
            "K, M, planar, polynomial"
        );
        assert_eq!(&c[7..14], &curve.knots[..]);
        assert_eq!(&c[14..18], &[1.0; 4]);
        assert_eq!(&c[18..21], &[0.0, 0.0, 0.0]);
        assert_eq!(&c[21..24], &[1.0, 2.0, 0.0]);
        let s = &back[1].1;
        assert_eq!((s[1], s[2], s[3], s[4]), (1.0, 2.0, 1.0, 1.0), "K1, K2, M1, M2");
        assert_eq!(&s[10..14], &surface.knots_u[..]);
        assert_eq!(&s[14..19], &surface.knots_v[..]);
        // Points after 6 weights, u fastest: (0,0), (1,0), (0,1), ...
        let pts = &s[25..43];
        assert_eq!(&pts[3..6], &surface.at(1, 0).to_array());
        assert_eq!(&pts[6..9], &surface.at(0, 1).to_array());
        let t = text.lines().last().unwrap();
        assert!(t.starts_with("S      1G") && t.ends_with("T0000001"), "{t}");
    }
}
