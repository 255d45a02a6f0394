"""bezchain: chained Bezier curves and patches as compact shape-optimisation variables.

Dense aerofoil contours and blade point clouds become a small set of design points; the
functions here call the same library functions as the ``bezchain`` command line, so their
numbers are the CLI's. Long computations release the GIL.
"""

from ._bezchain import (
    Chain,
    Evaluator,
    Surface,
    __version__,
    adapt,
    adapt_surface,
    aero,
    blade,
    fit,
    naca,
    objectives_list,
    optimise,
    read_aerofoil,
)

__all__ = [
    "Chain",
    "Evaluator",
    "Surface",
    "__version__",
    "adapt",
    "adapt_surface",
    "aero",
    "blade",
    "fit",
    "naca",
    "objectives_list",
    "optimise",
    "read_aerofoil",
]
