#!/usr/bin/env python3
"""A contact sheet of a building set: every real model of SET/manifest.json drawn flat-shaded from an
oblique view (azimuth 35, elevation 35 degrees, z up), so a reader can see what was measured
(docs/paper.md, "The building set").

  render_set.py SET OUT.png [--kind real|synthetic|all] [--cols 6]

Needs matplotlib (exit 3 without it). Reads OBJ positions and faces only.
"""
import argparse
import json
import os
import sys


def read_obj(path):
    verts, faces = [], []
    with open(path) as f:
        for line in f:
            if line.startswith("v "):
                verts.append([float(x) for x in line.split()[1:4]])
            elif line.startswith("f "):
                idx = [int(t.split("/")[0]) for t in line.split()[1:]]
                idx = [i - 1 if i > 0 else len(verts) + i for i in idx]
                faces.extend([idx[0], idx[k], idx[k + 1]] for k in range(1, len(idx) - 1))
    return verts, faces


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("set")
    ap.add_argument("out")
    ap.add_argument("--kind", default="real", choices=["real", "synthetic", "all"])
    ap.add_argument("--cols", type=int, default=6)
    a = ap.parse_args()
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        import numpy as np
        from mpl_toolkits.mplot3d.art3d import Poly3DCollection
    except ImportError as e:
        print("render_set: matplotlib/numpy missing (%s): no picture" % e, file=sys.stderr)
        return 3
    with open(os.path.join(a.set, "manifest.json")) as f:
        models = [m for m in json.load(f)["models"] if a.kind == "all" or m.get("kind") == a.kind]
    if not models:
        print("render_set: no %s model in %s" % (a.kind, a.set), file=sys.stderr)
        return 1
    cols = max(1, min(a.cols, len(models)))
    rows = (len(models) + cols - 1) // cols
    fig = plt.figure(figsize=(cols * 2.6, rows * 2.4))
    light = np.array([0.3, 0.5, 0.8]) / np.linalg.norm([0.3, 0.5, 0.8])
    for i, m in enumerate(models):
        v, fc = read_obj(os.path.join(a.set, m["path"]))
        v, fc = np.array(v), np.array(fc)
        tris = v[fc]
        n = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
        n /= np.linalg.norm(n, axis=1, keepdims=True) + 1e-12
        ax = fig.add_subplot(rows, cols, i + 1, projection="3d")
        ax.add_collection3d(Poly3DCollection(tris, facecolors=plt.cm.gray(0.25 + 0.75 * np.abs(n @ light)), edgecolor="none"))
        lo, hi = v.min(0), v.max(0)
        c, r = (lo + hi) / 2, (hi - lo).max() / 2
        ax.set_xlim(c[0] - r, c[0] + r)
        ax.set_ylim(c[1] - r, c[1] + r)
        ax.set_zlim(c[2] - r, c[2] + r)
        ax.view_init(35, 35)
        ax.set_title("%s (%d faces)" % (m["name"].replace("_building_", "_b"), len(fc)), fontsize=8)
        ax.set_axis_off()
    plt.tight_layout()
    plt.savefig(a.out, dpi=60)
    print("render_set: wrote %s (%d models)" % (a.out, len(models)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
