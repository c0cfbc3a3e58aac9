#!/usr/bin/env python3
"""Why the merging stopped where it did, per configuration (docs/paper.md, "Causes").

  causes.py --results RESULTS [--configs paper ...] [--kind real|synthetic|all] [--exclude TEXT ...]
                 [--out FILE.md]

Reads the run reports `RESULTS/runs/<label>/<model>/*.report.json` that `texdefrag bench` keeps
and the records of RESULTS/results.jsonl (status ok), and writes per configuration the medians over
its models of:
  faces per input chart; detector regions; the region floor 1 - regions / charts_in (the chart
  reduction reached if every region ended as one chart: merges never cross a region in a
  single-pass configuration); charts out / regions; the merger's final ARAP energy and the share
  of models whose energy is within 2% of the global bound 0.025 (budget spent);
  attempted and accepted merges; and the merger's refusals by reason, summed over the models.
Standard library only. Exit 0, or 1 when no record matches.
"""
import argparse
import json
import os
import statistics
import sys


def load_records(results, kind, exclude=()):
    recs = {}
    with open(os.path.join(results, "results.jsonl")) as f:
        for line in f:
            line = line.strip()
            if not line:
                continue
            r = json.loads(line)
            recs[(r["config"], r["model"])] = r  # the last record of a pair wins, as in bench
    out = [r for r in recs.values() if r.get("status") == "ok" and r.get("kind") == "pipeline"
           and not any(x in r["model"] for x in exclude)]
    if kind != "all":
        out = [r for r in out if (r.get("meta") or {}).get("kind") == kind]
    return out


def report_of(results, r):
    """The run report beside the record's output (labels of sweeps hold glob characters: '[')."""
    out = r.get("output") or ""
    path = os.path.splitext(out)[0] + ".report.json" if out else ""
    if not path or not os.path.isfile(path):
        d = os.path.join(results, "runs", r["config"], r["model"])
        files = [os.path.join(d, f) for f in os.listdir(d) if f.endswith(".report.json")] if os.path.isdir(d) else []
        if len(files) != 1:
            return None
        path = files[0]
    with open(path) as f:
        return json.load(f)


def stage(rep, prefix):
    for k, v in (rep.get("stages") or {}).items():
        if k.startswith(prefix) and isinstance(v, dict):
            return v
    return {}


def med(vs):
    vs = [v for v in vs if v is not None]
    return statistics.median(vs) if vs else None


def fmt(v, spec):
    return "-" if v is None else format(v, spec)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--results", required=True)
    ap.add_argument("--configs", nargs="*", help="labels (default: every pipeline configuration)")
    ap.add_argument("--kind", default="all", choices=["all", "real", "synthetic"])
    ap.add_argument("--exclude", nargs="*", default=[], help="leave out models whose name contains one of these")
    ap.add_argument("--out")
    a = ap.parse_args(argv)
    try:
        recs = load_records(a.results, a.kind, a.exclude)
    except (OSError, ValueError) as e:
        print("causes: %s: %s" % (a.results, e), file=sys.stderr)
        return 1
    labels = a.configs or sorted(set(r["config"] for r in recs))
    rows, reasons_all = [], {}
    for label in labels:
        per = {"fpc": [], "regions": [], "floor": [], "per_region": [], "e": [], "spent": [], "att": [], "acc": [],
               "red": []}
        reasons, n = {}, 0
        for r in recs:
            if r["config"] != label:
                continue
            rep = report_of(a.results, r)
            if rep is None:
                continue
            n += 1
            det, mer = stage(rep, "detectors."), stage(rep, "mergers.")
            cin, cout = mer.get("charts_in"), mer.get("charts_out")
            faces = (stage(rep, "read") or {}).get("faces") or (rep.get("stages", {}).get("read") or {}).get("faces")
            regions = det.get("regions") if det else None
            per["fpc"].append(faces / cin if faces and cin else None)
            per["regions"].append(regions)
            per["floor"].append(1 - regions / cin if regions and cin else None)
            per["per_region"].append(cout / regions if regions and cout else None)
            per["red"].append(1 - cout / cin if cin and cout is not None else None)
            e = mer.get("distortion_arap")
            per["e"].append(e)
            per["spent"].append(1.0 if e is not None and e >= 0.98 * 0.025 else 0.0)
            per["att"].append(mer.get("merges_attempted"))
            per["acc"].append(mer.get("merges_accepted"))
            for k, v in (mer.get("rejected") or {}).items():
                reasons[k] = reasons.get(k, 0) + v
                reasons_all[k] = True
        if n:
            rows.append((label, n, per, reasons))
    if not rows:
        print("causes: no successful pipeline record with a run report in %s" % a.results, file=sys.stderr)
        return 1
    keys = sorted(reasons_all)
    lines = ["Medians per model (kind %s); refusals summed over the models." % a.kind, "",
             "| configuration | models | faces / input chart | regions | region floor | merger chart reduction "
             "| charts out / region | ARAP E | budget spent | merges accepted / attempted | "
             + " | ".join("refused: " + k for k in keys) + " |",
             "|---|---|---|---|---|---|---|---|---|---|" + "---|" * len(keys)]
    for label, n, p, reasons in rows:
        spent = sum(p["spent"]) / len(p["spent"]) if p["spent"] else None
        lines.append("| %s | %d | %s | %s | %s | %s | %s | %s | %s | %s / %s | %s |" % (
            label, n, fmt(med(p["fpc"]), ".2f"), fmt(med(p["regions"]), ".0f"),
            fmt(None if med(p["floor"]) is None else 100 * med(p["floor"]), ".1f") + ("%" if med(p["floor"]) is not None else ""),
            fmt(None if med(p["red"]) is None else 100 * med(p["red"]), ".1f") + ("%" if med(p["red"]) is not None else ""),
            fmt(med(p["per_region"]), ".2f"), fmt(med(p["e"]), ".4f"),
            fmt(None if spent is None else 100 * spent, ".0f") + ("%" if spent is not None else ""),
            fmt(med(p["acc"]), ".0f"), fmt(med(p["att"]), ".0f"),
            " | ".join(str(reasons.get(k, 0)) for k in keys)))
    text = "\n".join(lines) + "\n"
    if a.out:
        with open(a.out, "w") as f:
            f.write(text)
    else:
        sys.stdout.write(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
