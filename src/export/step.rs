//! STEP AP214 (ISO 10303-21, `AUTOMOTIVE_DESIGN`) text, laid out the way OpenCASCADE's
//! STEPControl_Writer lays out one part: a `PRODUCT` with its definition, a shape
//! representation with a unit and uncertainty context, and
//! - curves: a `GEOMETRICALLY_BOUNDED_WIREFRAME_SHAPE_REPRESENTATION` holding a
//!   `GEOMETRIC_CURVE_SET` of `TRIMMED_CURVE`s of `B_SPLINE_CURVE_WITH_KNOTS`;
//! - surfaces: a `MANIFOLD_SURFACE_SHAPE_REPRESENTATION` holding a `SHELL_BASED_SURFACE_MODEL`,
//!   one `OPEN_SHELL` per surface with one `ADVANCED_FACE` on a `B_SPLINE_SURFACE_WITH_KNOTS`,
//!   bounded by its four boundary edges (each a `SURFACE_CURVE`: the boundary's B-spline and
//!   its parameter line).
//!
//! Numbers are written in shortest round-trip form, so a reader gets the f64 values back.

use super::bspline::{distinct_knots, BsplineCurve, BsplineSurface, CadShape, CadUnit};
use crate::error::{Error, Result};
use glam::DVec3;
use std::fmt::Write as _;

/// A STEP real: the shortest round-trip digits, always with a decimal point and an exponent
/// (`1.5E-3`, `0.E0`).
pub(crate) fn real(x: f64) -> String {
    let s = format!("{x:e}");
    let (mantissa, exp) = s.split_once('e').unwrap_or((&s, "0"));
    let mantissa = if mantissa.contains('.') {
        mantissa.to_string()
    } else {
        format!("{mantissa}.")
    };
    format!("{mantissa}E{exp}")
}

/// The length uncertainty in `unit` ([`CadUnit::resolution`]) with a two-digit exponent, as
/// OpenCASCADE writes it (`1.E-07`).
fn uncertainty(unit: CadUnit) -> String {
    let r = real(unit.resolution());
    match r.split_once("E-") {
        Some((m, e)) if e.len() == 1 => format!("{m}E-0{e}"),
        _ => r,
    }
}

/// A STEP string literal: printable ASCII only (others become `_`), `'` and `\` doubled.
fn string(s: &str) -> String {
    let mut out = String::with_capacity(s.len() + 2);
    out.push('\'');
    for c in s.chars() {
        match c {
            '\'' => out.push_str("''"),
            '\\' => out.push_str("\\\\"),
            ' '..='~' => out.push(c),
            _ => out.push('_'),
        }
    }
    out.push('\'');
    out
}

/// The entity list being built: ids are handed out first and bodies filled in, so bodies may
/// refer forward.
struct Entities {
    bodies: Vec<Option<String>>,
}

impl Entities {
    fn reserve(&mut self) -> usize {
        self.bodies.push(None);
        self.bodies.len()
    }

    fn set(&mut self, id: usize, body: String) {
        self.bodies[id - 1] = Some(body);
    }

    fn add(&mut self, body: String) -> usize {
        self.bodies.push(Some(body));
        self.bodies.len()
    }

    fn point(&mut self, p: DVec3) -> usize {
        self.add(format!(
            "CARTESIAN_POINT('',({},{},{}))",
            real(p.x),
            real(p.y),
            real(p.z)
        ))
    }

    fn point2(&mut self, u: f64, v: f64) -> usize {
        self.add(format!("CARTESIAN_POINT('',({},{}))", real(u), real(v)))
    }

    fn direction(&mut self, d: DVec3) -> usize {
        self.add(format!(
            "DIRECTION('',({},{},{}))",
            real(d.x),
            real(d.y),
            real(d.z)
        ))
    }

    fn bspline_curve(&mut self, c: &BsplineCurve) -> usize {
        let pts: Vec<String> = c.ctrl.iter().map(|p| format!("#{}", self.point(*p))).collect();
        let (values, mults) = distinct_knots(&c.knots);
        self.add(format!(
            "B_SPLINE_CURVE_WITH_KNOTS('',{},({}),.UNSPECIFIED.,.F.,.F.,({}),({}),.UNSPECIFIED.)",
            c.degree,
            pts.join(","),
            join(mults.iter().map(ToString::to_string)),
            join(values.iter().map(|v| real(*v)))
        ))
    }

