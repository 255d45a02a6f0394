//! Outputs: the JSON report, SVG plots, OBJ/STL meshes, PNG renders, STEP/IGES B-splines and
//! the readable summaries the commands print ([`summary`]); a run's files, written all or
//! nothing ([`Outputs`]), and what a long run writes as it goes ([`RunRecord`]).

mod adapt_report;
mod bspline;
mod cad;
mod cp_plot;
mod iges;
mod mesh;
mod offset_map;
mod outputs;
mod plot;
mod plot_png;
mod polar_plot;
mod raster;
mod render;
mod run_record;
mod stamp;
mod step;
pub mod summary;
mod svg;
mod viscous_report;

pub use crate::fit::report::{
    backend_label, CurveReport, FitInfo, InputInfo, OffsetReport, Report, SurfaceReport,
};
pub use adapt_report::{
    AdaptBlock, AdaptOutcome, AdaptReport, SurfaceAdaptBlock, SurfaceAdaptReport, COUNTING,
};
pub use bspline::{distinct_knots, BsplineCurve, BsplineSurface, CadShape, CadUnit};
pub use cad::{utc_now, write_cad};
pub use cp_plot::{CpCurve, CpPlot, Outline};
pub use iges::iges_text;
pub use mesh::SurfaceMesh;
pub use offset_map::{lightness, Colouring, Marked, CHORD_FLOOR};
pub use outputs::{Output, Outputs};
pub use plot::Plot;
pub use plot_png::{plot_png, PixelBackend};
pub use polar_plot::PolarPlot;
pub use render::{
    local_offsets, offset_colour, render, render_svg, Image, OffsetPoint, RenderOptions, Rgb, Station, View,
    BACKGROUND, BORDER, DATA_POINT, DESIGN_POINT, GENERATED_POINT, NET, SURFACE,
};
pub use run_record::{RunRecord, HISTORY_HEADER};
pub use stamp::{Schema, Stamp, Stamped, Sweep, Units, UNITS};
pub use step::step_text;
pub use svg::CurvePlot;
pub use viscous_report::{FilePolar, Polars, ViscousReport};
