#!/usr/bin/env python3
"""`texdefrag batch` over production formats other than a folder of OBJ tiles (docs/batch.md):

- a 3D Tiles tileset built here (GLBs with external PNG pages, two of them sharing one atlas, an
  external tileset, a pass-through .pnts): one task per model, the shared atlas one task, the
  tileset JSONs written at the end, the same files as `texdefrag run TILESET`; a broken content
  fails its task only and leaves no tileset JSON;
- a ContextCapture OSGB production (metadata.xml + Tile_*/ level files made by OpenSceneGraph's
  osgconv from synthetic OBJ tiles): the same files as `texdefrag run PRODUCTION`, metadata.xml
  copied, levels in the task list, the journal.

Run by ctest (test_batch_productions): TEXDEFRAG_EXE, TEXDEFRAG_SOURCE_DIR and
TEXDEFRAG_TEST_WORKDIR are set.
"""

import json
import os
import shutil
import struct
import subprocess
import sys
import unittest
import zlib

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402
from common import batch, journal_rows, leftovers, model_files  # noqa: E402


def png(w, h, seed):
    """An RGB PNG of w x h with a pattern per seed (standard library only)."""
    rows = b"".join(b"\0" + bytes(((x * 7 + y * 3 + seed * 50) % 256, (x * y + seed * 20) % 256, (x + seed * 90) % 256)
                                  [c] for x in range(w) for c in range(3)) for y in range(h))

    def chunk(tag, data):
        return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF)

    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(rows)) + chunk(b"IEND", b""))


def grid_glb(n, z, image_uri, u0=0.0, u1=1.0):
    """A GLB of an n x n grid at height z whose every triangle is its own chart (own vertices) in a
    row of cells of [u0, u1] x [0, 1] of the external image `image_uri`."""
    pos, uv, idx = [], [], []
    cells = 1
    while cells * cells < 2 * n * n:
        cells += 1
    t = 0
    for y in range(n):
        for x in range(n):
            for h in range(2):
                q = [(x, y), (x + 1, y), (x + 1, y + 1), (x, y + 1)]
                corners = [0, 2 if h else 1, 3 if h else 2]
                cu, cv, s = (t % cells) / cells, (t // cells) / cells, 0.8 / cells
                for c in corners:
                    px, py = q[c]
                    pos += [float(px), float(py), float(z)]
                    uv += [u0 + (u1 - u0) * (cu + s * (px - x)), cv + s * (1 - (py - y))]
                    idx.append(len(idx))
                t += 1
    nv = len(idx)
    pb = struct.pack(f"<{len(pos)}f", *pos)
    ub = struct.pack(f"<{len(uv)}f", *uv)
    ib = struct.pack(f"<{nv}I", *idx)
    binary = pb + ub + ib
    doc = {
        "asset": {"version": "2.0", "generator": "texdefrag batch tests"},
        "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "TEXCOORD_0": 1}, "indices": 2, "material": 0,
                                    "mode": 4}]}],
        "materials": [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}],
        "textures": [{"source": 0, "sampler": 0}], "samplers": [{}], "images": [{"uri": image_uri}],
        "buffers": [{"byteLength": len(binary)}],
        "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": len(pb), "target": 34962},
                        {"buffer": 0, "byteOffset": len(pb), "byteLength": len(ub), "target": 34962},
                        {"buffer": 0, "byteOffset": len(pb) + len(ub), "byteLength": len(ib), "target": 34963}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": nv, "type": "VEC3",
                       "min": [min(pos[k::3]) for k in range(3)], "max": [max(pos[k::3]) for k in range(3)]},
                      {"bufferView": 1, "componentType": 5126, "count": nv, "type": "VEC2"},
                      {"bufferView": 2, "componentType": 5125, "count": nv, "type": "SCALAR"}],
    }
    js = json.dumps(doc).encode()
    js += b" " * (-len(js) % 4)
    binary += b"\0" * (-len(binary) % 4)
    body = struct.pack("<I4s", len(js), b"JSON") + js + struct.pack("<I4s", len(binary), b"BIN\0") + binary
    return struct.pack("<4sII", b"glTF", 2, 12 + len(body)) + body


