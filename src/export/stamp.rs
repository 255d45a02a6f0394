//! The stamp every JSON report carries at its top (`docs/ARCHITECTURE.md` §5.10): the
//! bezchain version that wrote it, the report's schema and its version, the command line that
//! made it and the units its numbers are in. Each schema is a JSON Schema file in
//! `docs/schemas/`, named `<name>.v<version>.json`.

use serde::Serialize;

/// The kinds of JSON report, one schema each.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Schema {
    /// A curve report: `fit`, `adapt` (§5.4, §5.6).
    Curve,
    /// A surface report: `fit-surface`, `adapt-surface` (§5.5, §5.7).
    Surface,
    /// Several curve or surface reports, one a tolerance: `adapt --sweep`,
    /// `adapt-surface --sweep`.
    Sweep,
    /// A curve report with its optimisation: `optimise` (§5.9).
    Optimise,
    /// A polar with pressures: `aero` (§5.9).
    Aero,
    /// The method comparison table: `compare`.
    Compare,
    /// A benchmark: `bench`.
    Bench,
}

impl Schema {
    /// Every schema, in the order of the files in `docs/schemas/`.
    pub const ALL: [Schema; 7] = [
        Schema::Curve,
        Schema::Surface,
        Schema::Sweep,
        Schema::Optimise,
        Schema::Aero,
        Schema::Compare,
        Schema::Bench,
    ];

    /// The schema's name.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Schema::Curve => "curve",
            Schema::Surface => "surface",
            Schema::Sweep => "sweep",
            Schema::Optimise => "optimise",
            Schema::Aero => "aero",
            Schema::Compare => "compare",
            Schema::Bench => "bench",
        }
    }

    /// The schema's version: raised when a report's existing fields change meaning or go;
    /// new optional fields keep it.
    #[must_use]
    pub fn version(self) -> u32 {
        1
    }

    /// `bezchain.<name>/<version>`, the value of a report's `schema` field.
    #[must_use]
    pub fn id(self) -> String {
        format!("bezchain.{}/{}", self.name(), self.version())
    }

    /// The schema file's name in `docs/schemas/`.
    #[must_use]
    pub fn file_name(self) -> String {
        format!("{}.v{}.json", self.name(), self.version())
    }
}

/// The units of a report's numbers.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Units {
    /// Every coordinate, offset and tolerance: the input data's numbers, taken as metres (an
    /// aerofoil file of unit chord is a 1 m chord; STEP and IGES files are written so).
    pub length: &'static str,
    /// Angles of attack and twist.
    pub angle: &'static str,
}

/// The units of every report.
pub const UNITS: Units = Units {
    length: "m",
    angle: "deg",
};

/// The stamp at the top of a JSON report (see the module docs).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Stamp {
    /// The version of bezchain that wrote the report (`Cargo.toml`'s).
    pub bezchain_version: &'static str,
    /// The report's schema, `bezchain.<name>/<version>` ([`Schema::id`]).
    pub schema: String,
    /// The command line that made the report, program name first.
    pub command: Vec<String>,
    /// The units of its numbers.
    pub units: Units,
}

impl Stamp {
    /// The stamp of a report of `schema` made by `command`.
    #[must_use]
    pub fn new(schema: Schema, command: Vec<String>) -> Self {
        Stamp {
            bezchain_version: env!("CARGO_PKG_VERSION"),
            schema: schema.id(),
            command,
            units: UNITS,
        }
    }

    /// `report` with this stamp at its top, for serialising. `report` must serialise as a JSON
    /// object (an array goes into a [`Sweep`] first).
    #[must_use]
    pub fn on<'a, T: Serialize>(&'a self, report: &'a T) -> Stamped<'a, T> {
        Stamped { stamp: self, report }
    }
}

/// A report with its stamp: serialises as the stamp's fields, then the report's.
#[derive(Serialize)]
pub struct Stamped<'a, T: Serialize> {
    #[serde(flatten)]
    stamp: &'a Stamp,
    #[serde(flatten)]
    report: &'a T,
}

/// Several reports in one file (a sweep over tolerances): `{"kind": "sweep", "reports": […]}`,
/// read back by `bezchain::fit::report::read_reports`.
#[derive(Serialize)]
pub struct Sweep<'a, T: Serialize> {
    /// Always `sweep`.
    pub kind: &'static str,
    /// The reports, one a tolerance.
    pub reports: &'a [T],
}

impl<'a, T: Serialize> Sweep<'a, T> {
    /// The sweep of `reports`.
    #[must_use]
    pub fn of(reports: &'a [T]) -> Self {
        Sweep {
            kind: "sweep",
            reports,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The stamp comes first and the report's own fields follow in their order; a sweep is an
    /// object with its reports in an array.
    #[test]
    fn a_stamped_report_starts_with_its_stamp() {
        #[derive(Serialize)]
        struct R {
            kind: &'static str,
            b: u32,
            a: u32,
        }
        let stamp = Stamp::new(Schema::Curve, vec!["bezchain".into(), "fit".into()]);
        let text = serde_json::to_string(&stamp.on(&R {
            kind: "curve",
            b: 1,
            a: 2,
        }))
        .unwrap();
        assert_eq!(
            text,
            format!(
                r#"{{"bezchain_version":"{}","schema":"bezchain.curve/1","command":["bezchain","fit"],"units":{{"length":"m","angle":"deg"}},"kind":"curve","b":1,"a":2}}"#,
                env!("CARGO_PKG_VERSION")
            )
        );
        let sweep = Stamp::new(Schema::Sweep, vec![]);
        let v: serde_json::Value = serde_json::to_value(sweep.on(&Sweep::of(&[1, 2]))).unwrap();
        assert_eq!(v["schema"], "bezchain.sweep/1");
        assert_eq!(v["reports"], serde_json::json!([1, 2]));
        assert_eq!(Schema::Optimise.file_name(), "optimise.v1.json");
    }
}
