#!/usr/bin/env python3
"""`bezchain aero --re` against XFOIL 6.99 on aerofoils the project does not ship: 29 UIUC
files of many families (NACA 4/5/6/16-series, Eppler, Selig, Wortmann, Delft, Althaus,
Martin Hepperle, ...) from the aerosandbox 4.2.10 wheel on PyPI, at Re 1e6, Ncrit 9, 160
nodes, α −2…8° by continuation, both codes run now on the same files.

    apt-get install -y xfoil xvfb xauth xfonts-base
    cargo build --release
    python3 benches/peers/unseen_aerofoils.py [--files DIR]

Prints one row per file against the viscous bars (CL within 2 % of max(|CL|, 0.5), CD
within 5 % and median ≤ 2 %, CM within 0.005, transition within 0.03 chord, converged on at
least 95 % of XFOIL's converged points) and the totals.
"""

import argparse
import glob
import os
import statistics
import subprocess
import sys
import tempfile
import zipfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from polar_vs_xfoil import ROOT, ours, xfoil  # noqa: E402

NAMES = ["naca0013", "naca2411", "naca23012", "naca63209", "naca652215", "naca643618", "naca0024",
         "naca16015", "e473", "e603", "e1210", "s1210", "s1221", "s1223rtl", "sd7034", "sd7080",
         "sg6043", "fx63147", "fx74cl5140", "fx77w258", "du84132v", "du8608418",
         "du06-w-200-selig", "ah93w300", "s8038", "lrn1015", "ch10sm", "hq3514", "mh43"]


def fetch(work):
    """The aerosandbox wheel's aerofoil files, unpacked into `work`."""
    subprocess.run([sys.executable, "-m", "pip", "download", "--no-deps", "--quiet", "-d", work,
                    "aerosandbox==4.2.10"], check=True)
    wheel = glob.glob(os.path.join(work, "aerosandbox-*.whl"))[0]
    with zipfile.ZipFile(wheel) as z:
        for n in z.namelist():
            if "/airfoil_database/" in n and n.endswith(".dat"):
                with open(os.path.join(work, os.path.basename(n)), "wb") as f:
                    f.write(z.read(n))
    return work


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--files", help="a folder holding the .dat files (default: fetch the wheel)")
    ap.add_argument("--bezchain", default=os.path.join(ROOT, "target", "release", "bezchain"))
    ap.add_argument("--panels", type=int, default=160,
                    help="panel nodes for both codes (XFOIL's PPAR N; default 160, PANE's)")
    ap.add_argument("--only", help="a comma-separated subset of the file names (without .dat)")
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as work:
        folder = a.files or fetch(work)
        print("| file | compared (XFOIL converged) | CL max | CD max | CD median | CM max | xtr max | bars missed |")
        print("|---|---|---|---|---|---|---|---|")
        tot_x = tot_both = 0
        cds = []
        for name in (a.only.split(",") if a.only else NAMES):
            path = os.path.join(folder, name + ".dat")
            x = xfoil(path, "-2:8:1", "1e6", a.panels)
            b = {round(p[0], 3): p for p in ours(a.bezchain, path, "-2:8:1", "1e6", a.panels)}
            both = [(b[round(q[0], 3)], q) for q in x if round(q[0], 3) in b]
            tot_x += len(x)
            tot_both += len(both)
            if not both:
                print(f"| {name} | 0 ({len(x)}) | | | | | | {'conv' if x else '(XFOIL converged none)'} |")
                continue
            ecl = max(abs(p[1] - q[1]) / max(abs(q[1]), 0.5) for p, q in both)
            e = [abs(p[2] - q[2]) / q[2] for p, q in both]
            cds += e
            ecm = max(abs(p[3] - q[3]) for p, q in both)
            etr = max(max(abs(p[4] - q[4]), abs(p[5] - q[5])) for p, q in both)
            missed = [m for m, bad in [("CL", ecl > 0.02), ("CD", max(e) > 0.05),
                                       ("CD median", statistics.median(e) > 0.02), ("CM", ecm > 0.005),
                                       ("xtr", etr > 0.03), ("conv", len(both) < 0.95 * len(x))] if bad]
            print(f"| {name} | {len(both)} ({len(x)}) | {100 * ecl:.2f} % | {100 * max(e):.2f} % | "
                  f"{100 * statistics.median(e):.2f} % | {ecm:.4f} | {etr:.3f} | {', '.join(missed) or '-'} |")
        print(f"\nconverged on {tot_both} of XFOIL's {tot_x} converged points "
              f"({100 * tot_both / max(tot_x, 1):.1f} %); median CD difference "
              f"{100 * statistics.median(cds):.2f} % over {len(cds)} points")


if __name__ == "__main__":
    main()
