#!/usr/bin/env python3
"""Where an adapted blade grid leaves its cloud: a diagnostic for `adapt-surface` reports.

    python3 benches/peers/grid_sections.py REPORT.json CLOUD.csv [--top 5]

REPORT.json is an `adapt-surface --json` report (its `design_net`, `breaks_u`, `breaks_v`,
`degree` and `continuity` regenerate the grid: clamped knot vectors, each interior break of
multiplicity degree - continuity order); CLOUD.csv the sectioned cloud it was fitted to
(`bezchain blade` columns x,y,z,section,index). For every pair of neighbouring sections it
samples the surface at the span parameter half-way between them (the sections sit at
v_k = (z_k - z_0) / (z_last - z_0), the span rule's) on a dense u grid, and prints the largest
in-plane distance (x, y; the sections are planes z = const) from those surface points to the
nearest cloud point of the two sections, with its u, next to the largest such distance of the
two sections' own points from each other: a surface that follows its cloud stays within
about the latter, a folded or overhanging one leaves it by much more. It also prints the
report's fold check.

It also samples the surface AT every section (v = v_k) and prints, for the sections where it
lies farthest from the section's own points, that distance and its u, and the u range the
section's points cover (each point's foot approximated by the nearest of 200,001 surface
samples): where the surface leaves the cloud at u below the first foot or above the last one,
the grid runs past the section's trailing-edge points (an overhang the fit's own offsets do
not see: no data point is closer to it).

With `--tol T` it also counts, section by section, the points farther than T from the
surface's curve at their section (v = v_k held, as the fit's own foot points are: the
distance to the two sample chords either side of the nearest of the 200,001 samples).
Needs numpy and scipy.
"""
import argparse
import json

import numpy as np
from scipy.interpolate import BSpline
from scipy.spatial import cKDTree


def knots(breaks, degree, continuity):
    order = int(continuity[1:])
    k = [breaks[0]] * (degree + 1)
    for b in breaks[1:-1]:
        k += [b] * (degree - order)
    k += [breaks[-1]] * (degree + 1)
    return np.array(k)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("report")
    ap.add_argument("cloud")
    ap.add_argument("--top", type=int, default=5)
    ap.add_argument("--tol", type=float, help="count the points farther than this, by section")
    args = ap.parse_args()
    r = json.load(open(args.report))
    du, dv = r["degree"]
    ku = knots(r["breaks_u"], du, r["continuity"][0])
    kv = knots(r["breaks_v"], dv, r["continuity"][1])
    net = np.array(r["design_net"])  # rows along u, columns along v, xyz
    bu = BSpline(ku, np.eye(net.shape[0]), du)
    bv = BSpline(kv, np.eye(net.shape[1]), dv)
    d = np.genfromtxt(args.cloud, delimiter=",", names=True)
    sec = d["section"].astype(int)
    pts = np.c_[d["x"], d["y"], d["z"]]
    zs = np.array([pts[sec == k][0, 2] for k in range(sec.max() + 1)])
    v = (zs - zs[0]) / (zs[-1] - zs[0])
    u = np.unique(np.r_[np.linspace(0, 1, 20001), np.linspace(0, 0.02, 4001), np.linspace(0.98, 1, 4001)])
    Bu = bu(u)
    rows = []
    for k in range(len(v) - 1):
        vm = 0.5 * (v[k] + v[k + 1])
        s = Bu @ np.einsum("j,ijc->ic", bv([vm])[0], net)
        a, b = pts[sec == k][:, :2], pts[sec == k + 1][:, :2]
        dist, _ = cKDTree(np.r_[a, b]).query(s[:, :2])
        apart = max(cKDTree(a).query(b)[0].max(), cKDTree(b).query(a)[0].max())
        w = dist.argmax()
        rows.append((dist[w], k, vm, u[w], apart))
    rows.sort(reverse=True)
    print(f"{args.report}: surface half-way between neighbouring sections, farthest from the cloud")
    for dist, k, vm, uw, apart in rows[: args.top]:
        print(f"  sections {k}-{k + 1} (v {vm:.4f}): {dist:.3e} at u {uw:.5f} (the sections {apart:.3e} apart)")
    fine = np.linspace(0, 1, 200001)
    Bf = bu(fine)
    at, beyond = [], []
    for k in range(len(v)):
        s = (Bf @ np.einsum("j,ijc->ic", bv([v[k]])[0], net))[:, :2]
        a = pts[sec == k][:, :2]
        dist, _ = cKDTree(a).query(s)
        _, foot = cKDTree(s).query(a)
        if args.tol is not None:
            off = np.full(len(a), np.inf)
            for i0 in (np.maximum(foot - 1, 0), foot):
                p0, d0 = s[i0], s[np.minimum(i0 + 1, len(s) - 1)] - s[i0]
                t = np.clip(np.sum((a - p0) * d0, axis=1) / np.maximum(np.sum(d0 * d0, axis=1), 1e-300), 0, 1)
                off = np.minimum(off, np.linalg.norm(a - p0 - t[:, None] * d0, axis=1))
            beyond.append((k, int(np.sum(off > args.tol)), off.max()))
        w = dist.argmax()
        at.append((dist[w], k, fine[w], fine[foot].min(), fine[foot].max()))
    at.sort(reverse=True)
    print(f"{args.report}: surface at the sections, farthest from the section's own points")
    for dist, k, uw, lo, hi in at[: args.top]:
        print(f"  section {k} (v {v[k]:.4f}): {dist:.3e} at u {uw:.5f} (its points' feet cover u {lo:.5f} to {hi:.5f})")
    if args.tol is not None:
        total = sum(n for _, n, _ in beyond)
        print(f"{args.report}: {total} points farther than {args.tol:.4g} from their section's curve")
        for k, n, m in beyond:
            if n:
                print(f"  section {k}: {n} points, the farthest {m:.3e}")
    fold = r.get("adapt", {}).get("fold")
    if fold:
        print(f"  fold check: {fold['max_turn_deg']:.1f} deg at u {fold['at'][0]:.5f}, v {fold['at'][1]:.5f}")


if __name__ == "__main__":
    main()
