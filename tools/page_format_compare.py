#!/usr/bin/env python3
"""Page formats side by side on a production, model by model (issue 12 part 5, docs/bench.md "Page
bytes and fidelity against PNG pages"): runs every task of `texdefrag tasks INPUT` once per variant
(a variant is a list of `--set` overrides on one configuration; `png` = `output.image_format=png` is
always run and is the reference), evaluates every model file written against the input
(`texdefrag eval`, texture PSNR on the surface) and prints, per level, the page bytes in and out (the
run reports' `input_page_bytes` / `page_bytes`), the texture PSNR of each variant minus that of PNG
pages (min / median / max over the level's model files, and how many are more than 0.5 dB below),
the models over their input bytes and the CPU seconds of the runs (user + system of the child
processes, not wall time: the machine is shared).

    tools/page_format_compare.py INPUT --exe build/bin/texdefrag -o WORK [-c configs/best.json]
        [--variant NAME=KEY=V[,KEY=V...]] ... [--only REGEX] [-j 2] [--csv rows.csv]

INPUT: an OSGB production folder, a folder of OBJ tiles or a 3D Tiles tileset JSON (what `texdefrag
tasks` takes). Without --variant, one variant `default` (the configuration as it is). --only keeps
the tasks whose id matches REGEX (a subset for quick checks). Outputs go to WORK/<variant>/ (with
each run's CPU seconds beside its report, `<stem>.report.json.cpu_s`); --reuse keeps the runs found
there and only evaluates again (to add a variant or finish an interrupted comparison).
"""

import argparse
import concurrent.futures
import csv
import json
import os
import re
import statistics
import subprocess
import sys
import tempfile

from check_production import level_key, level_of  # same folder: one level naming for both tools

MODEL_EXT = (".osgb", ".glb", ".gltf", ".obj")


def run_timed(cmd):
    """Runs cmd; returns (stdout, stderr, CPU seconds of the child: user + system)."""
    with tempfile.TemporaryFile("w+") as out, tempfile.TemporaryFile("w+") as err:
        p = subprocess.Popen(cmd, stdout=out, stderr=err, text=True)
        _, _, ru = os.wait4(p.pid, 0)
        p.returncode = 0  # reaped by wait4; success is judged from the outputs
        out.seek(0)
        err.seek(0)
        return out.read(), err.read(), ru.ru_utime + ru.ru_stime


