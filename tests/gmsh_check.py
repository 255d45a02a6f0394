#!/usr/bin/env python3
"""Load a bezchain STEP or IGES file with gmsh (OpenCASCADE inside) and check it against
points sampled from the report it came from.

    python3 tests/gmsh_check.py FILE SAMPLES.csv [--unit m|mm|default] [--mesh-size H]
                                [--bbox-only]

SAMPLES.csv has a header `x,y,z` (and `t`, or `u,v`: the parameters the points were sampled
at) and points on the exported curve or surface, in metres (the data's units), computed by
bezchain's own evaluation of the chain or grid. `--unit` is the unit gmsh reads the file into
(OpenCASCADE converts from the unit the file declares; `default` leaves OpenCASCADE's own
choice, millimetres); the samples are converted to it, and every length printed (and H) is in
it. Prints one JSON object: the entities gmsh imported (dimension, tag, type); their bounding
box `[xmin, ymin, zmin, xmax, ymax, zmax]` (as gmsh reports it, padded by about 1e-7); with
`--bbox-only` nothing more, otherwise the largest distance from a sample to the closest point gmsh's `getClosestPoint` finds on the
imported entity (`max_distance_gmsh`); the largest distance from a sample to the imported
entity (`max_distance`), the nearer of two closest points found by Newton steps on gmsh's own
evaluation of the entity, one started at gmsh's answer and one at the sample's parameters
(OpenCASCADE's projection stops at about 1e-8 where a curve comes near itself, as an aerofoil
does at its trailing edge, and is trapped by a surface that folds over itself); and the node
count of the mesh gmsh makes of it.
Used by the opt-in test tests/cad_export.rs (BEZCHAIN_GMSH=1); needs
`pip install gmsh numpy`.
"""
import argparse
import csv
import json
import sys

import gmsh
import numpy as np


def refine(dim, tag, q, closest, steps=30):
    """Distances from `q` to the entity after Newton steps on gmsh's own evaluation, started
    at gmsh's closest points; never more than gmsh's own answer."""
    t = np.array(gmsh.model.getParametrization(dim, tag, closest.ravel())).reshape(len(q), dim)
    lo, hi = gmsh.model.getParametrizationBounds(dim, tag)
    lo, hi = np.array(lo), np.array(hi)
    for _ in range(steps):
        p = np.array(gmsh.model.getValue(dim, tag, t.ravel())).reshape(-1, 3)
        d1 = np.array(gmsh.model.getDerivative(dim, tag, t.ravel())).reshape(len(q), dim, 3)
        d2 = np.array(gmsh.model.getSecondDerivative(dim, tag, t.ravel()))
        r = p - q
        g = np.einsum("nk,ndk->nd", r, d1)
        if dim == 1:
            h = (np.einsum("ndk,ndk->n", d1, d1) + np.einsum("nk,nk->n", r, d2.reshape(-1, 3)))[:, None, None]
        else:
            s = d2.reshape(-1, 3, 3)  # uu, uv, vv
            huu = np.einsum("nk,nk->n", d1[:, 0], d1[:, 0]) + np.einsum("nk,nk->n", r, s[:, 0])
            huv = np.einsum("nk,nk->n", d1[:, 0], d1[:, 1]) + np.einsum("nk,nk->n", r, s[:, 1])
            hvv = np.einsum("nk,nk->n", d1[:, 1], d1[:, 1]) + np.einsum("nk,nk->n", r, s[:, 2])
            h = np.stack([np.stack([huu, huv], -1), np.stack([huv, hvv], -1)], -2)
        det_ok = np.abs(np.linalg.det(h)) > 1e-300
        step = np.zeros_like(t)
        step[det_ok] = np.linalg.solve(h[det_ok], g[det_ok][..., None])[..., 0]
        t = np.clip(t - step, lo, hi)
    p = np.array(gmsh.model.getValue(dim, tag, t.ravel())).reshape(-1, 3)
    return np.minimum(np.linalg.norm(p - q, axis=1), np.linalg.norm(closest - q, axis=1))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("file")
    ap.add_argument("samples")
    ap.add_argument("--unit", default="m", choices=["m", "mm", "default"])
    ap.add_argument("--mesh-size", type=float, default=0.0)
    ap.add_argument("--bbox-only", action="store_true")
    a = ap.parse_args()
    per_metre = 1.0 if a.unit == "m" else 1000.0
    with open(a.samples, newline="") as f:
        rows = list(csv.DictReader(f))
    pts = [tuple(per_metre * float(r[k]) for k in "xyz") for r in rows]
    names = ["t"] if rows and "t" in rows[0] else ["u", "v"] if rows and "u" in rows[0] else []
    params = np.array([[float(r[k]) for k in names] for r in rows]) if names else None

    gmsh.initialize(["gmsh", "-v", "0"])
    try:
        if a.unit != "default":
            # OpenCASCADE knows the unit setting only once a reader has run, so read the file
            # once first.
            gmsh.model.occ.importShapes(a.file)
            gmsh.model.remove()
            gmsh.model.add("check")
            gmsh.option.setString("Geometry.OCCTargetUnit", "M" if a.unit == "m" else "MM")
        gmsh.model.occ.importShapes(a.file)
        gmsh.model.occ.synchronize()
        entities = []
        for dim in (1, 2, 3):
            for _, tag in gmsh.model.getEntities(dim):
                entities.append({"dim": dim, "tag": tag, "type": gmsh.model.getType(dim, tag)})
        bbox = list(gmsh.model.getBoundingBox(-1, -1)) if entities else []
        if a.bbox_only:
            print(json.dumps({"file": a.file, "unit": a.unit, "entities": entities, "bbox": bbox}))
            return
        top = max(e["dim"] for e in entities) if entities else 0
        main_entities = [e for e in entities if e["dim"] == top]
        worst_gmsh = worst = float("nan")
        if len(main_entities) == 1:
            e = main_entities[0]
            q = np.array(pts)
            closest, _ = gmsh.model.getClosestPoint(e["dim"], e["tag"], q.ravel())
            closest = np.array(closest).reshape(-1, 3)
            worst_gmsh = float(np.linalg.norm(closest - q, axis=1).max())
            d = refine(e["dim"], e["tag"], q, closest)
            if params is not None and params.shape[1] == e["dim"]:
                own = np.array(gmsh.model.getValue(e["dim"], e["tag"], params.ravel())).reshape(-1, 3)
                d = np.minimum(d, refine(e["dim"], e["tag"], q, own))
            worst = float(d.max())
        if a.mesh_size > 0:
            gmsh.option.setNumber("Mesh.MeshSizeMax", a.mesh_size)
        gmsh.model.mesh.generate(top)
        tags, _, _ = gmsh.model.mesh.getNodes()
        elements = 0
        for t in gmsh.model.mesh.getElements(top)[1]:
            elements += len(t)
        print(
            json.dumps(
                {
                    "file": a.file,
                    "unit": a.unit,
                    "entities": entities,
                    "bbox": bbox,
                    "top_dim": top,
                    "samples": len(pts),
                    "max_distance_gmsh": worst_gmsh,
                    "max_distance": worst,
                    "mesh_nodes": len(tags),
                    "mesh_elements": elements,
                }
            )
        )
    finally:
        gmsh.finalize()


if __name__ == "__main__":
    sys.exit(main())