def box(n, z):
    """A 3D Tiles box around a grid of grid_glb (glTF y-up turned z-up: glTF (x, y, z) -> (x, -z, y))."""
    return {"box": [n / 2, -z, n / 2, n / 2 + 0.01, 0, 0, 0, 0.01, 0, 0, 0, n / 2 + 0.01]}


def put(path, data):
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, "wb") as f:
        f.write(data if isinstance(data, bytes) else data.encode())


def make_tileset(root):
    """tileset.json -> a.glb (own page), shared/s0.glb + shared/s1.glb (one atlas), sub/ext.json ->
    c.glb, points.pnts (passed through)."""
    put(os.path.join(root, "a.png"), png(32, 32, 1))
    put(os.path.join(root, "a.glb"), grid_glb(3, 0.0, "a.png"))
    put(os.path.join(root, "shared", "atlas.png"), png(64, 32, 2))
    put(os.path.join(root, "shared", "s0.glb"), grid_glb(2, 1.0, "atlas.png", 0.0, 0.5))
    put(os.path.join(root, "shared", "s1.glb"), grid_glb(2, 2.0, "atlas.png", 0.5, 1.0))
    put(os.path.join(root, "sub", "c.png"), png(16, 16, 3))
    put(os.path.join(root, "sub", "c.glb"), grid_glb(2, 3.0, "c.png"))
    put(os.path.join(root, "points.pnts"), b"pnts-bytes-passed-through")
    put(os.path.join(root, "sub", "ext.json"), json.dumps({
        "asset": {"version": "1.0"}, "geometricError": 1,
        "root": {"boundingVolume": box(2, 3.0), "geometricError": 0, "refine": "ADD", "content": {"uri": "c.glb"}}}))
    children = [{"boundingVolume": box(3, 0.0), "geometricError": 1, "content": {"uri": "a.glb"}},
                {"boundingVolume": box(2, 1.0), "geometricError": 1, "content": {"uri": "shared/s0.glb"}},
                {"boundingVolume": box(2, 2.0), "geometricError": 1, "content": {"uri": "shared/s1.glb"}},
                {"boundingVolume": box(2, 3.0), "geometricError": 2, "content": {"uri": "sub/ext.json"}},
                {"boundingVolume": box(3, 0.0), "geometricError": 1, "content": {"uri": "points.pnts"}}]
    put(os.path.join(root, "tileset.json"), json.dumps({
        "asset": {"version": "1.0"}, "extensionsUsed": ["3DTILES_content_gltf"], "geometricError": 100,
        "root": {"boundingVolume": {"box": [2, -2, 2, 3, 0, 0, 0, 3, 0, 0, 0, 3]}, "geometricError": 50,
                 "refine": "REPLACE", "children": children}}, indent=1))
    return os.path.join(root, "tileset.json")


def tasks_json(path):
    p = subprocess.run([common.EXE, "tasks", path, "--json"], capture_output=True, text=True)
    if p.returncode != 0:
        raise AssertionError(p.stderr)
    return json.loads(p.stdout)


