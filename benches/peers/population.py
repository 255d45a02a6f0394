#!/usr/bin/env python3
"""The population evaluator against JAX and numpy on the same workload.

The workload is `bezchain bench`'s: a 2 x 2 bicubic C1 patch grid (6 x 6 design points, 108
variables), P individuals perturbed around a base design, N target points with fixed
parameters; per individual the sum of squared offsets and the largest offset.

The script builds the problem (seeded), writes it as the files `bezchain eval` reads (a
surface report, the points, the population with the base design first), and

1. checks the fitness of JAX (f32), numpy (f32) and `bezchain eval --newton 0` against numpy
   in f64: the points lie on the base design's normals, so the base's closest points, which
   `bezchain eval` starts from, are the sampled parameters the peers use;
2. times the three alternately, one population each per round: JAX jit-compiled, 128
   individuals at a time, one matrix product per patch (its fastest form we know); numpy, 32
   at a time, one dense matrix product; bezchain via `bezchain eval --repeat`, which
   evaluates the same files again and again in one process. The medians over the rounds are
   reported, with bezchain's speed-up over the best peer.

Usage: python3 benches/peers/population.py [--bezchain target/release/bezchain]
       [--population 1024] [--points 4096] [--rounds 7] [--backend cpu] [--jax-chunk 128]
Needs numpy and `pip install "jax[cpu]"`.
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

import numpy as np

DEGREE = 3
PATCHES = 2
NU = PATCHES * DEGREE + 1  # control points a direction
ND = NU - 1  # design points a direction (one C1 join generated per interior break)


def extraction():
    """The C1 extraction map of one direction (NU x ND): uniform breaks, so each join point is
    the midpoint of its neighbours. `bezchain sample` checks it against the library's map."""
    e = np.zeros((NU, ND))
    d = 0
    for r in range(NU):
        if r % DEGREE == 0 and 0 < r < NU - 1:
            e[r, d - 1] = 0.5
            e[r, d] = 0.5
        else:
            e[r, d] = 1.0
            d += 1
    return e


def bernstein(t):
    """Cubic Bernstein values at the parameters t (..., 4)."""
    s = 1.0 - t
    return np.stack([s**3, 3 * s * s * t, 3 * s * t * t, t**3], axis=-1)


def bernstein_deriv(t):
    s = 1.0 - t
    return np.stack([-3 * s * s, 3 * s * s - 6 * s * t, 6 * s * t - 3 * t * t, 3 * t * t], axis=-1)


def locate(g):
    """Patch index and local parameter of global parameters g (uniform breaks)."""
    i = np.minimum((g * PATCHES).astype(int), PATCHES - 1)
    return i, g * PATCHES - i


def surface(net, u, v, deriv=(0, 0)):
    """Points (or partials) of the control net (NU, NU, 3) at global (u, v)."""
    iu, a = locate(u)
    iv, b = locate(v)
    bu = bernstein_deriv(a) * PATCHES if deriv[0] else bernstein(a)
    bv = bernstein_deriv(b) * PATCHES if deriv[1] else bernstein(b)
    out = np.zeros(u.shape + (3,))
    for i in range(4):
        for j in range(4):
            out += (bu[:, i] * bv[:, j])[:, None] * net[iu * DEGREE + i, iv * DEGREE + j]
    return out


