"""Type stubs of the Rust extension ``bezchain._bezchain``."""

import os
from typing import Any, Dict, List, Optional, Sequence, Tuple, Union, final

import numpy as np
import numpy.typing as npt

__version__: str
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

_ArrayLike = npt.ArrayLike
_FloatArray = npt.NDArray[np.float64]
_PathLike = Union[str, "os.PathLike[str]"]
_Degrees = Union[str, int, Tuple[int, int], None]

@final
class Chain:
    """A chain of Bezier curves (a fit, an adapted encoding or a saved curve report)."""

    def evaluate(self, t: _ArrayLike) -> _FloatArray:
        """The point at parameter ``t`` in [0, 1] (shape ``(2,)``), or at every parameter of an array."""
    @property
    def design_points(self) -> _FloatArray:
        """The design points, the optimisation variables (shape ``(n, 2)``)."""
    @property
    def control_points(self) -> _FloatArray:
        """The expanded Bezier control points."""
    @property
    def degree(self) -> int: ...
    @property
    def segments(self) -> int: ...
    @property
    def continuity(self) -> str: ...
    @property
    def breaks(self) -> _FloatArray: ...
    @property
    def sum_sq(self) -> float:
        """Sum of squared offsets of the data (model units squared)."""
    @property
    def max_offset(self) -> float:
        """Largest offset of a data point (model units)."""
    @property
    def met(self) -> bool:
        """False when an adaptive search did not meet its tolerance."""
    @property
    def message(self) -> Optional[str]:
        """Why an adaptive search did not meet its tolerance, else None."""
    def to_json(self) -> str:
        """The JSON report, as ``bezchain fit --json`` / ``adapt --json`` write it."""
    def with_design(self, design: _ArrayLike) -> "Chain":
        """The chain of the same layout with other design points (offsets unknown: NaN)."""
    @staticmethod
    def from_json(text: str) -> "Chain":
        """A chain from a curve report's JSON text."""

@final
class Surface:
    """A grid of tensor-product Bezier patches (an adapted surface)."""

    def evaluate(self, u: _ArrayLike, v: _ArrayLike) -> _FloatArray:
        """The point at ``(u, v)`` in [0, 1]² (shape ``(3,)``), or at every pair of two arrays."""
    @property
    def design_net(self) -> _FloatArray:
        """The design net, rows along u (shape ``(nu, nv, 3)``)."""
    @property
    def degree(self) -> List[int]: ...
    @property
    def patches(self) -> List[int]: ...
    @property
    def sum_sq(self) -> float: ...
    @property
    def max_offset(self) -> float: ...
    @property
    def met(self) -> bool: ...
    @property
    def message(self) -> Optional[str]: ...
    def to_json(self) -> str:
        """The JSON report, as ``bezchain adapt-surface --json`` writes it."""

@final
class Evaluator:
    """The fitness of populations of designs of one layout against fixed data (``bezchain eval``)."""

    def __new__(
        cls,
        chain: Union[Chain, Surface],
        points: _ArrayLike,
        backend: str = "auto",
        newton: int = 8,
        seeds: Optional[int] = None,
    ) -> "Evaluator": ...
    @property
    def n_vars(self) -> int:
        """Design variables per individual."""
    @property
    def info(self) -> str:
        """The backend and adapter of the last evaluation."""
    def evaluate(self, population: _ArrayLike) -> _FloatArray:
        """``(P, n_vars)`` designs → ``(P, 2)`` array of ``(sum_sq, max)``."""

def read_aerofoil(path: _PathLike) -> _FloatArray:
    """Read an aerofoil or contour file: an ``(N, 2)`` array."""

def naca(code: str, points: int = 161, spacing: str = "cosine", closed_te: bool = False) -> _FloatArray:
    """A NACA 4- or 5-digit aerofoil as ``bezchain naca`` writes it: an ``(N, 2)`` array."""

def blade(
    path: _PathLike, points_per_section: Optional[int] = None, sections: Optional[int] = None
) -> _FloatArray:
    """Loft a blade definition into the cloud ``bezchain blade`` writes: ``(M, 5)`` x, y, z, section, index."""

def fit(
    points: _ArrayLike,
    degree: int = 3,
    segments: int = 5,
    continuity: str = "c1",
    method: str = "lsq",
    metric: str = "closest",
) -> Chain:
    """Fit a chain to an ``(N, 2)`` contour, as ``bezchain fit``."""

def adapt(
    points: _ArrayLike,
    tol: float,
    norm: str = "max",
    degrees: _Degrees = None,
    mode: str = "auto",
    max_scalars: Optional[int] = None,
    search_points: int = 80,
    relative: bool = False,
) -> Chain:
    """The chain with the fewest stored scalars meeting ``tol``, as ``bezchain adapt``."""

def adapt_surface(
    cloud: Union[_ArrayLike, _PathLike],
    tol: float,
    norm: str = "max",
    degrees_u: _Degrees = None,
    degrees_v: _Degrees = None,
    span_rule: bool = True,
    chord_rule: str = "auto",
    max_scalars: Optional[int] = None,
    relative: bool = False,
    span_breaks: str = "auto",
) -> Surface:
    """The patch grid with the fewest stored scalars meeting ``tol``, as ``bezchain adapt-surface``."""

def aero(
    shape: Union[_ArrayLike, Chain, _PathLike],
    alpha: Sequence[float] = (0.0, 4.0, 8.0),
    re: Optional[float] = None,
    ncrit: float = 9.0,
    xtr_top: float = 1.0,
    xtr_bottom: float = 1.0,
    panels: int = 160,
    te_ratio: float = 0.15,
) -> Dict[str, Any]:
    """The panel method, as ``bezchain aero``: inviscid, or viscous with ``re``; a dict of arrays."""

def optimise(
    start: _PathLike,
    objective: str,
    alpha: float = 4.0,
    method: str = "cmaes",
    population: Optional[int] = None,
    generations: Optional[int] = None,
    seed: int = 1,
    tol: float = 1e-4,
    margin: float = 0.1,
    spread: float = 0.01,
    stall: int = 0,
    panels: int = 160,
    min_thickness: Optional[float] = None,
    cm_min: Optional[float] = None,
    backend: str = "auto",
    re: Optional[float] = None,
    ncrit: float = 9.0,
    cl: Optional[float] = None,
    min_thickness_at: Sequence[Tuple[float, float]] = (),
    cl_min: Optional[float] = None,
    min_te_angle: Optional[float] = None,
    min_area: Optional[float] = None,
) -> Dict[str, Any]:
    """Optimise an aerofoil as ``bezchain optimise``."""

def objectives_list() -> List[str]:
    """The objectives ``optimise`` takes."""