class BatchProductionsTest(unittest.TestCase):
    def fresh(self, name):
        d = common.fresh_dir("productions", name)
        return os.path.join(d, "in"), os.path.join(d, "out")

    def test_tileset(self):
        inp, out = self.fresh("tileset")
        ts = make_tileset(inp)
        before = model_files(inp)
        t = tasks_json(ts)
        self.assertEqual(t["kind"], "tileset")
        self.assertEqual([x["id"] for x in t["tasks"]], ["a", "shared/s0", "sub/c"])
        shared = t["tasks"][1]
        self.assertEqual(shared["contents"], ["shared/s0.glb", "shared/s1.glb"])  # one atlas: one task
        self.assertEqual(shared["args"], ["--contents", "shared/s0.glb", "--contents", "shared/s1.glb"])
        self.assertEqual(shared["files"], [ts] + [os.path.join(inp, "shared", f) for f in ("s0.glb", "s1.glb", "atlas.png")])
        self.assertEqual(t["finish"], ["tasks", ts, "--finish"])
        # A folder holding a tileset.json is that tileset.
        self.assertEqual([x["id"] for x in tasks_json(inp)["tasks"]], ["a", "shared/s0", "sub/c"])

        p = batch(ts, "-o", out, "--config", common.CONFIG, "-j", "2")
        self.assertEqual(p.returncode, 0, p.stderr)
        tasks, attempts = journal_rows(out)
        self.assertEqual(sorted(tasks), ["a", "shared/s0", "sub/c"])
        self.assertTrue(all(r["status"] == "finished" and r["attempts"] == 1 for r in tasks.values()), tasks)
        self.assertEqual(tasks["shared/s0"]["outputs"][-1], "shared/s0.report.json")  # committed last
        for f in ("shared/s0.glb", "shared/s1.glb", "shared/atlas.png"):
            self.assertIn(f, tasks["shared/s0"]["outputs"])
        self.assertEqual(leftovers(out), [])
        self.assertEqual(model_files(inp), before, "an input file changed")
        # The same files as one `texdefrag run` of the whole tileset (reports and summary hold times).
        whole = os.path.join(os.path.dirname(out), "whole")
        subprocess.run([common.EXE, "run", ts, "-c", common.CONFIG, "-o", whole, "--quiet"], check=True)
        got = {k: v for k, v in model_files(out).items()}
        want = {k: v for k, v in model_files(whole).items() if not k.endswith(".summary.json")}
        self.assertEqual(got, want)
        for f in ("tileset.json", "sub/ext.json", "points.pnts", "shared/atlas.png"):
            self.assertIn(f, got)

        # A rerun skips everything; a changed shared atlas redoes its one task.
        p = batch(ts, "-o", out, "--config", common.CONFIG)
        self.assertEqual(p.returncode, 0, p.stderr)
        self.assertEqual(len(journal_rows(out)[1]), 3, "a finished task ran again")
        put(os.path.join(inp, "shared", "atlas.png"), png(64, 32, 5))
        p = batch(ts, "-o", out, "--config", common.CONFIG, "--dry-run")
        decisions = dict(line.split("\t") for line in p.stdout.splitlines())
        self.assertEqual(decisions, {"a": "skip", "shared/s0": "input changed", "sub/c": "skip"})

    def test_tileset_with_a_broken_content(self):
        inp, out = self.fresh("tileset_broken")
        ts = make_tileset(inp)
        with open(os.path.join(inp, "sub", "c.glb"), "r+b") as f:
            f.truncate(60)  # a GLB cut inside its JSON chunk
        p = batch(ts, "-o", out, "--config", common.CONFIG, "-j", "2", "--retries", "0")
        self.assertEqual(p.returncode, 1, p.stderr)
        tasks, _ = journal_rows(out)
        self.assertEqual({k: v["status"] for k, v in tasks.items()},
                         {"a": "finished", "shared/s0": "finished", "sub/c": "failed"})
        self.assertIn(os.path.join(inp, "sub", "c.glb"), tasks["sub/c"]["error"])
        self.assertTrue(os.path.isfile(os.path.join(out, "shared", "s1.glb")))
        # No tileset JSON: a partial production never looks complete.
        self.assertFalse(os.path.exists(os.path.join(out, "tileset.json")))
        self.assertFalse(os.path.exists(os.path.join(out, "sub", "c.glb")))
        self.assertEqual(leftovers(out), [])

    def test_tileset_with_a_missing_content_and_a_missing_external_tileset(self):
        """A content file and an external tileset that the tree names but that are missing: each is
        a task of its own, failed at once (no attempt) with an error naming the file and the tileset
        naming it; the other tasks are listed and run; no tileset JSON is written. Once the files
        are back, a rerun runs those two tasks only and finishes the production."""
        inp, out = self.fresh("tileset_missing")
        ts = make_tileset(inp)
        saved = os.path.join(os.path.dirname(inp), "saved")
        os.makedirs(saved)
        for f in ("a.glb", "sub/ext.json"):
            os.rename(os.path.join(inp, f), os.path.join(saved, os.path.basename(f)))
        t = tasks_json(ts)
        listed = {x["id"]: x for x in t["tasks"]}
        self.assertEqual(sorted(listed), ["a", "shared/s0", "sub/ext"])
        self.assertEqual(listed["a"]["error"], f"{os.path.join(inp, 'a.glb')}: content not found (named by {ts})")
        self.assertEqual(listed["sub/ext"]["error"],
                         f"{os.path.join(inp, 'sub', 'ext.json')}: content not found (named by {ts})")
        self.assertNotIn("error", listed["shared/s0"])
        # texdefrag run on the missing model alone fails with the same error.
        p = subprocess.run([common.EXE, "run", ts, "--contents", "a.glb", "-c", common.CONFIG, "-o",
                            os.path.join(os.path.dirname(out), "one")], capture_output=True, text=True)
        self.assertNotEqual(p.returncode, 0)
        self.assertIn(f"a.glb: content not found (named by {ts})", p.stderr)

        p = batch(ts, "-o", out, "--config", common.CONFIG, "-j", "2")
        self.assertEqual(p.returncode, 1, p.stderr)
        tasks, attempts = journal_rows(out)
        self.assertEqual({k: v["status"] for k, v in tasks.items()},
                         {"a": "failed", "shared/s0": "finished", "sub/ext": "failed"})
        self.assertEqual(tasks["a"]["error"], listed["a"]["error"])
        self.assertEqual(tasks["sub/ext"]["error"], listed["sub/ext"]["error"])
        self.assertEqual([a["task_id"] for a in attempts], ["shared/s0"])  # the missing ones never ran
        self.assertIn("a.glb: content not found", p.stderr)
        self.assertTrue(os.path.isfile(os.path.join(out, "shared", "s1.glb")))
        self.assertFalse(os.path.exists(os.path.join(out, "tileset.json")))
        self.assertEqual(leftovers(out), [])

        for f in ("a.glb", "sub/ext.json"):
            os.rename(os.path.join(saved, os.path.basename(f)), os.path.join(inp, f))
        p = batch(ts, "-o", out, "--config", common.CONFIG, "--dry-run")
        decisions = dict(line.split("\t") for line in p.stdout.splitlines())
        self.assertEqual(decisions, {"a": "input changed", "shared/s0": "skip", "sub/c": "new"})
        p = batch(ts, "-o", out, "--config", common.CONFIG, "-j", "2")
        self.assertEqual(p.returncode, 0, p.stderr)
        tasks, attempts = journal_rows(out)
        self.assertEqual(sorted(a["task_id"] for a in attempts), ["a", "shared/s0", "sub/c"])
        self.assertEqual(tasks["a"]["status"], "finished")
        self.assertTrue(os.path.isfile(os.path.join(out, "tileset.json")))


