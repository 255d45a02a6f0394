#!/usr/bin/env python3
"""One aerofoil's viscous polar from `bezchain aero --re` drawn over XFOIL 6.99's, run now on
the same file with the same settings (PANE: 160 nodes, Re 1e6, Ncrit 9, ITER 200, α by
continuation with ASEQ). The README's polar picture is made by

    apt-get install -y xfoil xvfb xauth xfonts-base
    pip install matplotlib
    python3 benches/peers/polar_vs_xfoil.py data/airfoils/e387.dat -o docs/e387_polar_xfoil.png

Points where a code did not converge are left out of its curve (bezchain marks them in its
JSON; XFOIL writes no row). The largest differences where both converged are printed.
"""

import argparse
import json
import os
import signal
import subprocess
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def ours(binary, path, alphas, re, panels=160):
    """bezchain's converged points: (alpha, cl, cd, cm, xtr_top, xtr_bottom)."""
    out = subprocess.run(
        [binary, "aero", path, "--re", str(re), "--alpha", alphas, "--panels", str(panels), "--json", "-"],
        check=True, capture_output=True, text=True,
    ).stdout
    rows = [p for p in json.loads(out)["polar"] if p["converged"]]
    return [(p["alpha"], p["cl"], p["cd"], p["cm"], p["xtr_top"], p["xtr_bottom"]) for p in rows]


def xfoil(path, alphas, re, panels=160):
    """XFOIL's converged points (its polar file's rows): (alpha, cl, cd, cm, xtr_top,
    xtr_bottom). `panels`: PANE's node count (PPAR N)."""
    start, stop, step = alphas.split(":")
    with tempfile.TemporaryDirectory() as d:
        with open(path) as src, open(os.path.join(d, "a.dat"), "w") as dst:
            dst.write(src.read())
        pane = "PANE" if panels == 160 else f"PPAR\nN {panels}\n\n"
        script = (f"LOAD a.dat\n\n{pane}\nOPER\nVISC {re}\nITER 200\nPACC\npol.txt\n\n"
                  f"ASEQ {start} {stop} {step}\n\nQUIT\n")
        # XFOIL can loop forever on a file it cannot panel: what it wrote by then counts. Its
        # own process group is ended, not every XFOIL on the machine.
        run = subprocess.Popen(["xvfb-run", "-a", "xfoil"], stdin=subprocess.PIPE, cwd=d, text=True,
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                               start_new_session=True)
        try:
            run.communicate(script, timeout=120)
        except subprocess.TimeoutExpired:
            os.killpg(run.pid, signal.SIGKILL)
            run.wait()
        rows = []
        if not os.path.exists(os.path.join(d, "pol.txt")):
            return []
        with open(os.path.join(d, "pol.txt")) as f:
            for line in f:
                words = line.split()
                try:
                    v = [float(w) for w in words]
                except ValueError:
                    continue
                if len(v) >= 7:
                    rows.append((v[0], v[1], v[2], v[4], v[5], v[6]))
        return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("file")
    ap.add_argument("-o", "--output", required=True, help="the picture (PNG or SVG)")
    ap.add_argument("--alpha", default="-2:8:1", help="start:stop:step, degrees")
    ap.add_argument("--re", default="1e6")
    ap.add_argument("--bezchain", default=os.path.join(ROOT, "target", "release", "bezchain"))
    a = ap.parse_args()

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    b = ours(a.bezchain, a.file, a.alpha, a.re)
    x = xfoil(a.file, a.alpha, a.re)
    name = open(a.file).readline().strip() or os.path.basename(a.file)
    print(f"{a.file}: bezchain {len(b)} converged points, XFOIL {len(x)}")
    both = [(p, q) for p in b for q in x if abs(p[0] - q[0]) < 1e-6]
    if both:
        dcl = max(abs(p[1] - q[1]) / max(abs(q[1]), 0.5) for p, q in both)
        dcd = max(abs(p[2] - q[2]) / q[2] for p, q in both)
        dcm = max(abs(p[3] - q[3]) for p, q in both)
        print(f"where both converged ({len(both)}): CL within {100 * dcl:.2f} %, "
              f"CD within {100 * dcd:.2f} %, CM within {dcm:.4f}")

    fig, ax = plt.subplots(1, 3, figsize=(12, 4))
    panels = [(0, 1, "α (°)", "CL"), (2, 1, "CD", "CL"), (0, 3, "α (°)", "CM")]
    for k, (i, j, xl, yl) in enumerate(panels):
        ax[k].plot([r[i] for r in b], [r[j] for r in b], "-o", ms=4, color="#1f4e9c", label="bezchain")
        ax[k].plot([r[i] for r in x], [r[j] for r in x], "s", ms=7, mfc="none", color="#c0392b",
                   label="XFOIL 6.99")
        ax[k].set_xlabel(xl)
        ax[k].set_ylabel(yl)
        ax[k].grid(alpha=0.3)
    ax[0].legend()
    fig.suptitle(f"{name}: viscous polar at Re {float(a.re):.0e}, Ncrit 9, 160 panel nodes")
    fig.tight_layout()
    fig.savefig(a.output, dpi=110)


if __name__ == "__main__":
    main()
