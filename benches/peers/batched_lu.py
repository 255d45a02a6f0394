#!/usr/bin/env python3
"""What a GPU would give the viscous Newton step's dense solve.

Each Newton iteration of `bezchain aero --re` factors one dense system in the edge velocities
(the Schur complement of the boundary-layer blocks, about 186 square at 160 panels) and solves
it. A population of 256 shapes x 11 angles takes about ten iterations a point. This script
times that algebra for a whole population at once: LU factorisation and one solve of B systems
of size n in float64, batched through PyTorch on the GPU (cuSOLVER/cuBLAS, the fastest batched
LU at hand there) and, for scale, one at a time through numpy/LAPACK on one CPU thread.

It checks every solve's relative residual before reporting, and prints the medians of 5 timed
runs after a warm-up.

Usage: python3 benches/peers/batched_lu.py [--n 186] [--batch 2816]
"""

import argparse
import os
import time

# One BLAS thread for the CPU side: OpenBLAS reads this when numpy first loads it.
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402


def systems(batch, n, seed):
    """Diagonally weighted random systems: well conditioned, as the Newton matrices near a
    converged point are, and never zeros."""
    rng = np.random.default_rng(seed)
    a = rng.standard_normal((batch, n, n)) + n * np.eye(n)[None]
    b = rng.standard_normal((batch, n, 1))
    return a, b


def residual(a, x, b):
    r = np.einsum("bij,bjk->bik", a, x) - b
    return float(np.max(np.linalg.norm(r, axis=1) / np.linalg.norm(b, axis=1)))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--n", type=int, default=186)
    ap.add_argument("--batch", type=int, default=2816)
    ap.add_argument("--cpu-sample", type=int, default=64, help="systems timed on the CPU")
    args = ap.parse_args()
    a, b = systems(args.batch, args.n, 1)
    flops = args.batch * (2 * args.n**3 / 3 + 2 * args.n**2)

    import torch

    dev = torch.device("cuda")
    ta, tb = torch.from_numpy(a).to(dev), torch.from_numpy(b).to(dev)

    def gpu():
        lu, piv = torch.linalg.lu_factor(ta)
        return torch.linalg.lu_solve(lu, piv, tb)

    x = gpu()
    torch.cuda.synchronize()
    res = residual(a, x.cpu().numpy(), b)
    times = []
    for _ in range(5):
        start = torch.cuda.Event(enable_timing=True)
        end = torch.cuda.Event(enable_timing=True)
        start.record()
        gpu()
        end.record()
        torch.cuda.synchronize()
        times.append(start.elapsed_time(end) / 1e3)
    g = float(np.median(times))

    import scipy.linalg as sl

    k = min(args.cpu_sample, args.batch)
    ct = []
    for _ in range(5):
        t0 = time.perf_counter()
        for i in range(k):
            sl.lu_solve(sl.lu_factor(a[i], check_finite=False), b[i], check_finite=False)
        ct.append((time.perf_counter() - t0) / k)
    c = float(np.median(ct))
    print(f"{args.batch} systems of {args.n} (float64), LU + one solve; worst relative residual {res:.1e}")
    print(f"  GPU {torch.cuda.get_device_name()} batched (torch {torch.__version__}): "
          f"{g * 1e3:.2f} ms, {flops / g / 1e9:.0f} GFLOP/s, {g / args.batch * 1e6:.2f} us a system")
    print(f"  CPU LAPACK one thread, one at a time: {c * 1e6:.1f} us a system "
          f"({c * args.batch * 1e3:.1f} ms for the batch); GPU/CPU-thread speed-up {c * args.batch / g:.0f}x")


if __name__ == "__main__":
    main()
