//! Every kind of JSON report the commands write, made here by the commands themselves and
//! validated against its JSON Schema in `docs/schemas/` (`docs/ARCHITECTURE.md` §5.10) by an
//! outside validator (the `jsonschema` crate): the stamp (version, schema, command line,
//! units) and the report's documented fields.

mod common;

use common::cli::{ok, run};
use common::{crate_root, scratch};
use serde_json::Value;
use std::path::Path;

/// The URI the schema files name each other by (their `$id`s).
const BASE: &str = "https://bezchain.example/schemas/";

/// Resolves `$ref`s to the schema files of `docs/schemas/`, nothing else.
struct SchemaFiles;

impl jsonschema::Retrieve for SchemaFiles {
    fn retrieve(
        &self,
        uri: &jsonschema::Uri<String>,
    ) -> Result<Value, Box<dyn std::error::Error + Send + Sync>> {
        let name = uri
            .as_str()
            .strip_prefix(BASE)
            .ok_or_else(|| format!("{uri} is not one of bezchain's schemas"))?;
        Ok(serde_json::from_str(&std::fs::read_to_string(
            crate_root().join("docs/schemas").join(name),
        )?)?)
    }
}

/// The schema file `name` (`curve.v1.json`).
fn schema(name: &str) -> Value {
    let path = crate_root().join("docs/schemas").join(name);
    serde_json::from_str(&std::fs::read_to_string(&path).unwrap())
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// Validate `report` against the schema its `schema` field names, which must be `expected`;
/// every error is listed.
fn assert_valid(report: &Value, expected: &str, what: &str) {
    assert_eq!(report["schema"], expected, "{what}: schema");
    let (name, version) = expected
        .strip_prefix("bezchain.")
        .and_then(|s| s.split_once('/'))
        .unwrap();
    let validator = jsonschema::options()
        .with_retriever(SchemaFiles)
        .build(&schema(&format!("{name}.v{version}.json")))
        .unwrap_or_else(|e| panic!("{expected}: the schema does not compile: {e}"));
    let errors: Vec<String> = validator
        .iter_errors(report)
        .map(|e| format!("{} at {}", e, e.instance_path()))
        .collect();
    assert!(
        errors.is_empty(),
        "{what} against {expected}:\n{}",
        errors.join("\n")
    );
    assert_eq!(report["bezchain_version"], env!("CARGO_PKG_VERSION"), "{what}");
    assert_eq!(report["units"]["length"], "m", "{what}");
    let command: Vec<&str> = report["command"]
        .as_array()
        .unwrap()
        .iter()
        .map(|a| a.as_str().unwrap())
        .collect();
    assert!(
        command.len() > 1 && command[0].ends_with("bezchain"),
        "{what}: {command:?}"
    );
}

/// `bezchain ARGS --json FILE`, the report parsed, its command line checked to be `ARGS`.
fn report(dir: &Path, name: &str, args: &[&str]) -> Value {
    let path = dir.join(name);
    let mut all = args.to_vec();
    all.extend(["--json", path.to_str().unwrap()]);
    ok(run(&all));
    let rep: Value = serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
    assert_eq!(
        rep["command"].as_array().unwrap()[1..]
            .iter()
            .map(|a| a.as_str().unwrap())
            .collect::<Vec<_>>(),
        all,
        "{name}"
    );
    rep
}

/// Every schema file is a valid JSON Schema, names itself by its file name and is one of the
/// library's `Schema` kinds (the stamp's own file besides).
#[test]
fn every_schema_file_compiles_and_names_itself() {
    let mut names: Vec<String> = std::fs::read_dir(crate_root().join("docs/schemas"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    let mut expected: Vec<String> = bezchain::export::Schema::ALL
        .iter()
        .map(|s| s.file_name())
        .chain(["stamp.v1.json".to_string()])
        .collect();
    expected.sort();
    assert_eq!(names, expected);
    for name in &names {
        let s = schema(name);
        assert_eq!(s["$id"], format!("{BASE}{name}"));
        jsonschema::options()
            .with_retriever(SchemaFiles)
            .build(&s)
            .unwrap_or_else(|e| panic!("{name}: {e}"));
    }
}

/// The reports of `fit`, `adapt` (one tolerance and a sweep), `fit-surface`, `adapt-surface`,
/// `aero`, `optimise`, `compare` and `bench` are valid against their schemas; a report that
/// lost a stamp field or a documented one is not.
#[test]
fn every_report_kind_is_valid_against_its_schema() {
    let dir = scratch("report-schemas");
    let foil = "data/naca4413.dat";
    let cloud = dir.join("blade.csv");
    ok(run(&[
        "blade",
        "data/blade_paper_to_tip.json",
        "--points-per-section",
        "24",
        "-o",
        cloud.to_str().unwrap(),
    ]));
    let cloud = cloud.to_str().unwrap();

    let fit = report(
        &dir,
        "fit.json",
        &["fit", foil, "--degree", "3", "--segments", "5"],
    );
    assert_valid(&fit, "bezchain.curve/1", "fit");
    let adapt = report(&dir, "adapt.json", &["adapt", foil, "--tol", "1e-3"]);
    assert_valid(&adapt, "bezchain.curve/1", "adapt");
    let sweep = report(&dir, "sweep.json", &["adapt", foil, "--sweep", "1e-2,1e-3"]);
    assert_valid(&sweep, "bezchain.sweep/1", "adapt --sweep");
    assert_eq!(sweep["reports"].as_array().unwrap().len(), 2);
    let surface = report(
        &dir,
        "surface.json",
        &["fit-surface", cloud, "--degree", "3x2", "--patches", "2x2"],
    );
    assert_valid(&surface, "bezchain.surface/1", "fit-surface");
    let adapted = report(
        &dir,
        "adapt-surface.json",
        &[
            "adapt-surface",
            cloud,
            "--tol",
            "2e-3",
            "--relative",
            "--degrees-u",
            "3",
            "--degrees-v",
            "2",
        ],
    );
    assert_valid(&adapted, "bezchain.surface/1", "adapt-surface");
    let aero = report(&dir, "aero.json", &["aero", foil, "--alpha", "0,4"]);
    assert_valid(&aero, "bezchain.aero/1", "aero");
    let optimise = report(
        &dir,
        "optimise.json",
        &[
            "optimise",
            foil,
            "--objective",
            "max-cl",
            "--min-thickness",
            "0.1",
            "--population",
            "16",
            "--generations",
            "2",
            "--backend",
            "cpu",
        ],
    );
    assert_valid(&optimise, "bezchain.optimise/1", "optimise");
    let compare = report(
        &dir,
        "compare.json",
        &["compare", foil, "--methods", "lsq", "--backend", "cpu"],
    );
    assert_valid(&compare, "bezchain.compare/1", "compare");
    let bench = report(
        &dir,
        "bench.json",
        &[
            "bench",
            "--backend",
            "cpu",
            "--population",
            "8",
            "--points",
            "50",
            "--runs",
            "5",
            "--no-peak-measure",
        ],
    );
    assert_valid(&bench, "bezchain.bench/1", "bench");

    // The schemas bite: a report without a stamp field or a documented field is refused.
    for (field, mut broken) in [("units", fit.clone()), ("design_points", fit)] {
        broken.as_object_mut().unwrap().remove(field);
        let validator = jsonschema::options()
            .with_retriever(SchemaFiles)
            .build(&schema("curve.v1.json"))
            .unwrap();
        assert!(
            !validator.is_valid(&broken),
            "a curve report without '{field}' passed"
        );
    }
}