    fn bspline_surface(&mut self, s: &BsplineSurface) -> usize {
        let mut rows = Vec::with_capacity(s.count[0]);
        for i in 0..s.count[0] {
            let row: Vec<String> = (0..s.count[1])
                .map(|j| format!("#{}", self.point(s.at(i, j))))
                .collect();
            rows.push(format!("({})", row.join(",")));
        }
        let (vu, mu) = distinct_knots(&s.knots_u);
        let (vv, mv) = distinct_knots(&s.knots_v);
        self.add(format!(
            "B_SPLINE_SURFACE_WITH_KNOTS('',{},{},({}),.UNSPECIFIED.,.F.,.F.,.F.,({}),({}),({}),({}),.UNSPECIFIED.)",
            s.degree[0],
            s.degree[1],
            rows.join(","),
            join(mu.iter().map(ToString::to_string)),
            join(mv.iter().map(ToString::to_string)),
            join(vu.iter().map(|v| real(*v))),
            join(vv.iter().map(|v| real(*v)))
        ))
    }
}

fn join(items: impl Iterator<Item = String>) -> String {
    items.collect::<Vec<_>>().join(",")
}

/// Write `#id = body;` wrapped after commas outside strings at about 72 columns.
fn emit(out: &mut String, id: usize, body: &str) {
    let mut line = format!("#{id} = ");
    let mut in_string = false;
    for c in body.chars() {
        line.push(c);
        if c == '\'' {
            in_string = !in_string;
        }
        if c == ',' && !in_string && line.len() >= 72 {
            out.push_str(&line);
            out.push('\n');
            line = String::from("  ");
        }
    }
    out.push_str(&line);
    out.push_str(";\n");
}