class Problem:
    def __init__(self, population, points, seed):
        rng = np.random.default_rng(seed)
        x, y = np.meshgrid(np.linspace(0, 1, ND), np.linspace(0, 1, ND), indexing="ij")
        base = np.stack([x, y, 0.2 * np.sin(np.pi * x) * np.cos(2 * y)], axis=-1)
        self.E = extraction()
        self.base = base
        net = np.einsum("ia,abk,jb->ijk", self.E, base, self.E)
        u, v = rng.random(points), rng.random(points)
        # Points off the base surface along its unit normal: their closest points on it are (u, v).
        n = np.cross(surface(net, u, v, (1, 0)), surface(net, u, v, (0, 1)))
        n /= np.linalg.norm(n, axis=1, keepdims=True)
        self.q = surface(net, u, v) + n * rng.normal(0.0, 1e-3, (points, 1))
        self.u, self.v = u, v
        pop = base[None] + rng.normal(0.0, 1e-2, (population,) + base.shape)
        pop[0] = base
        self.pop = pop.astype(np.float32)  # what every tool evaluates, rounded as bezchain reads it
        # Per patch: its points, their basis products (from f64) and its 16 control points.
        iu, a = locate(u)
        iv, b = locate(v)
        patch = iu * PATCHES + iv
        self.order = np.argsort(patch, kind="stable")
        w = (bernstein(a)[:, :, None] * bernstein(b)[:, None, :]).reshape(points, 16)
        self.patches = []
        for p in range(PATCHES * PATCHES):
            sel = np.nonzero(patch == p)[0]
            i, j = divmod(p, PATCHES)
            idx = [(i * DEGREE + a) * NU + j * DEGREE + b for a in range(4) for b in range(4)]
            self.patches.append((w[sel], self.q[sel], np.array(idx)))
        # The dense design-point basis: point k's offset is dense[k] . design - q.
        full = np.zeros((points, NU * NU))
        for p, (wp, _, idx) in enumerate(self.patches):
            sel = np.nonzero(patch == p)[0]
            full[np.ix_(sel, idx)] = wp
        e2 = np.kron(self.E, self.E)  # (NU*NU, ND*ND)
        self.dense = full @ e2

    def write(self, folder):
        """The report, points and population files of `bezchain eval`."""
        net = np.einsum("ia,abk,jb->ijk", self.E, self.base, self.E)
        breaks = [k / PATCHES for k in range(PATCHES + 1)]
        report = {
            "kind": "surface",
            "dimension": 3,
            "degree": [DEGREE, DEGREE],
            "patches": [PATCHES, PATCHES],
            "continuity": ["C1", "C1"],
            "breaks_u": breaks,
            "breaks_v": breaks,
            "design_net": self.base.tolist(),
            "control_net": net.tolist(),
            "continuity_error": 0.0,
            "offset": {"metric": "closest", "sum_sq": 0.0, "sum": 0.0, "rms": 0.0, "max": 0.0,
                       "max_at": [0.0, 0.0, 0.0]},
            "fit": {"method": "peers", "iterations": 0, "evaluations": 0, "seconds": 0.0,
                    "backend": "none"},
            "input": {"path": "points.csv", "points": len(self.q)},
        }
        paths = {k: os.path.join(folder, f) for k, f in
                 [("report", "report.json"), ("points", "points.csv"), ("pop", "pop.csv")]}
        with open(paths["report"], "w") as f:
            json.dump(report, f)
        np.savetxt(paths["points"], self.q, delimiter=",", header="x,y,z", comments="", fmt="%.17g")
        np.savetxt(paths["pop"], self.pop.reshape(len(self.pop), -1), delimiter=",", fmt="%.9g")
        return paths


def numpy_fitness(problem, dtype, chunk=32):
    """numpy, `chunk` individuals at a time, one dense matrix product each."""
    dense = problem.dense.astype(dtype)
    q = problem.q.astype(dtype)
    out = np.empty((len(problem.pop), 2), dtype=np.float64)
    flat = problem.pop.reshape(len(problem.pop), ND * ND, 3).astype(dtype)
    for s in range(0, len(flat), chunk):
        d = flat[s:s + chunk]  # (c, 36, 3)
        pts = np.tensordot(dense, d, axes=([1], [1]))  # (N, c, 3)
        e2 = ((pts - q[:, None, :]) ** 2).sum(axis=2)  # (N, c)
        out[s:s + chunk, 0] = e2.sum(axis=0)
        out[s:s + chunk, 1] = np.sqrt(e2.max(axis=0))
    return out


def make_jax(problem, chunk=128):
    """JAX, jit-compiled, `chunk` individuals at a time, one matrix product per patch (on the
    CPU 128 is its fastest chunk we know; on a GPU a whole population at once fills it)."""
    import jax
    import jax.numpy as jnp

    e = jnp.asarray(problem.E, dtype=jnp.float32)
    patches = [(jnp.asarray(w, dtype=jnp.float32), jnp.asarray(q, dtype=jnp.float32), jnp.asarray(idx))
               for w, q, idx in problem.patches]

    @jax.jit
    def fitness(d):  # (c, ND, ND, 3)
        net = jnp.einsum("ia,cabk,jb->cijk", e, d, e).reshape(d.shape[0], NU * NU, 3)
        total = jnp.zeros(d.shape[0], dtype=jnp.float32)
        worst = jnp.zeros(d.shape[0], dtype=jnp.float32)
        for w, q, idx in patches:
            pts = jnp.einsum("nk,ckd->cnd", w, net[:, idx, :])
            e2 = jnp.sum((pts - q[None]) ** 2, axis=2)
            total = total + e2.sum(axis=1)
            worst = jnp.maximum(worst, e2.max(axis=1))
        return total, jnp.sqrt(worst)

    pop = jnp.asarray(problem.pop)
    p = len(problem.pop)
    pad = (-p) % chunk
    if pad:
        pop = jnp.concatenate([pop, jnp.repeat(pop[:1], pad, axis=0)])

    def run():
        parts = [fitness(pop[s:s + chunk]) for s in range(0, len(pop), chunk)]
        s = jnp.concatenate([a for a, _ in parts])[:p]
        m = jnp.concatenate([b for _, b in parts])[:p]
        s.block_until_ready()
        return np.stack([np.asarray(s, dtype=np.float64), np.asarray(m, dtype=np.float64)], axis=1)

    return run, jax.__version__