def make_osgb_production(root, work):
    """metadata.xml + three level files in two Tile_* folders, converted from synthetic OBJ tiles by
    OpenSceneGraph's osgconv (pages embedded as JPEG files)."""
    synth = common.make_production(os.path.join(work, "synth3"), 3, seed=11, min_faces=1000, max_faces=1200)
    names = ["Tile_+000_+000/Tile_+000_+000_L15_0.osgb", "Tile_+000_+000/Tile_+000_+000_L16_00.osgb",
             "Tile_+000_+001/Tile_+000_+001_L15_0.osgb"]
    for k, name in enumerate(names):
        dst = os.path.join(root, name)
        os.makedirs(os.path.dirname(dst), exist_ok=True)
        src = os.path.join(synth, f"b000{k}", f"b000{k}.obj")
        subprocess.run(["osgconv", "-O", "WriteImageHint=IncludeFile", os.path.basename(src), dst],
                       cwd=os.path.dirname(src), check=True, capture_output=True)
    put(os.path.join(root, "metadata.xml"),
        '<?xml version="1.0" encoding="utf-8"?>\n<ModelMetadata version="1">\n\t<SRS>EPSG:4547</SRS>\n'
        "\t<SRSOrigin>0,0,0</SRSOrigin>\n</ModelMetadata>\n")
    return names


