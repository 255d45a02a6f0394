//! Every `shaders/*.wgsl` parsed and validated by naga with no device, as written (with its
//! includes spliced in) and specialised for a range of layouts, and every Rust mirror struct
//! checked against naga's layout of its WGSL twin.

use bezchain::aero::batch::{AeroConfig, AeroResult, AeroStep};
use bezchain::eval::gpu::{prepare, prepare_with, source};
use bezchain::eval::{Config, Fitness, MapEntry, Partial, RefJet, Sample, Target, Vertex};
use std::mem::{offset_of, size_of};

fn validate(name: &str, src: &str) -> naga::Module {
    validate_with(name, src, naga::valid::Capabilities::empty())
}

/// [`validate`] for a device with `capabilities` (subgroup operations for the shaders that
/// splice in points_subgroup.wgsl).
fn validate_with(name: &str, src: &str, capabilities: naga::valid::Capabilities) -> naga::Module {
    let module = naga::front::wgsl::parse_str(src)
        .unwrap_or_else(|e| panic!("{name}: parse error\n{}", e.emit_to_string(src)));
    naga::valid::Validator::new(naga::valid::ValidationFlags::all(), capabilities)
        .validate(&module)
        .unwrap_or_else(|e| panic!("{name}: invalid\n{}", e.emit_to_string(src)));
    module
}

/// The point reads that eval_patch.wgsl splices in on devices with subgroup operations.
const SUBGROUP_POINTS: [(&str, &str); 1] = [("points.wgsl", source::POINTS_SUBGROUP)];

/// `(name, contents)` of every file in `shaders/`, includes spliced in; an include file alone
/// gets the constant it expects from its includer, and the point reads are checked in it.
fn shader_files() -> Vec<(String, String)> {
    raw_files()
        .into_iter()
        .map(|(name, src)| {
            let src = match name.as_str() {
                "basis.wgsl" => format!("const NMAX: u32 = 4u;\n{src}"),
                "points.wgsl" => source::expand(source::EVAL_PATCH).unwrap(),
                "points_subgroup.wgsl" => source::expand_with(source::EVAL_PATCH, &SUBGROUP_POINTS).unwrap(),
                _ => source::expand(&src).unwrap(),
            };
            (name, src)
        })
        .collect()
}

/// What validating `name` needs of the device.
fn capabilities(name: &str) -> naga::valid::Capabilities {
    if name == "points_subgroup.wgsl" {
        naga::valid::Capabilities::SUBGROUP
    } else {
        naga::valid::Capabilities::empty()
    }
}

/// `(name, contents)` of every file in `shaders/`, as written.
fn raw_files() -> Vec<(String, String)> {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("shaders");
    let mut files: Vec<(String, String)> = std::fs::read_dir(&dir)
        .expect("shaders/ is readable")
        .map(|e| e.expect("directory entry").path())
        .filter(|p| p.extension().is_some_and(|x| x == "wgsl"))
        .map(|p| {
            let name = p.file_name().unwrap().to_string_lossy().into_owned();
            (name, std::fs::read_to_string(&p).expect("shader is readable"))
        })
        .collect();
    files.sort();
    files
}

#[test]
fn every_wgsl_file_validates_as_written() {
    let files = shader_files();
    let names: Vec<&str> = files.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(
        names,
        [
            "aero.wgsl",
            "basis.wgsl",
            "config.wgsl",
            "dense_grid.wgsl",
            "eval_patch.wgsl",
            "expand.wgsl",
            "points.wgsl",
            "points_subgroup.wgsl",
            "reduce.wgsl"
        ]
    );
    for (name, src) in &files {
        let module = validate_with(name, src, capabilities(name));
        let entries: Vec<&str> = module.entry_points.iter().map(|e| e.name.as_str()).collect();
        let expect: &[&str] = if ["basis.wgsl", "config.wgsl"].contains(&name.as_str()) {
            &[]
        } else {
            &["main"]
        };
        assert_eq!(entries, expect, "{name}: entry points");
    }
}

