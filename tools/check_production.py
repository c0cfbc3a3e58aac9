#!/usr/bin/env python3
"""Checks a production output against its input, model file by model file (issue 12, docs/bench.md
"Productions"): `texdefrag eval` on every pair (faces matched and lost, positions exact, texture
PSNR and share of texels copied, charts, megapixels, page bytes), OpenSceneGraph's `osgconv` reading
back every OSGB written, and the Khronos glTF validator (scripts/validate-gltf.js) on every GLB
written. Prints a table per level (markdown) and writes one CSV row per file.

    tools/check_production.py INPUT_DIR OUTPUT_DIR --exe build/bin/texdefrag [-j 2] [--csv rows.csv]
                              [--exact-copy]

INPUT_DIR: the production's folder (an OSGB production, or a tileset's folder). Model files are
every .osgb/.glb/.gltf under it whose output exists at the same relative path. Levels: `_L<n>_` in
a file name (ContextCapture), `lod<n>` (Matterport tilesets), else "root". Exit code 0 when every
file passed (no face lost, no osgconv or validator error; with --exact-copy, for a round trip without
merging such as configs/repack.json, also every file's share of texels copied exactly 1: eval's
`copied_fraction`, every sample of every face of non-zero UV area reads an output texel bit-identical
to its input texel), 1 otherwise, 2 on a usage error.
Page bytes come from the run reports (`<stem>.report.json` beside each output: the `write` node's
`input_page_bytes` and `page_bytes`, the encoded page bytes of the model in and out), one per model
(contents sharing one atlas are one model); eval's own page bytes are those of its lossless scratch
copies, not the files'.
"""

import argparse
import concurrent.futures
import csv
import json
import os
import re
import shutil
import statistics
import subprocess
import sys
import tempfile

MODEL_EXT = (".osgb", ".glb", ".gltf")


def level_of(rel):
    name = os.path.basename(rel)
    m = re.search(r"_L(\d+)_", name)
    if m:
        return f"L{int(m.group(1))}"
    m = re.search(r"lod(\d+)", name)
    return f"lod{m.group(1)}" if m else "root"


def level_key(s):
    """Sort key of level names: root, then L14.. or lod0.. by number, then "all" last."""
    return (s == "all", s != "root", int(re.sub(r"\D", "", s) or -1))


def pairs(inp, out):
    found = []
    for root, dirs, files in os.walk(inp):
        dirs[:] = sorted(d for d in dirs if not d.startswith("."))
        for f in sorted(files):
            if f.lower().endswith(MODEL_EXT):
                rel = os.path.relpath(os.path.join(root, f), inp)
                found.append((rel, os.path.join(inp, rel), os.path.join(out, rel)))
    return found


def check_one(exe, rel, a, b, tmp):
    row = {"file": rel, "level": level_of(rel)}
    if not os.path.isfile(b):
        row["error"] = "no output file"
        return row
    p = subprocess.run([exe, "eval", "--json", "--no-appearance", a, b], capture_output=True, text=True)
    if p.returncode != 0:
        row["error"] = f"eval exit {p.returncode}: {p.stderr.strip()[-300:]}"
        return row
    e = json.loads(p.stdout)
    i, o, m, fid = e["input"], e["output"], e["matching"], e.get("fidelity") or {}
    row.update(faces=i["faces"], lost=m["lost"], added=m["added"], v3=i["v3"], exact_positions=m["exact_positions"],
               moved_positions=m["moved_positions"], charts_in=i["charts"], charts_out=o["charts"],
               mp_in=i["megapixels"], mp_out=o["megapixels"], bytes_in=i["page_bytes"], bytes_out=o["page_bytes"],
               psnr_db=fid.get("psnr_db"), copied=fid.get("copied_fraction"),
               arap=(e.get("distortion") or {}).get("arap"))
    if b.lower().endswith(".osgb") and shutil.which("osgconv"):
        check = os.path.join(tmp, re.sub(r"[^A-Za-z0-9]", "_", rel) + ".osgt")
        q = subprocess.run(["osgconv", b, check], capture_output=True, text=True)
        row["osgconv"] = "ok" if q.returncode == 0 and os.path.isfile(check) else f"exit {q.returncode}"
        if os.path.exists(check):
            os.remove(check)
    return row


def validate_glbs(rows, out, source):
    files = [os.path.join(out, r["file"]) for r in rows if r["file"].lower().endswith((".glb", ".gltf"))]
    if not files:
        return
    script = os.path.join(source, "scripts", "validate-gltf.js")
    p = subprocess.run(["node", script, *files], capture_output=True, text=True)
    if p.returncode == 2 and not p.stdout:
        print(f"glTF validator not run: {p.stderr.strip()}", file=sys.stderr)
        return
    by_file = {}
    for line in p.stdout.splitlines():
        j = json.loads(line)
        by_file[os.path.abspath(j["file"])] = j
    for r in rows:
        j = by_file.get(os.path.abspath(os.path.join(out, r["file"])))
        if j:
            r["validator_errors"], r["validator_warnings"] = j["errors"], j["warnings"]