/// The STEP file of `shapes` (all curves or all surfaces, in metres) in `unit`, product
/// `name`, dated `timestamp`.
pub fn step_text(shapes: &[CadShape], unit: CadUnit, name: &str, timestamp: &str) -> Result<String> {
    let shapes: Vec<CadShape> = shapes.iter().map(|s| s.in_unit(unit)).collect();
    let mut curves: Vec<&BsplineCurve> = Vec::new();
    let mut surfaces: Vec<&BsplineSurface> = Vec::new();
    for shape in &shapes {
        match shape {
            CadShape::Curve(c) => curves.push(c),
            CadShape::Surface(s) => surfaces.push(s),
        }
    }
    if curves.is_empty() == surfaces.is_empty() {
        return Err(Error::invalid(
            "a STEP file holds either curves or surfaces (and at least one)",
        ));
    }
    let mut e = Entities { bodies: Vec::new() };
    let apd = e.reserve();
    let app = e.add("APPLICATION_CONTEXT('core data for automotive mechanical design processes')".into());
    e.set(
        apd,
        format!("APPLICATION_PROTOCOL_DEFINITION('international standard','automotive_design',2000,#{app})"),
    );
    let sdr = e.reserve();
    let pds = e.reserve();
    let pd = e.reserve();
    let pdf = e.reserve();
    let product = e.reserve();
    let pc = e.add(format!("PRODUCT_CONTEXT('',#{app},'mechanical')"));
    let pdc = e.add(format!(
        "PRODUCT_DEFINITION_CONTEXT('part definition',#{app},'design')"
    ));
    let rep = e.reserve();
    e.set(sdr, format!("SHAPE_DEFINITION_REPRESENTATION(#{pds},#{rep})"));
    e.set(pds, format!("PRODUCT_DEFINITION_SHAPE('','',#{pd})"));
    e.set(pd, format!("PRODUCT_DEFINITION('design','',#{pdf},#{pdc})"));
    e.set(pdf, format!("PRODUCT_DEFINITION_FORMATION('','',#{product})"));
    let n = string(name);
    e.set(product, format!("PRODUCT({n},{n},'',(#{pc}))"));
    let origin = e.point(DVec3::ZERO);
    let z = e.direction(DVec3::Z);
    let x = e.direction(DVec3::X);
    let placement = e.add(format!("AXIS2_PLACEMENT_3D('',#{origin},#{z},#{x})"));
    let context = e.reserve();
    let length = e.add(match unit {
        CadUnit::Metre => "( LENGTH_UNIT() NAMED_UNIT(*) SI_UNIT($,.METRE.) )".into(),
        CadUnit::Millimetre => "( LENGTH_UNIT() NAMED_UNIT(*) SI_UNIT(.MILLI.,.METRE.) )".into(),
    });
    let angle = e.add("( NAMED_UNIT(*) PLANE_ANGLE_UNIT() SI_UNIT($,.RADIAN.) )".into());
    let solid = e.add("( NAMED_UNIT(*) SI_UNIT($,.STERADIAN.) SOLID_ANGLE_UNIT() )".into());
    let uncertainty = e.add(format!(
        "UNCERTAINTY_MEASURE_WITH_UNIT(LENGTH_MEASURE({}),#{length},'distance_accuracy_value','confusion accuracy')",
        uncertainty(unit)
    ));
    e.set(
        context,
        format!(
            "( GEOMETRIC_REPRESENTATION_CONTEXT(3) GLOBAL_UNCERTAINTY_ASSIGNED_CONTEXT((#{uncertainty})) \
             GLOBAL_UNIT_ASSIGNED_CONTEXT((#{length},#{angle},#{solid})) REPRESENTATION_CONTEXT('Context #1',\
             '3D Context with UNIT and UNCERTAINTY') )"
        ),
    );
    e.add(format!("PRODUCT_RELATED_PRODUCT_CATEGORY('part',$,(#{product}))"));

    if !curves.is_empty() {
        let mut trimmed = Vec::with_capacity(curves.len());
        for c in curves {
            let bs = e.bspline_curve(c);
            let (t0, t1) = (c.knots[0], c.knots[c.knots.len() - 1]);
            let p0 = e.point(c.eval(t0));
            let p1 = e.point(c.eval(t1));
            trimmed.push(e.add(format!(
                "TRIMMED_CURVE('',#{bs},(#{p0},PARAMETER_VALUE({})),(#{p1},PARAMETER_VALUE({})),.T.,.PARAMETER.)",
                real(t0),
                real(t1)
            )));
        }
        let set = e.add(format!(
            "GEOMETRIC_CURVE_SET('',({}))",
            join(trimmed.iter().map(|t| format!("#{t}")))
        ));
        e.set(
            rep,
            format!(
                "GEOMETRICALLY_BOUNDED_WIREFRAME_SHAPE_REPRESENTATION('',(#{placement},#{set}),#{context})"
            ),
        );
    } else {
        let ctx2 = e.add(
            "( GEOMETRIC_REPRESENTATION_CONTEXT(2) PARAMETRIC_REPRESENTATION_CONTEXT() REPRESENTATION_CONTEXT('2D SPACE','') )"
                .into(),
        );
        let mut shells = Vec::with_capacity(surfaces.len());
        for s in surfaces {
            let surf = e.bspline_surface(s);
            let (u0, u1) = (s.knots_u[0], s.knots_u[s.knots_u.len() - 1]);
            let (v0, v1) = (s.knots_v[0], s.knots_v[s.knots_v.len() - 1]);
            let (nu, nv) = (s.count[0], s.count[1]);
            let vertex = |e: &mut Entities, p: DVec3| {
                let pt = e.point(p);
                e.add(format!("VERTEX_POINT('',#{pt})"))
            };
            let v00 = vertex(&mut e, s.at(0, 0));
            let v10 = vertex(&mut e, s.at(nu - 1, 0));
            let v11 = vertex(&mut e, s.at(nu - 1, nv - 1));
            let v01 = vertex(&mut e, s.at(0, nv - 1));
            // An edge on the boundary curve `c` from vertex `a` to `b`, with its parameter line
            // through `(pu, pv)` along `(du, dv)` (the curve's parameter is the surface's).
            let edge = |e: &mut Entities, c: &BsplineCurve, a: usize, b: usize, line: [f64; 4]| {
                let bs = e.bspline_curve(c);
                let p = e.point2(line[0], line[1]);
                let d = e.add(format!("DIRECTION('',({},{}))", real(line[2]), real(line[3])));
                let vec = e.add(format!("VECTOR('',#{d},1.E0)"));
                let l = e.add(format!("LINE('',#{p},#{vec})"));
                let def = e.add(format!("DEFINITIONAL_REPRESENTATION('',(#{l}),#{ctx2})"));
                let pcurve = e.add(format!("PCURVE('',#{surf},#{def})"));
                let sc = e.add(format!("SURFACE_CURVE('',#{bs},(#{pcurve}),.PCURVE_S1.)"));
                e.add(format!("EDGE_CURVE('',#{a},#{b},#{sc},.T.)"))
            };
            let e_u0 = edge(&mut e, &s.u_boundary(0), v00, v01, [u0, 0.0, 0.0, 1.0]);
            let e_v0 = edge(&mut e, &s.v_boundary(0), v00, v10, [0.0, v0, 1.0, 0.0]);
            let e_u1 = edge(&mut e, &s.u_boundary(1), v10, v11, [u1, 0.0, 0.0, 1.0]);
            let e_v1 = edge(&mut e, &s.v_boundary(1), v01, v11, [0.0, v1, 1.0, 0.0]);
            let oriented: Vec<usize> = [(e_u0, false), (e_v0, true), (e_u1, true), (e_v1, false)]
                .into_iter()
                .map(|(id, same)| {
                    e.add(format!(
                        "ORIENTED_EDGE('',*,*,#{id},{})",
                        if same { ".T." } else { ".F." }
                    ))
                })
                .collect();
            let lp = e.add(format!(
                "EDGE_LOOP('',({}))",
                join(oriented.iter().map(|o| format!("#{o}")))
            ));
            let bound = e.add(format!("FACE_BOUND('',#{lp},.T.)"));
            let face = e.add(format!("ADVANCED_FACE('',(#{bound}),#{surf},.T.)"));
            shells.push(e.add(format!("OPEN_SHELL('',(#{face}))")));
        }
        let model = e.add(format!(
            "SHELL_BASED_SURFACE_MODEL('',({}))",
            join(shells.iter().map(|s| format!("#{s}")))
        ));
        e.set(
            rep,
            format!("MANIFOLD_SURFACE_SHAPE_REPRESENTATION('',(#{placement},#{model}),#{context})"),
        );
    }

    let mut out = String::new();
    out.push_str("ISO-10303-21;\nHEADER;\n");
    out.push_str("FILE_DESCRIPTION(('bezchain B-spline export'),'2;1');\n");
    let _ = writeln!(
        out,
        "FILE_NAME({n},{},('bezchain'),(''),'bezchain {v}','bezchain {v}','');",
        string(timestamp),
        v = env!("CARGO_PKG_VERSION")
    );
    out.push_str("FILE_SCHEMA(('AUTOMOTIVE_DESIGN { 1 0 10303 214 1 1 1 1 }'));\nENDSEC;\nDATA;\n");
    for (k, body) in e.bodies.iter().enumerate() {
        let body = body
            .as_deref()
            .ok_or_else(|| Error::Output(format!("step: entity #{} was reserved but not written", k + 1)))?;
        emit(&mut out, k + 1, body);
    }
    out.push_str("ENDSEC;\nEND-ISO-10303-21;\n");
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reals_are_step_reals_and_round_trip() {
        for x in [
            0.0,
            1.0,
            -2.5,
            0.1,
            1e-300,
            123456.789,
            -0.004_670_000_000_000_1,
            f64::MIN_POSITIVE,
        ] {
            let s = real(x);
            assert!(s.contains('.') && s.contains('E'), "{s}");
            assert_eq!(s.replace('E', "e").parse::<f64>().unwrap(), x, "{s}");
        }
        assert_eq!(real(1.0), "1.E0");
        assert_eq!(real(0.25), "2.5E-1");
        assert_eq!(string("it's a\\b é"), "'it''s a\\\\b _'");
    }
}