#[test]
fn the_embedded_sources_are_the_files() {
    let embedded = [
        bezchain::aero::batch::gpu::SOURCE,
        source::BASIS,
        source::CONFIG,
        source::DENSE_GRID,
        source::EVAL_PATCH,
        source::EXPAND,
        source::POINTS,
        source::POINTS_SUBGROUP,
        source::REDUCE,
    ];
    for ((name, src), e) in raw_files().iter().zip(embedded) {
        assert_eq!(src, e, "{name}");
    }
}

#[test]
fn shared_definitions_are_written_once() {
    // `struct Config` and the basis live in their include files only.
    for (name, src) in raw_files() {
        let configs = src.matches("struct Config {").count();
        let bases = src.matches("fn basis(").count() + src.matches("fn bernstein(").count();
        match name.as_str() {
            "config.wgsl" => assert_eq!(configs, 1),
            "basis.wgsl" => assert_eq!(bases, 2),
            // eval_patch.wgsl's point reads: spliced into it after its config.
            "points.wgsl" | "points_subgroup.wgsl" => {
                assert_eq!(configs + bases, 0, "{name} defines a shared item itself");
            }
            // The panel kernel has its own `AeroConfig` and no Bernstein basis.
            "aero.wgsl" => assert_eq!(configs + bases, 0, "{name} defines a shared item itself"),
            _ => {
                assert_eq!(configs + bases, 0, "{name} defines a shared item itself");
                assert!(
                    src.contains("// @include config.wgsl"),
                    "{name} includes the config"
                );
            }
        }
    }
}

#[test]
fn specialised_shaders_validate_for_every_supported_shape() {
    // Curves (DV = 0, DIM = 2) and grids (DIM = 3), degrees 1 to 7.
    let mut shapes = Vec::new();
    for du in 1..=7u32 {
        shapes.push((du, 0, 2));
        for dv in [1, 2, 3, 7] {
            shapes.push((du, dv, 3));
        }
    }
    for (du, dv, dim) in shapes {
        for (cross, per) in [(0, 1), (1, 1), (0, 4), (1, 4)] {
            let consts = [
                ("DIM", dim),
                ("DU", du),
                ("DV", dv),
                ("CROSS", cross),
                ("PER", per),
            ];
            let eval = prepare(source::EVAL_PATCH, &consts).unwrap();
            assert!(
                !eval.lines().any(|l| l.trim_end().ends_with("// @unroll")),
                "every marked loop is unrolled"
            );
            let name = format!("eval_patch {du}x{dv} dim {dim} cross {cross} per {per}");
            validate(&name, &eval);
            let eval = prepare_with(source::EVAL_PATCH, &consts, &SUBGROUP_POINTS).unwrap();
            validate_with(
                &format!("{name} subgroups"),
                &eval,
                capabilities("points_subgroup.wgsl"),
            );
        }
        validate("expand", &prepare(source::EXPAND, &[("DIM", dim)]).unwrap());
        if dim == 3 {
            let consts = [("DIM", dim), ("DU", du), ("DV", dv)];
            validate("dense_grid", &prepare(source::DENSE_GRID, &consts).unwrap());
        }
    }
}

/// Size and member offsets of struct `name` in `src`, per naga.
fn wgsl_layout(src: &str, name: &str) -> Option<(u32, Vec<(String, u32)>)> {
    let module = naga::front::wgsl::parse_str(src).ok()?;
    let mut layouter = naga::proc::Layouter::default();
    layouter.update(module.to_ctx()).ok()?;
    let found = module
        .types
        .iter()
        .find_map(|(handle, ty)| match (&ty.name, &ty.inner) {
            (Some(n), naga::TypeInner::Struct { members, .. }) if n == name => Some((
                layouter[handle].size,
                members
                    .iter()
                    .map(|m| (m.name.clone().unwrap_or_default(), m.offset))
                    .collect(),
            )),
            _ => None,
        });
    found
}

