//! The 2D plots (a fitted curve, a pressure distribution, a polar) as one kind: each draws to
//! SVG and to PNG, so a command writes whichever its user asked for.

use crate::error::Result;
use crate::export::{CpPlot, CurvePlot, PolarPlot};

/// A 2D plot that draws to both formats.
pub trait Plot {
    /// The SVG document.
    fn svg(&self) -> Result<String>;
    /// The PNG bytes.
    fn png(&self) -> Result<Vec<u8>>;
}

impl Plot for CurvePlot<'_> {
    fn svg(&self) -> Result<String> {
        self.to_svg()
    }
    fn png(&self) -> Result<Vec<u8>> {
        self.to_png()
    }
}

impl Plot for PolarPlot {
    fn svg(&self) -> Result<String> {
        self.to_svg()
    }
    fn png(&self) -> Result<Vec<u8>> {
        self.to_png()
    }
}

impl Plot for CpPlot {
    fn svg(&self) -> Result<String> {
        self.to_svg()
    }
    fn png(&self) -> Result<Vec<u8>> {
        self.to_png()
    }
}
