#!/usr/bin/env python3
"""Inviscid panel-method throughput, side by side in one sitting: XFOIL (one process, 100
shapes, timed whole and less its start-up), AeroSandbox's AirfoilInviscid (--asb-shapes shapes
after one warm-up), and `bezchain bench
--kernel aero` on the CPU and on the GPU backend (lavapipe where that is the adapter).

    apt-get install -y xfoil xvfb xauth && pip install aerosandbox
    cargo build --release
    python3 benches/peers/aero.py [--shapes 100] [--repeat 3]

Every tool solves NACA 4-digit sections (160 panel nodes: XFOIL's PANE, AeroSandbox repaneled
to 80 points a side) at 4°; the rates are shapes per second, medians of --repeat runs, and the
machine's load average is printed with them (two shared cores here: quote ratios measured in
the same run, not absolute rates).
"""

import argparse
import contextlib
import json
import math
import os
import statistics
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
BEZCHAIN = os.path.join(ROOT, "target", "release", "bezchain")


def naca4(m, p, t, points=161):
    """Selig-order coordinates of NACA 4-digit (m, p, t as chord fractions), cosine spacing."""
    half = (points + 1) // 2
    xs = [0.5 * (1 - math.cos(math.pi * k / (half - 1))) for k in range(half)]
    upper, lower = [], []
    for x in xs:
        yt = 5 * t * (0.2969 * math.sqrt(x) - 0.1260 * x - 0.3516 * x**2 + 0.2843 * x**3 - 0.1015 * x**4)
        if m == 0:
            yc, dyc = 0.0, 0.0
        elif x < p:
            yc, dyc = m / p**2 * (2 * p * x - x**2), 2 * m / p**2 * (p - x)
        else:
            yc, dyc = m / (1 - p) ** 2 * (1 - 2 * p + 2 * p * x - x**2), 2 * m / (1 - p) ** 2 * (p - x)
        th = math.atan(dyc)
        upper.append((x - yt * math.sin(th), yc + yt * math.cos(th)))
        lower.append((x + yt * math.sin(th), yc - yt * math.cos(th)))
    return list(reversed(upper)) + lower[1:]


def shapes(count):
    """`count` different NACA 4-digit sections: camber 0-6 %, its position 30-50 %, 9-18 % thick."""
    out = []
    for k in range(count):
        m = (k % 7) / 100
        p = (3 + k % 3) / 10
        t = (9 + k % 10) / 100
        out.append((f"NACA {int(m * 100)}{int(p * 10)}{int(round(t * 100)):02d}", naca4(m, p, t)))
    return out


def write_dat(path, name, pts):
    with open(path, "w") as f:
        f.write(name + "\n")
        for x, y in pts:
            f.write(f"{x:.8f} {y:.8f}\n")


def time_xfoil(sections, work):
    """Seconds for one XFOIL process to load, panel and solve every section at 4° (start-up
    and exit included), and the seconds of a process that solves none."""
    def run(n):
        cmds = []
        for k in range(n):
            cmds += [f"LOAD s{k}.dat", "", "PANE", "OPER", "ALFA 4", ""]
        cmds += ["QUIT", ""]
        start = time.perf_counter()
        out = subprocess.run(["xvfb-run", "-a", "xfoil"], input="\n".join(cmds), text=True,
                             cwd=work, capture_output=True)
        seconds = time.perf_counter() - start
        # In this mode XFOIL draws CL instead of printing it; each solve announces itself.
        return seconds, out.stdout.count("Calculating unit vorticity distributions")

    for k, (name, pts) in enumerate(sections):
        write_dat(os.path.join(work, f"s{k}.dat"), name, pts)
    base, _ = run(0)
    total, solved = run(len(sections))
    if solved < len(sections):
        raise SystemExit(f"XFOIL solved {solved} of {len(sections)} sections")
    return total, base


def time_aerosandbox(sections):
    """Seconds for AeroSandbox's AirfoilInviscid on every section at 4° (after one warm-up)."""
    import aerosandbox as asb

    foils = [asb.Airfoil(name=n, coordinates=pts).repanel(n_points_per_side=80) for n, pts in sections]
    op = asb.OperatingPoint(velocity=1, alpha=4)
    # IPOPT reports every solve on standard output: sent to /dev/null (at the descriptor).
    with open(os.devnull, "w") as null, contextlib.redirect_stdout(null):
        saved = os.dup(1)
        os.dup2(null.fileno(), 1)
        try:
            asb.AirfoilInviscid(airfoil=[foils[0]], op_point=op)
            start = time.perf_counter()
            cls = [float(asb.AirfoilInviscid(airfoil=[f], op_point=op).Cl) for f in foils]
            seconds = time.perf_counter() - start
        finally:
            os.dup2(saved, 1)
            os.close(saved)
    assert all(math.isfinite(c) for c in cls)
    return seconds


def bezchain_rate(backend, population):
    out = subprocess.run([BEZCHAIN, "bench", "--kernel", "aero", "--backend", backend, "--population",
                          str(population), "--runs", "5"], capture_output=True, text=True, check=True)
    report = json.loads(out.stdout)
    return report["shapes_per_second"], report["adapter"]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--shapes", type=int, default=100)
    ap.add_argument("--asb-shapes", type=int, default=20,
                    help="shapes for AeroSandbox (about 2 s each here)")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--population", type=int, default=1024, help="bezchain's population per call")
    ap.add_argument("--skip-gpu", action="store_true")
    args = ap.parse_args()
    sections = shapes(args.shapes)
    rates = {"xfoil (one process, start-up included)": [], "xfoil (start-up subtracted)": [],
             "aerosandbox": [], "bezchain cpu": [], "bezchain gpu": []}
    adapters = {}
    with tempfile.TemporaryDirectory() as work:
        for _ in range(args.repeat):
            total, base = time_xfoil(sections, work)
            rates["xfoil (one process, start-up included)"].append(args.shapes / total)
            if total > base:
                rates["xfoil (start-up subtracted)"].append(args.shapes / (total - base))
            rates["aerosandbox"].append(args.asb_shapes / time_aerosandbox(sections[: args.asb_shapes]))
            r, adapters["bezchain cpu"] = bezchain_rate("cpu", args.population)
            rates["bezchain cpu"].append(r)
            if not args.skip_gpu:
                r, adapters["bezchain gpu"] = bezchain_rate("gpu", args.population)
                rates["bezchain gpu"].append(r)
    load = os.getloadavg()
    print(f"load average {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}, {os.cpu_count()} CPUs, {args.repeat} runs")
    print("| tool | shapes/s (median) | runs | × XFOIL |")
    print("|---|---|---|---|")
    xfoil = statistics.median(rates["xfoil (one process, start-up included)"])
    for tool, rs in rates.items():
        if not rs:
            continue
        med = statistics.median(rs)
        label = tool + (f" ({adapters[tool]})" if tool in adapters else "")
        print(f"| {label} | {med:.1f} | {', '.join(f'{r:.1f}' for r in rs)} | {med / xfoil:.1f} |")


if __name__ == "__main__":
    sys.exit(main())
