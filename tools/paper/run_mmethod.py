#!/usr/bin/env python3
"""Runs the M-method's own program on every model of a building set (docs/paper.md).

  run_mmethod.py --set OUT [--tool /work/shared/tools/mmethod/run.sh] [--timeout S] [--only NAME ...]

For each model of OUT/manifest.json (tools/paper/make_buildings.py) writes OUT/mmethod/<name>/
(`run.sh IN.obj DIR`: <name>_defrag.obj, its pages, log.txt, time.txt), the folder layout
`texdefrag bench --external mmethod_orig=OUT/mmethod` reads. A model whose folder already holds
<name>_defrag.obj is skipped (rerun = resume); a failure or a timeout is printed and recorded in
OUT/mmethod/<name>/failed.txt (bench then records the model as `missing`), and the next model runs.
Exit code 0 when every model has an output, 1 otherwise, 2 for bad arguments.
"""
import argparse
import json
import os
import shutil
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--set", required=True, help="building set folder (holds manifest.json)")
    ap.add_argument("--tool", default=os.path.join(ROOT, "..", "shared", "tools", "mmethod", "run.sh"))
    ap.add_argument("--timeout", type=float, default=900.0)
    ap.add_argument("--only", action="append", default=[], help="model name (repeatable)")
    a = ap.parse_args()
    if not os.access(a.tool, os.X_OK):
        print("run_mmethod: no M-method program at %s (see its README); skipped" % a.tool, file=sys.stderr)
        return 2
    man = os.path.join(a.set, "manifest.json")
    try:
        with open(man) as f:
            models = json.load(f)["models"]
    except (OSError, ValueError, KeyError) as e:
        print("run_mmethod: %s: %s" % (man, e), file=sys.stderr)
        return 2
    base = os.path.join(a.set, "mmethod")
    missing = 0
    for m in models:
        name = m["name"]
        if a.only and name not in a.only:
            continue
        d = os.path.join(base, name)
        if os.path.isfile(os.path.join(d, name + "_defrag.obj")):
            continue
        shutil.rmtree(d, ignore_errors=True)
        inp = os.path.join(a.set, m["path"])
        t0 = time.time()
        try:
            r = subprocess.run(["nice", "-n", "10", a.tool, inp, d], stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                               universal_newlines=True, timeout=a.timeout)
            err = "" if r.returncode == 0 else "exit %d: %s" % (r.returncode, r.stdout[-1500:])
        except subprocess.TimeoutExpired:
            err = "timeout after %.0f s" % a.timeout
        ok = not err and os.path.isfile(os.path.join(d, name + "_defrag.obj"))
        if not ok:
            missing += 1
            os.makedirs(d, exist_ok=True)
            with open(os.path.join(d, "failed.txt"), "w") as f:
                f.write((err or "no output OBJ written") + "\n")
        print("%-28s %s %.1f s" % (name, "ok" if ok else "FAILED " + (err or "no output")[:200], time.time() - t0),
              flush=True)
    return 1 if missing else 0


if __name__ == "__main__":
    sys.exit(main())