@unittest.skipUnless(shutil.which("osgconv"), "osgconv (Debian package openscenegraph) not installed")
class BatchOsgbTest(unittest.TestCase):
    def test_osgb_production(self):
        d = os.path.join(common.WORKDIR, "productions", "osgb")
        shutil.rmtree(d, ignore_errors=True)
        inp, out, single = os.path.join(d, "in"), os.path.join(d, "out"), os.path.join(d, "single")
        names = make_osgb_production(inp, os.path.join(common.WORKDIR, "productions"))
        before = model_files(inp)
        t = tasks_json(inp)
        self.assertEqual([x["id"] for x in t["tasks"]], [n[:-5] for n in names])
        self.assertEqual([x["level"] for x in t["tasks"]], [15, 16, 15])
        self.assertEqual(t["copies"], [{"input": os.path.join(inp, "metadata.xml"), "output": "metadata.xml"}])

        p = batch(inp, "-o", out, "--config", common.CONFIG, "-j", "2")
        self.assertEqual(p.returncode, 0, p.stderr)
        tasks, attempts = journal_rows(out)
        self.assertEqual(sorted(tasks), sorted(n[:-5] for n in names))
        for tid, r in tasks.items():
            self.assertEqual((r["status"], r["attempts"]), ("finished", 1), tid)
            self.assertEqual(r["outputs"], [f"{tid}.osgb", f"{tid}.report.json"])  # pages embedded; report last
        self.assertEqual(len(attempts), 3)
        with open(os.path.join(inp, "metadata.xml"), "rb") as a, open(os.path.join(out, "metadata.xml"), "rb") as b:
            self.assertEqual(a.read(), b.read())
        self.assertEqual(leftovers(out), [])
        self.assertEqual(model_files(inp), before, "an input file changed")
        with open(os.path.join(out, ".texdefrag-batch", "summary.json")) as f:
            summary = json.load(f)
        self.assertEqual(summary["tasks"], {"total": 3, "finished": 3, "failed": 0})
        # Every output reads back in OpenSceneGraph and equals the sequential production run's.
        for n in names:
            subprocess.run(["osgconv", os.path.join(out, n), os.path.join(d, "check.osgt")], check=True,
                           capture_output=True)
        subprocess.run([common.EXE, "run", inp, "-c", common.CONFIG, "-o", single, "--quiet"], check=True)
        self.assertEqual(model_files(out), {k: v for k, v in model_files(single).items()
                                            if k != "texdefrag_summary.json"})
        # A rerun skips everything.
        p = batch(inp, "-o", out, "--config", common.CONFIG)
        self.assertEqual(p.returncode, 0, p.stderr)
        self.assertEqual(len(journal_rows(out)[1]), 3)

    def test_missing_child_with_and_without_allow_missing_children(self):
        """The bundled pyramid (examples/production) without its L16 file: the L15 file names a
        missing PagedLOD child, so its task fails naming both; `--allow-missing-children` is
        forwarded to every run, changes the configuration hash (the failed task is redone without
        --retry-failed) and lets it finish, the missing child listed in its report."""
        d = os.path.join(common.WORKDIR, "productions", "osgb_missing")
        shutil.rmtree(d, ignore_errors=True)
        inp, out = os.path.join(d, "in"), os.path.join(d, "out")
        shutil.copytree(os.path.join(common.SOURCE, "examples", "production"), inp)
        tile = "Data/Tile_+000_+000/Tile_+000_+000"
        os.remove(os.path.join(inp, tile + "_L16_0.osgb"))
        p = batch(inp, "-o", out, "--config", common.CONFIG, "--retries", "0")
        self.assertEqual(p.returncode, 1, p.stderr)
        tasks, _ = journal_rows(out)
        self.assertEqual({k: v["status"] for k, v in tasks.items()}, {tile: "finished", tile + "_L15_0": "failed"})
        error = tasks[tile + "_L15_0"]["error"]
        self.assertIn("Tile_+000_+000_L16_0.osgb", error)  # the child ...
        self.assertIn("Tile_+000_+000_L15_0.osgb", error)  # ... and its parent
        self.assertIn("--allow-missing-children", batch("--help").stdout)
        p = batch(inp, "-o", out, "--config", common.CONFIG, "--allow-missing-children", "--dry-run")
        decisions = dict(line.split("\t") for line in p.stdout.splitlines())
        self.assertEqual(decisions, {tile: "configuration changed", tile + "_L15_0": "configuration changed"})
        p = batch(inp, "-o", out, "--config", common.CONFIG, "--allow-missing-children", "--retries", "0")
        self.assertEqual(p.returncode, 0, p.stderr)
        tasks, _ = journal_rows(out)
        self.assertTrue(all(r["status"] == "finished" for r in tasks.values()), tasks)
        with open(os.path.join(out, tile + "_L15_0.report.json")) as f:
            report = json.load(f)
        missing = report["stages"]["read"]["missing_files"]
        self.assertEqual(len(missing), 1, missing)
        self.assertIn("Tile_+000_+000_L16_0.osgb", missing[0])
        self.assertEqual(leftovers(out), [])


if __name__ == "__main__":
    unittest.main(verbosity=2)
