#!/usr/bin/env python3
"""Builds the building set of the paper reproduction (issue 14, docs/paper.md).

  make_buildings.py -o OUT [--data DIR | --tile OBJ ...] [--per-tile N] [--min-faces N]
                    [--synth-count N] [--synth-faces MIN:MAX] [--synth-seed S] [--exe TEXDEFRAG]

1. Every tile OBJ (by default the six development tiles DIR/contextcapture/*/*.obj, DIR =
   ../shared/data from the repository root) is cut with `texdefrag buildings` into
   OUT/cut/<tile>/ (one OBJ per building, largest first, plus a remainder that is not used).
2. The `--per-tile` largest buildings of each tile (all when 0) are written as models of their
   own: `texdefrag run -c configs/repack.json` keeps every input chart and texel (texels copied,
   no resampling) and packs them into the building's own atlas, OUT/set/<name>/<name>.obj. The
   cut buildings alone would still reference the whole tile's atlases, so their texture size would
   be the tile's, not the building's (Liu et al.'s building models carry their own textures).
3. `--synth-count` hard synthetic buildings (`texdefrag synth --preset hard`), OUT/synth/.
4. OUT/manifest.json lists the models for `texdefrag bench --data OUT/manifest.json`
   (name, path, kind real|synthetic, tile, faces).

Input files are only read. Reruns redo everything (OUT/cut, OUT/set, OUT/synth are emptied).
"""
import argparse
import json
import os
import shutil
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def fail(msg):
    print("make_buildings: " + msg, file=sys.stderr)
    sys.exit(2)


def run(cmd):
    r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, universal_newlines=True)
    if r.returncode != 0:
        fail("command failed (exit %d): %s\n%s" % (r.returncode, " ".join(cmd), r.stderr[-2000:]))
    return r.stdout


def default_exe():
    for p in (os.path.join(ROOT, "build", "bin", "texdefrag"), shutil.which("texdefrag") or ""):
        if p and os.access(p, os.X_OK):
            return p
    return ""


def dev_tiles(data):
    base = os.path.join(data, "contextcapture")
    if not os.path.isdir(base):
        fail("no folder %s (the six development tiles); give --data or --tile" % base)
    tiles = []
    for d in sorted(os.listdir(base)):
        sub = os.path.join(base, d)
        if not os.path.isdir(sub) or d == "osgb_prod5":
            continue
        objs = sorted(f for f in os.listdir(sub) if f.endswith(".obj"))
        if len(objs) != 1:
            fail("%s: expected one OBJ, found %d" % (sub, len(objs)))
        tiles.append(os.path.join(sub, objs[0]))
    if not tiles:
        fail("no tile OBJ under %s" % base)
    return tiles


def cut_tile(exe, tile, out, min_faces):
    stem = os.path.splitext(os.path.basename(tile))[0]
    cut_dir = os.path.join(out, "cut", stem)
    run([exe, "buildings", tile, "-o", cut_dir, "--min-faces", str(min_faces)])
    with open(os.path.join(cut_dir, stem + "_buildings.json")) as f:
        parts = json.load(f)["parts"]
    return stem, [(p["name"], p["faces"], os.path.join(cut_dir, p["obj"])) for p in parts if p["name"] != "rest"]


def repack(exe, obj, name, out):
    d = os.path.join(out, "set", name)
    run([exe, "run", obj, "-c", os.path.join(ROOT, "configs", "repack.json"), "-o", d, "--quiet"])
    path = os.path.join(d, name + ".obj")
    if not os.path.isfile(path):
        fail("repack wrote no %s" % path)
    # The run report beside the OBJ would make bench's folder discovery skip it; the manifest
    # names the file, and the report is kept (it proves every chart was kept).
    return path


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("-o", "--out", required=True)
    ap.add_argument("--data", default=os.path.join(ROOT, "..", "shared", "data"))
    ap.add_argument("--tile", action="append", default=[], help="tile OBJ (repeatable; replaces the development tiles)")
    ap.add_argument("--per-tile", type=int, default=0, help="largest buildings kept per tile (0 = all)")
    ap.add_argument("--min-faces", type=int, default=200, help="texdefrag buildings --min-faces")
    ap.add_argument("--synth-count", type=int, default=0)
    ap.add_argument("--synth-faces", default="8000:30000")
    ap.add_argument("--synth-seed", type=int, default=11)
    ap.add_argument("--exe", default=default_exe())
    a = ap.parse_args()
    if not a.exe or not os.access(a.exe, os.X_OK):
        fail("no texdefrag executable (build it, or give --exe)")
    if a.per_tile < 0 or a.synth_count < 0 or a.min_faces < 1:
        fail("--per-tile and --synth-count must be >= 0, --min-faces >= 1")
    try:
        smin, smax = (int(x) for x in a.synth_faces.split(":"))
    except ValueError:
        fail("--synth-faces: expected MIN:MAX, got '%s'" % a.synth_faces)
    out = os.path.abspath(a.out)
    tiles = [os.path.abspath(t) for t in a.tile] or dev_tiles(a.data)
    for t in tiles:
        if not os.path.isfile(t):
            fail("no tile file %s" % t)
        if os.path.commonpath([out, os.path.dirname(t)]) == os.path.dirname(t):
            fail("--out %s is inside the folder of input %s" % (out, t))
    for sub in ("cut", "set", "synth"):
        shutil.rmtree(os.path.join(out, sub), ignore_errors=True)
    os.makedirs(out, exist_ok=True)

    models, tile_counts = [], []
    for tile in tiles:
        stem, blds = cut_tile(a.exe, tile, out, a.min_faces)
        kept = blds if a.per_tile == 0 else blds[:a.per_tile]
        tile_counts.append({"tile": stem, "path": tile, "buildings": len(blds), "kept": len(kept),
                            "building_faces": [b[1] for b in blds]})
        for part, faces, obj in kept:
            name = os.path.splitext(os.path.basename(obj))[0]
            path = repack(a.exe, obj, name, out)
            models.append({"name": name, "path": os.path.relpath(path, out), "kind": "real", "tile": stem,
                           "part": part, "faces": faces})
        print("%-12s %3d buildings, %3d kept (%s faces)" % (stem, len(blds), len(kept),
                                                             ", ".join(str(k[1]) for k in kept)))
    if a.synth_count:
        sdir = os.path.join(out, "synth")
        run([a.exe, "synth", "--preset", "hard", "--count", str(a.synth_count), "--min-faces", str(smin),
             "--max-faces", str(smax), "--seed", str(a.synth_seed), "-o", sdir])
        with open(os.path.join(sdir, "manifest.json")) as f:
            smodels = json.load(f)["models"]
        for m in smodels:
            p = m.get("path") or m.get("obj")
            name = m.get("name") or m.get("id") or os.path.splitext(os.path.basename(p))[0]
            models.append({"name": name, "path": os.path.relpath(os.path.join(sdir, p), out), "kind": "synthetic",
                           "tile": "synth_hard_seed%d" % a.synth_seed, "archetype": m.get("archetype", ""),
                           "faces": m.get("faces", 0)})
        print("synthetic    %3d hard buildings (seed %d)" % (len(smodels), a.synth_seed))
    with open(os.path.join(out, "manifest.json"), "w") as f:
        json.dump({"description": "building set of the paper reproduction (tools/paper/make_buildings.py)",
                   "command": sys.argv, "tiles": tile_counts, "models": models}, f, indent=1)
    print("%d models => %s" % (len(models), os.path.join(out, "manifest.json")))


if __name__ == "__main__":
    main()