def model_reports(out):
    """One row per run report under out: level, page bytes in and out, page format."""
    rows = []
    for root, dirs, files in os.walk(out):
        dirs[:] = sorted(d for d in dirs if not d.startswith("."))
        for f in sorted(files):
            if f.endswith(".report.json"):
                with open(os.path.join(root, f)) as fh:
                    w = json.load(fh)["stages"]["write"]
                rows.append({"report": os.path.relpath(os.path.join(root, f), out), "level": level_of(f),
                             "in": w.get("input_page_bytes") or 0, "out": w.get("page_bytes") or 0,
                             "format": w.get("image_format"), "quality": w.get("jpeg_quality")})
    return rows


def fmt_int(v):
    return f"{v:,}"


def table(rows, reports):
    levels = sorted({r["level"] for r in rows}, key=level_key)
    lines = ["| level | files | faces (lost) | positions exact | charts in -> out | MP in -> out | page bytes in -> out "
             "| models over input bytes | texture PSNR min / median | texels copied min | osgconv / validator |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for lv in levels + ["all"]:
        rs = [r for r in rows if (lv == "all" or r["level"] == lv) and "error" not in r]
        if not rs:
            continue
        s = lambda k: sum(r[k] for r in rs)  # noqa: E731
        psnr = [r["psnr_db"] for r in rs if r.get("psnr_db") is not None]
        ms = [m for m in reports if lv == "all" or m["level"] == lv]
        b_in, b_out = sum(m["in"] for m in ms), sum(m["out"] for m in ms)
        over = sum(1 for m in ms if m["out"] > m["in"])
        copied = [r["copied"] for r in rs if r.get("copied") is not None]
        osg = sum(1 for r in rs if r.get("osgconv") == "ok")
        val = [r for r in rs if "validator_errors" in r]
        checks = []
        if any("osgconv" in r for r in rs):
            checks.append(f"osgconv {osg}/{len(rs)} read")
        if val:
            checks.append(f"validator {sum(r['validator_errors'] for r in val)} errors in {len(val)}")
        lines.append(f"| {lv} | {len(rs)} | {fmt_int(s('faces'))} ({s('lost')}) | {fmt_int(s('exact_positions'))} of "
                     f"{fmt_int(s('v3'))} | {fmt_int(s('charts_in'))} -> {fmt_int(s('charts_out'))} | "
                     f"{s('mp_in'):.2f} -> {s('mp_out'):.2f} | {fmt_int(b_in)} -> {fmt_int(b_out)} "
                     + (f"({(b_out / b_in - 1) * 100:+.1f}%)" if b_in else "") + f" | {over} of {len(ms)} | "
                     + (f"{min(psnr):.2f} / {statistics.median(psnr):.2f} dB" if psnr else "-")
                     + (f" | {min(copied) * 100:.1f}%" if copied else " | -")
                     + f" | {'; '.join(checks) or '-'} |")
    return "\n".join(lines)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("input")
    ap.add_argument("output")
    ap.add_argument("--exe", required=True, help="texdefrag executable")
    ap.add_argument("-j", "--jobs", type=int, default=1)
    ap.add_argument("--csv", help="write one row per file here")
    ap.add_argument("--exact-copy", action="store_true",
                    help="fail every file whose share of texels copied is not exactly 1 (a repack round trip)")
    a = ap.parse_args()
    source = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    todo = pairs(a.input, a.output)
    if not todo:
        print(f"check_production: no model file under {a.input}", file=sys.stderr)
        return 2
    with tempfile.TemporaryDirectory() as tmp, concurrent.futures.ThreadPoolExecutor(a.jobs) as pool:
        rows = list(pool.map(lambda t: check_one(a.exe, *t, tmp), todo))
    validate_glbs(rows, a.output, source)
    if a.csv:
        keys = sorted({k for r in rows for k in r}, key=lambda k: (k not in ("file", "level"), k))
        with open(a.csv, "w", newline="") as f:
            w = csv.DictWriter(f, keys)
            w.writeheader()
            w.writerows(rows)
    print(table(rows, model_reports(a.output)))
    bad = [r for r in rows if "error" in r or r.get("lost") or r.get("osgconv", "ok") != "ok"
           or r.get("validator_errors") or (a.exact_copy and r.get("copied") != 1.0)]
    for r in bad:
        keys = ("lost", "osgconv", "validator_errors") + (("copied",) if a.exact_copy else ())
        print(f"FAILED {r['file']}: {r.get('error') or {k: r.get(k) for k in keys}}", file=sys.stderr)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