def jax_device():
    import jax

    d = jax.devices()[0]
    return f"{d.platform} ({getattr(d, 'device_kind', '?')})"


def bezchain(binary, paths, backend, repeat):
    """`bezchain eval --newton 0` on the files: the fitness and the median seconds of one
    evaluation over `repeat` timed ones (one process, the evaluator built once)."""
    out = subprocess.run(
        [binary, "eval", paths["report"], "--population", paths["pop"], "--points", paths["points"],
         "--backend", backend, "--newton", "0", "--repeat", str(repeat), "-o", "-"],
        check=True, capture_output=True, text=True)
    fit = np.array([[float(x) for x in line.split(",")] for line in out.stdout.split()])
    seconds = None
    for line in out.stderr.splitlines():
        if line.startswith("median of"):
            seconds = float(line.split(":")[1].split()[0])
    return fit, seconds, out.stderr.splitlines()[0]


def worst_relative(a, b):
    return float(np.max(np.abs(a[:, 0] - b[:, 0]) / np.maximum(np.abs(a[:, 0]), np.abs(b[:, 0]))))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--bezchain", default="target/release/bezchain")
    ap.add_argument("--population", type=int, default=1024)
    ap.add_argument("--points", type=int, default=4096)
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--backend", default="cpu")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--jax-chunk", type=int, default=128, help="individuals per JAX call")
    args = ap.parse_args()

    problem = Problem(args.population, args.points, args.seed)
    truth = numpy_fitness(problem, np.float64)
    jax_run, jax_version = make_jax(problem, min(args.jax_chunk, args.population))
    with tempfile.TemporaryDirectory() as folder:
        paths = problem.write(folder)
        # The report's control net is checked against bezchain's own map by `sample`.
        subprocess.run([args.bezchain, "sample", paths["report"], "--u", "3", "--v", "3",
                        "--backend", "cpu", "-o", os.path.join(folder, "check.csv")],
                       check=True, capture_output=True)
        bz_fit, _, adapter = bezchain(args.bezchain, paths, args.backend, 0)
        jax_fit = jax_run()
        np_fit = numpy_fitness(problem, np.float32)
        print(f"P {args.population} x N {args.points}, 2 x 2 bicubic grid, fixed parameters; "
              f"JAX {jax_version} on {jax_device()}, numpy {np.__version__}; bezchain: {adapter}")
        print("fitness against numpy f64 (largest relative difference of sum_sq):")
        for name, fit in [("bezchain eval", bz_fit), ("JAX f32", jax_fit), ("numpy f32", np_fit)]:
            print(f"  {name:14s} {worst_relative(fit, truth):.1e}")
        times = {"bezchain": [], "jax": [], "numpy": []}
        for _ in range(args.rounds):
            _, t, _ = bezchain(args.bezchain, paths, args.backend, 5)
            times["bezchain"].append(t)
            start = time.perf_counter()
            jax_run()
            times["jax"].append(time.perf_counter() - start)
            start = time.perf_counter()
            numpy_fitness(problem, np.float32)
            times["numpy"].append(time.perf_counter() - start)
    med = {k: float(np.median(v)) for k, v in times.items()}
    print(f"median seconds per population over {args.rounds} alternating rounds:")
    for k, label in [("bezchain", f"bezchain eval ({args.backend}, median of 5 a round)"),
                     ("jax", f"JAX jit, {min(args.jax_chunk, args.population)} at a time, per-patch matmul"),
                     ("numpy", "numpy f32, 32 at a time, dense matmul")]:
        print(f"  {label:48s} {med[k] * 1e3:8.2f} ms")
    best = min(med["jax"], med["numpy"])
    print(f"bezchain is {best / med['bezchain']:.2f}x the best peer")


if __name__ == "__main__":
    sys.exit(main())