def tasks_of(exe, inp):
    p = subprocess.run([exe, "tasks", inp, "--json"], capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit(f"page_format_compare: texdefrag tasks {inp} failed: {p.stderr.strip()}")
    return json.loads(p.stdout)


def run_task(a, plan, task, name, sets, work):
    out_dir = os.path.join(work, name, task.get("output_dir", "."))
    os.makedirs(out_dir, exist_ok=True)
    cmd = [a.exe, "run", "-q", "-c", a.config, task["input"], *task.get("args", []), "-o", out_dir,
           "--allow-missing-children", "--threads", "1"]
    for s in sets:
        cmd += ["--set", s]
    root = plan["root"]
    if "contents" in task:
        models = [c for c in task["contents"]]
    else:
        models = [os.path.relpath(task["input"], root)]
    rep = os.path.join(work, name, os.path.splitext(models[0])[0] + ".report.json")
    cpu_file = rep + ".cpu_s"
    if a.reuse and os.path.isfile(rep) and os.path.isfile(cpu_file):
        err = ""
        with open(cpu_file) as fh:
            cpu = float(fh.read())
    else:
        _, err, cpu = run_timed(cmd)
        if os.path.isfile(rep):
            with open(cpu_file, "w") as fh:
                fh.write(f"{cpu}\n")
    rows = []
    for rel in models:
        b = os.path.join(work, name, rel)
        row = {"variant": name, "task": task["id"], "file": rel, "level": level_of(rel)}
        if not os.path.isfile(b):
            row["error"] = f"no output ({err.strip()[-300:]})"
            rows.append(row)
            continue
        e_out, e_err, _ = run_timed([a.exe, "eval", "--json", "--no-appearance", os.path.join(root, rel), b])
        try:
            fid = json.loads(e_out).get("fidelity") or {}
            row["psnr_db"] = fid.get("psnr_db")
            row["copied"] = fid.get("copied_fraction")
        except json.JSONDecodeError:
            row["error"] = f"eval failed: {e_err.strip()[-300:]}"
        rows.append(row)
    # One run report per model (contents sharing one atlas are one model): the first content's stem.
    model = {"variant": name, "task": task["id"], "level": level_of(models[0]), "cpu_s": cpu}
    if os.path.isfile(rep):
        with open(rep) as fh:
            w = json.load(fh)["stages"]["write"]
        model.update(bytes_in=w.get("input_page_bytes") or 0, bytes_out=w.get("page_bytes") or 0,
                     quality=w.get("jpeg_quality"), format=w.get("image_format"))
    else:
        model["error"] = f"no run report ({err.strip()[-300:]})"
    return rows, model


def summarise(variants, rows, models):
    levels = sorted({r["level"] for r in rows}, key=level_key) + ["all"]
    psnr = {(r["variant"], r["file"]): r.get("psnr_db") for r in rows}
    files = sorted({r["file"] for r in rows})
    head = ["level", "files", "input bytes"]
    for v in variants:
        head += [f"{v} bytes", f"{v} - PNG (min / median / max dB)" if v != "png" else "png PSNR median",
                 f"{v} CPU s"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for lv in levels:
        fs = [f for f in files if lv == "all" or level_of(f) == lv]
        ms = {v: [m for m in models if m["variant"] == v and (lv == "all" or m["level"] == lv) and "error" not in m]
              for v in variants}
        b_in = sum(m["bytes_in"] for m in ms["png"])
        cells = [lv, str(len(fs)), f"{b_in:,}"]
        for v in variants:
            b_out = sum(m["bytes_out"] for m in ms[v])
            over = sum(1 for m in ms[v] if m["bytes_out"] > m["bytes_in"])
            q = sorted({m.get("quality") for m in ms[v] if m.get("quality")})
            qs = f", q{q[0]}-{q[-1]}" if len(q) > 1 else (f", q{q[0]}" if q else "")
            cells.append(f"{b_out:,} ({(b_out / b_in - 1) * 100:+.1f}%{qs}; {over} of {len(ms[v])} over input)"
                         if b_in else f"{b_out:,}")
            if v == "png":
                ps = [psnr[("png", f)] for f in fs if psnr.get(("png", f)) is not None]
                cells.append(f"{statistics.median(ps):.2f} dB" if ps else "-")
            else:
                d = [psnr[(v, f)] - psnr[("png", f)] for f in fs
                     if psnr.get((v, f)) is not None and psnr.get(("png", f)) is not None]
                bad = sum(1 for x in d if x < -0.5)
                cells.append(f"{min(d):+.2f} / {statistics.median(d):+.2f} / {max(d):+.2f} ({bad} of {len(d)} below 0.5)"
                             if d else "-")
            cells.append(f"{sum(m['cpu_s'] for m in ms[v]):.1f}")
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("input")
    ap.add_argument("--exe", required=True)
    ap.add_argument("-o", "--work", required=True, help="work folder (outputs per variant)")
    ap.add_argument("-c", "--config", default="best")
    ap.add_argument("--variant", action="append", default=[], help="NAME=KEY=V[,KEY=V...] (repeatable)")
    ap.add_argument("--only", help="regular expression on task ids")
    ap.add_argument("-j", "--jobs", type=int, default=1)
    ap.add_argument("--csv")
    ap.add_argument("--reuse", action="store_true",
                    help="keep a run whose report (and CPU record) is already in WORK; evaluate again")
    a = ap.parse_args()
    variants = {"png": ["output.image_format=png"]}
    for v in a.variant or ["default="]:
        name, _, sets = v.partition("=")
        if not name or name == "png":
            sys.exit(f"page_format_compare: bad variant '{v}' (NAME=KEY=V,...; png is the reference)")
        variants[name] = [s for s in sets.split(",") if s]
    plan = tasks_of(a.exe, a.input)
    todo = [t for t in plan["tasks"] if not a.only or re.search(a.only, t["id"])]
    if not todo:
        sys.exit("page_format_compare: no task")
    # Tasks writing into one output folder (the files of one OSGB tile) run one after the other: a
    # texdefrag run locks its output folder, so two at once there would fail.
    groups = {}
    for t in todo:
        for n, s in variants.items():
            groups.setdefault((n, t.get("output_dir", ".")), []).append((t, n, s))

    def run_group(jobs):
        return [run_task(a, plan, t, n, s, a.work) for t, n, s in jobs]

    with concurrent.futures.ThreadPoolExecutor(a.jobs) as pool:
        results = [r for rs in pool.map(run_group, list(groups.values())) for r in rs]
    rows = [r for rs, _ in results for r in rs]
    models = [m for _, m in results]
    for x in rows + models:
        if "error" in x:
            print(f"FAILED {x['variant']} {x.get('file', x['task'])}: {x['error']}", file=sys.stderr)
    if a.csv:
        keys = sorted({k for r in rows for k in r})
        with open(a.csv, "w", newline="") as f:
            w = csv.DictWriter(f, keys)
            w.writeheader()
            w.writerows(rows)
    print(summarise(list(variants), rows, models))
    return 1 if any("error" in x for x in rows + models) else 0


if __name__ == "__main__":
    sys.exit(main())
