#!/usr/bin/env python3
"""The statistics Liu et al. 2024 quote for Figures 16-20, from a `texdefrag bench` results folder.

  paper_numbers.py --results RESULTS [--configs paper mmethod_orig ...] [--kind real|synthetic|all]
                   [--exclude TEXT ...] [--out FILE.md]

Reads RESULTS/results.csv (docs/bench.md), keeps the successful records of the models every
listed configuration succeeded on (so each column is over the same buildings), optionally only
models whose manifest `kind` (column meta.kind, tools/paper/make_buildings.py) matches and whose
name holds none of the --exclude texts (e.g. `t078_`: the rural tile's pieces), and writes
one markdown table, a row per statement of the paper, a column per configuration:
  Fig. 16 charts:  median chart reduction; share of models >= 90%; share in [90%, 95%); share in
                   [80%, 95%); the 5%-wide bin holding most models (the paper's "peak interval")
  Fig. 17 seams:   median 3D seam and UV border reduction; share of models above 70%
  Fig. 18 ARAP:    median (the paper's 0.011 / 0.017), mean, max
  Fig. 19 texture: mean megapixel change (the paper's -19.6% / -6.4%), median, share of models that
                   grew; mean bytes change
  Fig. 20 V2/V3:   median input and output replication, share of models below the M-method's
Standard library only. Exit 0, or 1 for a missing/unreadable CSV or no common model.
"""
import argparse
import csv
import math
import os
import statistics
import sys


def num(text):
    if text is None or text == "":
        return None
    try:
        v = float(text)
    except ValueError:
        return None
    return v if math.isfinite(v) else None


def load(path, kind, exclude=()):
    with open(path, newline="") as f:
        rows = [r for r in csv.DictReader(f) if r.get("status") == "ok" and not any(x in r["model"] for x in exclude)]
    if kind != "all":
        rows = [r for r in rows if r.get("meta.kind", "") == kind]
    return rows


def common_models(rows, configs):
    sets = [set(r["model"] for r in rows if r["config"] == c) for c in configs]
    return set.intersection(*sets) if sets else set()


def column(rows, config, metric, models):
    out = []
    for r in rows:
        if r["config"] == config and r["model"] in models:
            v = num(r.get(metric))
            if v is not None:
                out.append(v)
    return out


def share(vs, pred):
    return sum(1 for v in vs if pred(v)) / len(vs) if vs else None


def peak_bin(vs):
    """The 5%-wide bin [lo, lo+5%) holding most values (lowest bin on ties), as text."""
    if not vs:
        return "-"
    counts = {}
    for v in vs:
        b = math.floor(v * 100 / 5 + 1e-9) * 5
        counts[b] = counts.get(b, 0) + 1
    best = max(counts.values())
    lo = min(b for b, c in counts.items() if c == best)
    return "%d..%d%% (%d of %d)" % (lo, lo + 5, best, len(vs))


def pct(v):
    return "-" if v is None else "%.1f%%" % (100 * v)


def val(v, digits=4):
    return "-" if v is None else ("%.*f" % (digits, v))


def med(vs):
    return statistics.median(vs) if vs else None


def avg(vs):
    return sum(vs) / len(vs) if vs else None


