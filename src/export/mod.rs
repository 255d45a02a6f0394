//! Outputs: the JSON report, SVG plots, OBJ/STL meshes and PNG renders.

mod mesh;
mod render;
mod report;
mod svg;

pub use mesh::SurfaceMesh;
pub use render::{
    render, render_svg, Image, RenderOptions, Rgb, View, BACKGROUND, BORDER, DATA_POINT, DESIGN_POINT,
    GENERATED_POINT, NET, SURFACE,
};
pub use report::{CurveReport, FitInfo, InputInfo, OffsetReport, Report, SurfaceReport};
pub use svg::CurvePlot;
