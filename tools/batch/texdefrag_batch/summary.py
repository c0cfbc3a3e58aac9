"""The end-of-batch summary: OUT/.texdefrag-batch/{summary.json, results.csv, summary.md}.

results.csv has the columns of `texdefrag bench`'s results.csv (docs/bench.md) that a run report
gives without an evaluation pass (charts_in, charts_out, chart_reduction, texture_mp_change,
texture_bytes_change, time_s, peak_rss_mb), so summary.md is the bench table, written by
eval/plots/plots.py's own summary_markdown (imported, not copied).
"""

import csv
import json
import os
import statistics
import sys

IMAGE_EXT = (".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp", ".tga", ".dds", ".ktx2", ".webp")


def _page_bytes(paths):
    return sum(os.path.getsize(p) for p in paths if p.lower().endswith(IMAGE_EXT) and os.path.exists(p))


def _ratio(a, b):
    return (b - a) / a if a not in (None, 0) and b is not None else None


def rows(tasks, output_root, label):
    """One bench-style record per task of the production (finished: ok, failed: failed)."""
    out = []
    for t in sorted(tasks.values(), key=lambda t: t["id"]):
        if t["status"] not in ("finished", "failed"):
            continue
        r = {"config": label, "kind": "pipeline", "model": t["id"],
             "status": "ok" if t["status"] == "finished" else "failed",
             "failed_step": "run" if t["status"] == "failed" else "", "error": t["error"] or "",
             "attempts": t["attempts"], "host": t["host"] or "", "wall_s": t["wall_s"]}
        fig = t["figures"] or {}
        if t["status"] == "finished":
            cin, cout = fig.get("charts_in"), fig.get("charts_out")
            r["charts_in"], r["charts_out"] = cin, cout
            r["chart_reduction"] = (cin - cout) / cin if cin and cout is not None else None
            r["texture_mp_change"] = _ratio(fig.get("mp_in"), fig.get("mp_out"))
            pin = _page_bytes([f[0] for f in t["files"] or []])
            pout = _page_bytes([os.path.join(output_root, o) for o in t["outputs"] or []])
            r["texture_bytes_change"] = _ratio(pin or None, pout)
            r["time_s"] = fig.get("time_s")
            r["peak_rss_mb"] = fig["max_rss_kb"] / 1024 if fig.get("max_rss_kb") else None
            r["faces"] = fig.get("faces")
            r["cpu_s"] = fig.get("cpu_s")
            r["input_bytes"] = sum(f[1] for f in t["files"] or [])
            r["output_bytes"] = sum(os.path.getsize(os.path.join(output_root, o))
                                    for o in t["outputs"] or [] if os.path.exists(os.path.join(output_root, o)))
        out.append(r)
    return out


COLUMNS = ["config", "kind", "model", "status", "failed_step", "error", "chart_reduction", "texture_mp_change",
           "texture_bytes_change", "charts_in", "charts_out", "time_s", "peak_rss_mb", "faces", "input_bytes",
           "output_bytes", "wall_s", "cpu_s", "attempts", "host"]


def write_csv(path, records):
    with open(path + ".tmp", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=COLUMNS, extrasaction="ignore")
        w.writeheader()
        for r in records:
            w.writerow({k: ("" if r.get(k) is None else r.get(k)) for k in COLUMNS})
    os.replace(path + ".tmp", path)


def stats(values):
    vs = [v for v in values if v is not None]
    if not vs:
        return None
    return {"n": len(vs), "median": statistics.median(vs), "mean": statistics.fmean(vs), "min": min(vs),
            "max": max(vs), "sum": sum(vs)}


def summary(records, batch_info):
    ok = [r for r in records if r["status"] == "ok"]
    s = dict(batch_info)
    s["tasks"] = {"total": len(records), "finished": len(ok), "failed": len(records) - len(ok)}
    s["per_task"] = {k: stats([r.get(k) for r in ok]) for k in
                     ("wall_s", "cpu_s", "time_s", "peak_rss_mb", "faces", "input_bytes", "output_bytes", "chart_reduction",
                      "texture_mp_change", "texture_bytes_change")}
    s["failures"] = [{"id": r["model"], "attempts": r["attempts"], "error": r["error"]}
                     for r in records if r["status"] != "ok"]
    return s


def write_all(state_dir, tasks, output_root, label, batch_info, plots_dir):
    """Writes the three files; returns (summary dict, markdown text or None, note)."""
    records = rows(tasks, output_root, label)
    write_csv(os.path.join(state_dir, "results.csv"), records)
    s = summary(records, batch_info)
    with open(os.path.join(state_dir, "summary.json.tmp"), "w") as f:
        json.dump(s, f, indent=1, default=str)
    os.replace(os.path.join(state_dir, "summary.json.tmp"), os.path.join(state_dir, "summary.json"))
    md, note = None, ""
    if plots_dir and os.path.exists(os.path.join(plots_dir, "plots.py")) and records:
        sys.path.insert(0, plots_dir)
        try:
            import plots  # eval/plots/plots.py
            with open(os.path.join(state_dir, "results.csv"), newline="") as f:
                csv_rows = list(csv.DictReader(f))
            md = plots.summary_markdown(csv_rows, [label])
            with open(os.path.join(state_dir, "summary.md"), "w") as f:
                f.write(md + "\n")
        except Exception as e:  # noqa: BLE001 (the JSON summary stands without the table)
            note = f"summary.md not written ({plots_dir}/plots.py: {type(e).__name__}: {e})"
        finally:
            sys.path.remove(plots_dir)
    elif records:
        note = f"summary.md not written: eval/plots/plots.py not found in {plots_dir}"
    return s, md, note
