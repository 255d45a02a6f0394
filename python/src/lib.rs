//! `bezchain._bezchain`: the Python module, a thin layer over the library functions the CLI's
//! subcommands call (so that its numbers are the CLI's); arrays in and out through numpy,
//! library errors mapped to `ValueError` (bad input), `OSError` (files) or `RuntimeError`, and
//! every long computation run with the GIL released.

mod aero;
mod convert;
mod evaluate;
mod files;
mod shapes;

use evaluate::Evaluator;
use files::{blade, naca, read_aerofoil};
use pyo3::prelude::*;
use shapes::{adapt, adapt_surface, fit, Chain, Surface};

/// bezchain: chained Bezier curves and patches as compact shape-optimisation variables.
#[pymodule]
fn _bezchain(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_class::<Chain>()?;
    m.add_class::<Surface>()?;
    m.add_class::<Evaluator>()?;
    m.add_function(wrap_pyfunction!(read_aerofoil, m)?)?;
    m.add_function(wrap_pyfunction!(naca, m)?)?;
    m.add_function(wrap_pyfunction!(blade, m)?)?;
    m.add_function(wrap_pyfunction!(fit, m)?)?;
    m.add_function(wrap_pyfunction!(adapt, m)?)?;
    m.add_function(wrap_pyfunction!(adapt_surface, m)?)?;
    m.add_function(wrap_pyfunction!(aero::aero, m)?)?;
    m.add_function(wrap_pyfunction!(aero::optimise, m)?)?;
    m.add_function(wrap_pyfunction!(aero::objectives_list, m)?)?;
    Ok(())
}