/// Check `name` in every shader that declares it against the Rust size and offsets.
fn check(name: &str, size: usize, offsets: &[(&str, usize)], expect_in: &[&str]) {
    let mut seen = Vec::new();
    for (file, src) in shader_files() {
        // The point reads are checked as spliced into eval_patch.wgsl, so they are that file.
        let include = ["basis.wgsl", "points.wgsl", "points_subgroup.wgsl"].contains(&file.as_str());
        if include || (file == "config.wgsl" && name != "Config") {
            continue;
        }
        if let Some((wsize, members)) = wgsl_layout(&src, name) {
            seen.push(file.clone());
            assert_eq!(wsize as usize, size, "{name} in {file}: size");
            let got: Vec<(&str, usize)> = members.iter().map(|(n, o)| (n.as_str(), *o as usize)).collect();
            assert_eq!(got, offsets, "{name} in {file}: members and offsets");
        }
    }
    assert_eq!(seen, expect_in, "{name} is declared where expected");
}

macro_rules! offsets {
    ($t:ty; $($f:ident),*) => { [$((stringify!($f), offset_of!($t, $f))),*] };
}

#[test]
fn rust_structs_match_their_wgsl_twins() {
    let all = [
        "config.wgsl",
        "dense_grid.wgsl",
        "eval_patch.wgsl",
        "expand.wgsl",
        "reduce.wgsl",
    ];
    check(
        "Config",
        size_of::<Config>(),
        &offsets!(Config; population, net_stride, n_vars, n_ctrl, n_points, group_points,
            n_groups, newton, patches_u, patches_v, net_cols, grid_u, grid_v, degree_u, degree_v, dim,
            cross, seeds, seed_ring, _pad2),
        &all,
    );
    check(
        "Target",
        size_of::<Target>(),
        &offsets!(Target; rx, ry, rz, patch_id, u, v, reach_u, reach_v),
        &["eval_patch.wgsl"],
    );
    check(
        "RefJet",
        size_of::<RefJet>(),
        &offsets!(RefJet; su, sv, suu, suv, svv, _pad),
        &["eval_patch.wgsl"],
    );
    check(
        "Sample",
        size_of::<Sample>(),
        &offsets!(Sample; index, t),
        &["dense_grid.wgsl"],
    );
    check(
        "Partial",
        size_of::<Partial>(),
        &offsets!(Partial; sum_sq, max_sq),
        &["eval_patch.wgsl", "reduce.wgsl"],
    );
    check(
        "Fitness",
        size_of::<Fitness>(),
        &offsets!(Fitness; sum_sq, max),
        &["reduce.wgsl"],
    );
    check(
        "MapEntry",
        size_of::<MapEntry>(),
        &offsets!(MapEntry; index, weight),
        &["expand.wgsl"],
    );
    check(
        "AeroConfig",
        size_of::<AeroConfig>(),
        &offsets!(AeroConfig; population, stride, n_vars, n_nodes, objective, target_samples,
            constraints, _pad0, cos_alpha, sin_alpha, min_thickness, cm_min),
        &["aero.wgsl"],
    );
    check(
        "AeroStep",
        size_of::<AeroStep>(),
        &offsets!(AeroStep; phase, first, last, _pad0),
        &["aero.wgsl"],
    );
    check(
        "AeroResult",
        size_of::<AeroResult>(),
        &offsets!(AeroResult; cl, cm, thickness, objective, score, flags, violation, _pad0),
        &["aero.wgsl"],
    );
    check(
        "Vertex",
        size_of::<Vertex>(),
        &offsets!(Vertex; px, py, pz, nx, ny, nz, tangent_sq, _pad),
        &["dense_grid.wgsl"],
    );
}
