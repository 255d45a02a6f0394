#!/usr/bin/env python3
"""How far a contour's points stray from any smooth curve through their neighbours.

    python3 benches/peers/contour_noise.py cloud CLOUD.csv [--tol T]
    python3 benches/peers/contour_noise.py aerofoils FILE...

For every point with three neighbours on either side, the seven points are fitted in the
least-squares sense by one cubic per coordinate over their chord-length parameter, and the
point's *residual* is its distance from that fit. On a smooth contour sampled at spacing h
the residual is of order h^4 times the fourth derivative: far below the tolerances of
interest where the spacing is fine for the curvature, but not at a coarsely sampled leading
edge (NACA 4413 at 82 points: 5.1e-4 chords there). Digitising noise of amplitude s gives
residuals of order s, and a corner gives one large residual: read the residuals beside a
fit of the same contour. A fit of low-degree pieces (or any smooth surface) cannot follow a point
whose residual is larger than the tolerance without a break next to it.

`cloud`: a sectioned cloud from `bezchain blade` (columns x,y,z,section,index; sections are
planes z = const). Prints, per section, the largest and the median residual (the data's units)
and, with `--tol`, how many points have a residual above half the tolerance.

`aerofoils`: aerofoil coordinate files (OpenFAST `*_Coords.txt`, whose first coordinate row is
the reference point and is skipped, or two-column `.dat`/text files), or windIO YAML files
(every entry of `airfoils`; needs PyYAML). Residuals in chords.
Needs numpy.
"""
import argparse
import sys

import numpy as np


def residuals(xy):
    """The seven-point local-cubic residual of every interior point of a polyline."""
    p = np.asarray(xy, float)
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(p, axis=0), axis=1))])
    r = np.full(len(p), np.nan)
    for i in range(3, len(p) - 3):
        t = s[i - 3 : i + 4] - s[i]
        if np.ptp(t) <= 0.0:
            continue
        a = np.vander(t / np.ptp(t), 4)
        coef, *_ = np.linalg.lstsq(a, p[i - 3 : i + 4], rcond=None)
        r[i] = np.linalg.norm(coef[-1] - p[i])  # the fit at t = 0 is its constant term
    return r[3:-3]


def numeric_rows(path):
    rows = []
    with open(path) as f:
        for line in f:
            parts = line.replace(",", " ").split()
            try:
                rows.append([float(parts[0]), float(parts[1])])
            except (IndexError, ValueError):
                continue
    return np.array(rows)


def aerofoil_contours(path):
    if path.endswith((".yaml", ".yml")):
        import yaml

        with open(path) as f:
            doc = yaml.safe_load(f)
        afs = doc.get("airfoils") or doc.get("components", {}).get("airfoils", [])
        for a in afs:
            c = a["coordinates"]
            yield a["name"], np.c_[c["x"], c["y"]]
    else:
        rows = numeric_rows(path)
        if path.endswith("_Coords.txt"):
            rows = rows[1:]  # the airfoil reference point
        yield path.rsplit("/", 1)[-1], rows


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="mode", required=True)
    c = sub.add_parser("cloud")
    c.add_argument("cloud")
    c.add_argument("--tol", type=float)
    a = sub.add_parser("aerofoils")
    a.add_argument("files", nargs="+")
    args = ap.parse_args()
    if args.mode == "cloud":
        data = np.genfromtxt(args.cloud, delimiter=",", names=True)
        sec = data["section"].astype(int)
        print("section  points  max residual  median residual" + ("  points above tol/2" if args.tol else ""))
        for k in np.unique(sec):
            rows = data[sec == k]
            rows = rows[np.argsort(rows["index"])]
            r = residuals(np.c_[rows["x"], rows["y"]])
            line = f"{k:7d}  {len(rows):6d}  {np.nanmax(r):12.3e}  {np.nanmedian(r):15.3e}"
            if args.tol:
                line += f"  {int(np.sum(r > args.tol / 2)):19d}"
            print(line)
    else:
        print("aerofoil                                points  max residual (c)  median residual (c)")
        for path in args.files:
            for name, xy in aerofoil_contours(path):
                if len(xy) < 7:
                    print(f"{name}: fewer than 7 points", file=sys.stderr)
                    continue
                r = residuals(xy)
                print(f"{name:38s}  {len(xy):6d}  {np.nanmax(r):16.2e}  {np.nanmedian(r):19.2e}")


if __name__ == "__main__":
    main()
