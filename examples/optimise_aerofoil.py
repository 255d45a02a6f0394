"""Optimise an aerofoil with pymoo through bezchain's Python module, and plot the result.

The design variables are the y coordinates of a Bezier chain's design points, fitted to
NACA 4413 (``bezchain.fit``). A pymoo-style vectorised problem scores a whole population at
once: the lift coefficient at ``--alpha`` from the inviscid panel method (``bezchain.aero``),
and, as a constraint, the largest closest-point offset of the start contour from each design
(``bezchain.Evaluator``, one call for the population), so that designs stay within
``--max-offset`` of the start. The start and the best design, and their pressures, are drawn
with matplotlib into a PNG.

    pip install ./python pymoo matplotlib
    python examples/optimise_aerofoil.py --generations 20 --png optimised.png
"""

import argparse
from pathlib import Path

import numpy as np

import bezchain

try:
    from pymoo.algorithms.soo.nonconvex.ga import GA
    from pymoo.core.problem import Problem
    from pymoo.optimize import minimize
except ImportError as e:  # pragma: no cover - the test skips without pymoo
    raise SystemExit(f"this example needs pymoo (pip install pymoo): {e}")


class MaxLift(Problem):
    """Maximise CL at `alpha` over the y of the design points, each within ±`box` of its
    start, subject to the start contour staying within `max_offset` of the design."""

    def __init__(self, start, points, alpha=4.0, box=0.01, max_offset=0.01, backend="auto"):
        self.start = start
        self.alpha = alpha
        self.max_offset = max_offset
        self.base = start.design_points.copy()
        # The ends (the trailing edge) are held: only interior y coordinates move.
        self.free = np.arange(1, len(self.base) - 1)
        y0 = self.base[self.free, 1]
        self.evaluator = bezchain.Evaluator(start, points, backend=backend)
        super().__init__(n_var=len(self.free), n_obj=1, n_ieq_constr=1, xl=y0 - box, xu=y0 + box)

    def designs(self, x):
        """Rows of design variables → rows of flattened design points (x0, y0, x1, y1, ...)."""
        pop = np.repeat(self.base[None, :, :], len(x), axis=0)
        pop[:, self.free, 1] = x
        return pop.reshape(len(x), -1)

    def _evaluate(self, x, out, *args, **kwargs):
        designs = self.designs(np.atleast_2d(x))
        # One call for the whole population; the start as the first row is the reference the
        # foot-point searches begin from, its own fitness dropped.
        fitness = self.evaluator.evaluate(np.vstack([self.base.ravel(), designs]))[1:]
        cl = np.array(
            [bezchain.aero(self.start.with_design(d), alpha=[self.alpha])["cl"][0] for d in designs]
        )
        out["F"] = -cl[:, None]
        out["G"] = (fitness[:, 1] - self.max_offset)[:, None]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--aerofoil", default=None, help="start aerofoil file (default: NACA 4413)")
    ap.add_argument("--alpha", type=float, default=4.0, help="angle of attack, degrees")
    ap.add_argument("--generations", type=int, default=20)
    ap.add_argument("--population", type=int, default=24)
    ap.add_argument("--max-offset", type=float, default=0.01, help="largest offset from the start, chords")
    ap.add_argument("--backend", default="auto", help="auto, gpu or cpu (the Evaluator's)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--png", default="optimised_aerofoil.png", help="the picture written")
    args = ap.parse_args(argv)

    points = bezchain.read_aerofoil(args.aerofoil) if args.aerofoil else bezchain.naca("4413")
    start = bezchain.fit(points, degree=3, segments=5)
    problem = MaxLift(start, points, alpha=args.alpha, max_offset=args.max_offset, backend=args.backend)
    result = minimize(
        problem,
        GA(pop_size=args.population, eliminate_duplicates=True),
        ("n_gen", args.generations),
        seed=args.seed,
        verbose=False,
    )
    x = np.atleast_2d(result.X)[0] if result.X is not None else problem.base[problem.free, 1]
    best = start.with_design(problem.designs(x[None, :])[0])
    before = bezchain.aero(start, alpha=[args.alpha])
    after = bezchain.aero(best, alpha=[args.alpha])
    print(f"CL at {args.alpha} deg: start {before['cl'][0]:.4f}, optimised {after['cl'][0]:.4f}")
    plot(start, best, before, after, args.alpha, Path(args.png))
    print(f"wrote {args.png}")
    return before["cl"][0], after["cl"][0]


def plot(start, best, before, after, alpha, png):
    """The two shapes and their Cp against x, one above the other."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = np.linspace(0, 1, 400)
    fig, (cp_ax, shape_ax) = plt.subplots(2, 1, figsize=(8, 6), sharex=True, height_ratios=[2, 1])
    for name, chain, res, style in (("start", start, before, "--"), ("optimised", best, after, "-")):
        xy = chain.evaluate(t)
        shape_ax.plot(xy[:, 0], xy[:, 1], style, label=name)
        cp_ax.plot(res["nodes"][:, 0], res["cp"][0], style, label=f"{name}: CL {res['cl'][0]:.3f}")
    shape_ax.plot(*best.design_points.T, "o", ms=3, label="design points")
    shape_ax.set_aspect("equal")
    shape_ax.set_xlabel("x / chord")
    shape_ax.legend(fontsize=8)
    cp_ax.invert_yaxis()
    cp_ax.set_ylabel("Cp")
    cp_ax.set_title(f"inviscid Cp at {alpha}°")
    cp_ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(png, dpi=120)
    plt.close(fig)


if __name__ == "__main__":
    main()
