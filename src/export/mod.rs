//! Outputs: the JSON report, SVG plots, OBJ/STL meshes and PNG renders.

mod report;
mod svg;

pub use report::{CurveReport, FitInfo, InputInfo, OffsetReport, Report, SurfaceReport};
pub use svg::CurvePlot;
