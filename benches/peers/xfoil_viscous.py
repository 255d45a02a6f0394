#!/usr/bin/env python3
"""Viscous throughput, side by side in one sitting: XFOIL (ONE process over many shapes, each
swept over α −2…8° by continuation at Re 1e6) against `bezchain bench --kernel viscous`
(256 shapes × the same 11 angles). Both count converged points per second.

    apt-get install -y xfoil xvfb xauth xfonts-base
    cargo build --release
    python3 benches/peers/xfoil_viscous.py [--shapes 30] [--population 256]

The shapes are NACA 4412 (161 points) with smooth random changes of up to ±0.2 % of the chord
(the same recipe as `bezchain bench --kernel viscous`, other random numbers). XFOIL runs each
with LOAD, PANE (160 nodes), OPER, ASEQ -2 8 1 at ITER 200 (a new paneling restarts the boundary layer), its polar accumulated in a
file per shape; XFOIL's converged points are the rows of those files. The machine's load
average is printed with the rates (shared cores: quote the ratio measured in the same run).
"""

import argparse
import json
import math
import os
import random
import subprocess
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
BEZCHAIN = os.path.join(ROOT, "target", "release", "bezchain")


def naca4412(points=161):
    """Selig-order NACA 4412, cosine spacing (upper TE → LE → lower TE)."""
    m, p, t = 0.04, 0.4, 0.12
    half = (points + 1) // 2
    xs = [0.5 * (1 - math.cos(math.pi * k / (half - 1))) for k in range(half)]
    upper, lower = [], []
    for x in xs:
        yt = 5 * t * (0.2969 * math.sqrt(x) - 0.1260 * x - 0.3516 * x**2 + 0.2843 * x**3 - 0.1015 * x**4)
        if x < p:
            yc, dyc = m / p**2 * (2 * p * x - x**2), 2 * m / p**2 * (p - x)
        else:
            yc, dyc = m / (1 - p) ** 2 * (1 - 2 * p + 2 * p * x - x**2), 2 * m / (1 - p) ** 2 * (p - x)
        th = math.atan(dyc)
        upper.append((x - yt * math.sin(th), yc + yt * math.cos(th)))
        lower.append((x + yt * math.sin(th), yc - yt * math.cos(th)))
    return list(reversed(upper)) + lower[1:]


def shapes(count, seed=1):
    rng = random.Random(seed)
    base = naca4412()
    half = len(base) // 2
    amp = 0.002 / 3
    out = []
    for _ in range(count):
        c = [(amp * rng.uniform(-1, 1), amp * rng.uniform(-1, 1)) for _ in range(3)]
        pts = []
        for i, (x, y) in enumerate(base):
            side = 1.0 if i <= half else -1.0
            dy = sum(side * a * math.sin((k + 1) * math.pi * x) + b * math.sin((k + 1) * math.pi * x)
                     for k, (a, b) in enumerate(c))
            pts.append((x, y + dy))
        out.append(pts)
    return out


def is_number(w):
    try:
        float(w)
        return True
    except ValueError:
        return False


def is_row(line):
    """A polar file's data row: at least seven numbers (the header's "1 1 Reynolds number
    fixed ..." is not one)."""
    words = line.split()
    return len(words) >= 7 and all(is_number(w) for w in words[:7])


def time_xfoil(sections, work):
    """Seconds for one XFOIL process over every section, and its converged points."""
    cmds = []
    for k, pts in enumerate(sections):
        with open(os.path.join(work, f"s{k}.dat"), "w") as f:
            f.write(f"shape {k}\n")
            for x, y in pts:
                f.write(f"{x:.8f} {y:.8f}\n")
        cmds += [f"LOAD s{k}.dat", "", "PANE", "OPER"]
        if k == 0:
            cmds += ["VISC 1e6", "ITER 200"]
        # XFOIL keeps at most 12 polars in memory and dies at the 13th: delete each when done.
        cmds += ["PACC", f"p{k}.pol", "", "ASEQ -2 8 1", "PACC", "PDEL 0", ""]
    cmds += ["QUIT", ""]
    start = time.perf_counter()
    run = subprocess.run(["xvfb-run", "-a", "xfoil"], input="\n".join(cmds), text=True, cwd=work,
                         capture_output=True)
    seconds = time.perf_counter() - start
    if "Fortran runtime error" in run.stdout + run.stderr:
        raise SystemExit("XFOIL died: " + (run.stdout + run.stderr).split("Fortran runtime error")[1][:200])
    converged = 0
    for k in range(len(sections)):
        path = os.path.join(work, f"p{k}.pol")
        if os.path.exists(path):
            with open(path) as f:
                converged += sum(1 for l in f if is_row(l))
    return seconds, converged


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--shapes", type=int, default=30, help="shapes XFOIL sweeps")
    ap.add_argument("--population", type=int, default=256, help="bezchain's shapes")
    args = ap.parse_args()
    load = os.getloadavg()
    with tempfile.TemporaryDirectory() as work:
        xs, xc = time_xfoil(shapes(args.shapes), work)
    out = subprocess.run([BEZCHAIN, "bench", "--kernel", "viscous", "--population", str(args.population)],
                         capture_output=True, text=True, check=True)
    report = json.loads(out.stdout)
    xr = xc / xs
    br = report["points_per_second"]
    print(f"load average before: {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}; after: "
          + " ".join(f"{v:.2f}" for v in os.getloadavg()))
    print(f"| XFOIL 6.99, one process | {args.shapes} shapes x 11 angles | {xc}/{args.shapes * 11} converged "
          f"| {xs:.1f} s | {xr:.1f} converged points/s |")
    print(f"| bezchain bench --kernel viscous ({report['threads']} threads) | {report['population']} shapes x 11 angles "
          f"| {report['converged']}/{report['points']} converged | {report['seconds']:.1f} s | {br:.1f} converged points/s |")
    print(f"ratio: {br / xr:.2f}x XFOIL")


if __name__ == "__main__":
    main()