def rows_for(rows, configs, models):
    def col(metric):
        return {c: column(rows, c, metric, models) for c in configs}

    cr, s3, uv = col("chart_reduction"), col("seam_3d_reduction"), col("uv_border_reduction")
    ar, mp, by = col("distortion_arap"), col("texture_mp_change"), col("texture_bytes_change")
    ri, ro = col("replication_in"), col("replication_out")
    ref = "mmethod_orig" if "mmethod_orig" in configs else None
    ref_out = {r["model"]: num(r.get("replication_out")) for r in rows
               if ref and r["config"] == ref and r["model"] in models}

    def below_ref(c):
        if not ref or c == ref:
            return "-"
        pairs = [(num(r.get("replication_out")), ref_out.get(r["model"])) for r in rows
                 if r["config"] == c and r["model"] in models]
        pairs = [p for p in pairs if p[0] is not None and p[1] is not None]
        return pct(share(pairs, lambda p: p[0] < p[1])) if pairs else "-"

    return [
        ("16", "median chart reduction", "-90..-95% peak", {c: pct(med(cr[c])) for c in configs}),
        ("16", "models with chart reduction >= 90%", "more than half", {c: pct(share(cr[c], lambda v: v >= 0.9)) for c in configs}),
        ("16", "models in 90-95%", "peak interval", {c: pct(share(cr[c], lambda v: 0.9 <= v < 0.95)) for c in configs}),
        ("16", "models in 80-95%", "M-method: most", {c: pct(share(cr[c], lambda v: 0.8 <= v < 0.95)) for c in configs}),
        ("16", "5% bin holding most models", "90..95%", {c: peak_bin(cr[c]) for c in configs}),
        ("17", "median 3D seam length reduction", "-", {c: pct(med(s3[c])) for c in configs}),
        ("17", "models with 3D seam reduction > 70%", "more than half", {c: pct(share(s3[c], lambda v: v > 0.7)) for c in configs}),
        ("17", "median UV border length reduction", "-", {c: pct(med(uv[c])) for c in configs}),
        ("17", "models with UV border reduction > 70%", "more than half", {c: pct(share(uv[c], lambda v: v > 0.7)) for c in configs}),
        ("18", "median ARAP distortion", "0.011 (M-method 0.017)", {c: val(med(ar[c])) for c in configs}),
        ("18", "mean ARAP distortion", "-", {c: val(avg(ar[c])) for c in configs}),
        ("18", "max ARAP distortion", "cap 0.025", {c: val(max(ar[c]) if ar[c] else None) for c in configs}),
        ("19", "mean texture megapixel change", "-19.6% (M-method -6.4%)", {c: pct(avg(mp[c])) for c in configs}),
        ("19", "median texture megapixel change", "-", {c: pct(med(mp[c])) for c in configs}),
        ("19", "models whose texture grew", "some", {c: pct(share(mp[c], lambda v: v > 0)) for c in configs}),
        ("19", "mean texture bytes change", "-", {c: pct(avg(by[c])) for c in configs}),
        ("20", "median V2/V3, input", "-", {c: val(med(ri[c]), 3) for c in configs}),
        ("20", "median V2/V3, output", "below the M-method's", {c: val(med(ro[c]), 3) for c in configs}),
        ("20", "models with V2/V3 below mmethod_orig's", "most", {c: below_ref(c) for c in configs}),
    ]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--results", required=True)
    ap.add_argument("--configs", nargs="+", default=["paper", "mmethod_orig", "mmethod", "best"])
    ap.add_argument("--kind", default="all", choices=["all", "real", "synthetic"])
    ap.add_argument("--exclude", nargs="*", default=[], help="leave out models whose name contains one of these")
    ap.add_argument("--out", help="markdown file (default: standard output)")
    a = ap.parse_args(argv)
    path = os.path.join(a.results, "results.csv")
    try:
        rows = load(path, a.kind, a.exclude)
    except OSError as e:
        print("paper_numbers: %s: %s" % (path, e), file=sys.stderr)
        return 1
    present = [c for c in a.configs if any(r["config"] == c for r in rows)]
    absent = [c for c in a.configs if c not in present]
    models = common_models(rows, present)
    if not models:
        print("paper_numbers: %s: no model where every configuration of %s succeeded (kind %s)"
              % (path, " ".join(a.configs), a.kind), file=sys.stderr)
        return 1
    lines = ["Models: %d (kind %s%s) where every configuration succeeded: %s"
             % (len(models), a.kind, "".join(", not *%s*" % x for x in a.exclude), ", ".join(present)),
             "" if not absent else "Configurations without a successful record (left out): %s" % ", ".join(absent), "",
             "| fig. | statistic | paper (Liu et al.) | " + " | ".join(present) + " |",
             "|---|---|---|" + "---|" * len(present)]
    for fig, what, paper, by in rows_for(rows, present, models):
        lines.append("| %s | %s | %s | %s |" % (fig, what, paper, " | ".join(by[c] for c in present)))
    text = "\n".join(lines) + "\n"
    if a.out:
        with open(a.out, "w") as f:
            f.write(text)
    else:
        sys.stdout.write(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
