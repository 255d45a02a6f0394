//! Aerofoil and point-cloud geometry: NACA generators, Selig/Lednicer `.dat` and CSV/XYZ
//! readers and writers, population files, blade definitions (JSON, windIO v1/v2, AeroDyn
//! 15) and lofting.

mod aerodyn;
mod blade;
mod blade_read;
mod dat;
mod gaussian;
mod interp;
mod io;
mod lednicer;
mod loft;
mod naca;
mod points;
mod population;
mod scale;
mod scatter;
mod section;
mod spline;
mod windio;

pub use blade::{
    Aerofoil, Axes, Blade, BladeFormat, Blend, Station, DEFAULT_NACA_POINTS, DEFAULT_PITCH_AXIS,
};
pub use dat::{write_selig, write_selig_to, SELIG_DECIMALS};
pub use gaussian::Gaussian;
pub(crate) use interp::Pchip;
pub(crate) use io::{from_json_value, parse_json, read_bytes, read_text};
pub use io::{is_stdin, write_atomic, Destination, Staged, MAX_INPUT_BYTES, MAX_LINE_BYTES};
pub use loft::{LoftOptions, MAX_CLOUD_POINTS, MIN_SECTION_POINTS};
#[cfg(test)]
pub(crate) use naca::test_contour;
pub use naca::{Naca, NacaOptions, Spacing, MAX_NACA_POINTS};
pub use points::{
    parse_cloud, parse_curve, parse_points, read_cloud, read_curve, read_points, write_cloud_csv,
    write_csv_to, write_curve_csv, Cloud, Format, Grid, Loaded, Loaded2, Loaded3, LoadedPoints,
};
pub use population::{parse_population, read_population};
pub use scale::{check_design_scale, check_scale, Precision, MIN_EXTENT_F32, MIN_EXTENT_F64};
pub use scatter::{curve_scatter, section_scatter, Scatter};
pub(crate) use section::twice_signed_area;
pub use section::SectionShape;
pub use spline::SplineContour;
pub(crate) use spline::{locate, tridiagonal, Spline1};
