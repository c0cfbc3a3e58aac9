#!/usr/bin/env python3
"""Figures and summary table of a `texdefrag bench` results folder (docs/bench.md).

Reproduces the comparison figures of Liu et al. 2024 ("planar feature-preserving texture
defragmentation", Remote Sensing), Figures 16-20, from RESULTS/results.csv:
  fig16_chart_reduction.png   per-model relative reduction of the chart count (histogram)
  fig17_seam_reduction.png    per-model relative reduction of seam length, 3D and UV border (histograms)
  fig18_distortion.png        ARAP distortion of the UV map (box plots)
  fig19_texture_size.png      per-model relative change of texture megapixels and bytes
  fig20_vertex_replication.png vertex replication V2/V3 before and after, per model
  fig21_rendered_mip.png      rendered-view PSNR / SSIM against viewing distance, input and each configuration
  sweep_<key>.png             medians against the swept value (when a --sweep was run)
and RESULTS/summary.md: median and mean of every derived metric per configuration, and which
configuration wins each metric (over the models every configuration succeeded on).

The table needs only the standard library; the figures need matplotlib (Debian: python3-matplotlib).
Exit codes: 0 ok, 1 bad input, 3 matplotlib missing (summary.md written, no figure).
"""

import argparse
import csv
import math
import os
import statistics
import sys

# Derived metric columns written by eval/bench (src/tables.cpp): name -> (direction, label, scale, unit).
# direction +1: larger is better, -1: smaller is better, 0: not compared.
METRICS = [
    ("chart_reduction", +1, "chart count reduction", 100, "%"),
    ("chart_reduction_nonzero", +1, "chart reduction (non-zero-area charts)", 100, "%"),
    ("uv_border_reduction", +1, "UV border length reduction", 100, "%"),
    ("seam_3d_reduction", +1, "3D seam length reduction", 100, "%"),
    ("distortion_arap", -1, "ARAP distortion", 1, ""),
    ("distortion_sym_dirichlet", -1, "symmetric Dirichlet", 1, ""),
    ("flipped_faces", -1, "flipped faces", 1, ""),
    ("texture_mp_change", -1, "texture megapixels change", 100, "%"),
    ("texture_bytes_change", -1, "texture bytes change", 100, "%"),
    ("replication_in", 0, "vertex replication, input", 1, ""),
    ("replication_out", -1, "vertex replication, output", 1, ""),
    ("charts_in", 0, "charts, input", 1, ""),
    ("charts_out", 0, "charts, output", 1, ""),
    ("packing_efficiency_out", +1, "packing efficiency, output", 100, "%"),
    ("uv_overlaps_out", -1, "UV overlaps, output", 1, ""),
    ("psnr_db", +1, "texture PSNR", 1, "dB"),
    ("copied_fraction", +1, "surface copied without resampling", 100, "%"),
    ("lost_faces", -1, "lost faces", 1, ""),
    ("time_s", -1, "time", 1, "s"),
    ("peak_rss_mb", -1, "peak memory", 1, "MiB"),
    ("clash_fraction_l2_in", 0, "texel clashes at MIP level 2, input", 100, "%"),
    ("clash_fraction_l2_out", -1, "texel clashes at MIP level 2, output", 100, "%"),
    ("clash_fraction_l4_out", -1, "texel clashes at MIP level 4, output", 100, "%"),
    ("seam_colour_in", 0, "seam colour discrepancy, input", 1, ""),
    ("seam_colour_out", -1, "seam colour discrepancy, output", 1, ""),
    ("seam_colour_l2_in", 0, "seam colour discrepancy at MIP level 2, input", 1, ""),
    ("seam_colour_l2_out", -1, "seam colour discrepancy at MIP level 2, output", 1, ""),
    ("seam_colour_l4_out", -1, "seam colour discrepancy at MIP level 4, output", 1, ""),
    ("input_rendered_psnr_l0", 0, "rendered PSNR of the input, distance step 0", 1, "dB"),
    ("rendered_psnr_l0", +1, "rendered PSNR vs prefiltered input, distance step 0", 1, "dB"),
    ("input_rendered_psnr_l2", 0, "rendered PSNR of the input, distance step 2", 1, "dB"),
    ("rendered_psnr_l2", +1, "rendered PSNR, distance step 2", 1, "dB"),
    ("input_rendered_psnr_l4", 0, "rendered PSNR of the input, distance step 4", 1, "dB"),
    ("rendered_psnr_l4", +1, "rendered PSNR, distance step 4", 1, "dB"),
    ("rendered_ssim_l2", +1, "rendered SSIM, distance step 2", 1, ""),
]
# Rendered-view fidelity per MIP level (docs/eval.md "Appearance"): columns written by eval/bench.
MIP_LEVELS = range(5)
DIRECTION = {m[0]: m[1] for m in METRICS}


def parse_number(text):
    """A CSV cell as a float; None for empty or non-numeric cells ("inf" is +infinity)."""
    if text is None or text == "":
        return None
    try:
        return float(text)
    except ValueError:
        return None


def read_results(path):
    """Rows of results.csv as dicts; raises OSError / ValueError on a missing or malformed file."""
    with open(path, newline="") as f:
        reader = csv.DictReader(f)
        if reader.fieldnames is None or "config" not in reader.fieldnames or "model" not in reader.fieldnames:
            raise ValueError(f"{path}: not a bench results CSV (no config/model columns)")
        return list(reader)


def config_order(rows):
    order = []
    for r in rows:
        if r["config"] not in order:
            order.append(r["config"])
    return order


def values(rows, config, metric, models=None):
    out = []
    for r in rows:
        if r["config"] != config or r.get("status") != "ok":
            continue
        if models is not None and r["model"] not in models:
            continue
        v = parse_number(r.get(metric))
        if v is not None and not math.isnan(v):
            out.append(v)
    return out


def fmt(v, scale, unit):
    if v is None:
        return "-"
    if math.isinf(v):
        return "inf" if v > 0 else "-inf"
    v *= scale
    if unit == "%":
        return f"{v:.1f}%"
    if v == int(v):
        return f"{v:.0f}"
    if abs(v) >= 100:
        return f"{v:.1f}"
    return f"{v:.4g}"


def mean(vs):
    if any(math.isinf(v) for v in vs):
        pos, neg = any(v == math.inf for v in vs), any(v == -math.inf for v in vs)
        return math.nan if pos and neg else (math.inf if pos else -math.inf)
    return statistics.fmean(vs)


def winners(stats, configs, metric):
    """Configs with the best median of `metric` (ties share), or [] when fewer than two have one."""
    d = DIRECTION.get(metric, 0)
    meds = {c: stats[c][metric][0] for c in configs if stats[c].get(metric)}
    if d == 0 or len(meds) < 2:
        return []
    best = max(v * d for v in meds.values())
    return [c for c, v in meds.items() if v * d == best]


def table(rows, configs, models, title):
    stats = {}
    for c in configs:
        stats[c] = {}
        for name, *_ in METRICS:
            vs = values(rows, c, name, models)
            if vs:
                stats[c][name] = (statistics.median(vs), mean(vs), len(vs))
    lines = [f"### {title}", "", "median / mean (n) per configuration; **best** median in bold "
             "(direction: larger is better for reductions, efficiency, PSNR, copied; smaller otherwise)", ""]
    lines.append("| metric | " + " | ".join(configs) + " | best |")
    lines.append("|---|" + "---|" * len(configs) + "---|")
    for name, direction, label, scale, unit in METRICS:
        if not any(name in stats[c] for c in configs):
            continue
        win = winners(stats, configs, name)
        cells = []
        for c in configs:
            if name not in stats[c]:
                cells.append("-")
                continue
            med, avg, n = stats[c][name]
            cell = f"{fmt(med, scale, unit)} / {fmt(avg, scale, unit)} ({n})"
            cells.append(f"**{cell}**" if c in win and len(win) < len(configs) else cell)
        best = ", ".join(win) if win and len(win) < len(configs) else ("tie" if win else "")
        lines.append(f"| {label} | " + " | ".join(cells) + f" | {best} |")
    return lines, stats


def summary_markdown(rows, configs):
    lines = ["# texdefrag bench summary", ""]
    lines.append("| configuration | kind | swept | ok | failed | missing |")
    lines.append("|---|---|---|---|---|---|")
    for c in configs:
        rs = [r for r in rows if r["config"] == c]
        kind = rs[0].get("kind", "")
        swept = f"{rs[0].get('sweep_key', '')}={rs[0].get('sweep_value', '')}" if rs[0].get("sweep_key") else ""
        count = {s: sum(1 for r in rs if r.get("status") == s) for s in ("ok", "failed", "missing")}
        lines.append(f"| {c} | {kind} | {swept} | {count['ok']} | {count['failed']} | {count['missing']} |")
    lines.append("")
    ok_models = {c: {r["model"] for r in rows if r["config"] == c and r.get("status") == "ok"} for c in configs}
    common = set.intersection(*ok_models.values()) if ok_models else set()
    all_models = set.union(*ok_models.values()) if ok_models else set()
    if common:
        t, _ = table(rows, configs, common, f"Models every configuration succeeded on (n = {len(common)})")
        lines += t + [""]
    if common != all_models or not common:
        t, _ = table(rows, configs, None, "All successful records")
        lines += t + [""]
    failed = [r for r in rows if r.get("status") == "failed"]
    if failed:
        lines += ["### Failures", ""]
        for r in failed:
            err = (r.get("error") or "").replace("|", "\\|").replace("\n", " ")
            lines.append(f"- {r['config']} / {r['model']} ({r.get('failed_step', '')}): {err[:300]}")
        lines.append("")
    return "\n".join(lines)


# ------------------------------------------------------------------------------------------------
# Figures

def ok_rows(rows, config):
    return [r for r in rows if r["config"] == config and r.get("status") == "ok"]


def save_if_drawn(plt, fig, path, title, drew):
    """Titles and lays out `fig`, writes it to `path` when any panel was drawn, closes it; returns drew."""
    fig.suptitle(title)
    fig.tight_layout()
    if drew:
        fig.savefig(path, dpi=120)
    plt.close(fig)
    return drew


def histogram_figure(plt, rows, configs, panels, path, title):
    """One histogram panel per (metric, label); configurations overlaid, bins of 5%."""
    fig, axes = plt.subplots(1, len(panels), figsize=(6 * len(panels), 4.2), squeeze=False)
    drew = False
    for ax, (metric, label) in zip(axes[0], panels):
        data = [[100 * v for v in values(rows, c, metric)] for c in configs]
        lo = min([0.0] + [min(d) for d in data if d])
        bins = [lo + 5 * i for i in range(int((100 - lo) / 5) + 2)] if lo >= -100 else 20
        for c, d in zip(configs, data):
            if d:
                ax.hist(d, bins=bins, alpha=0.55, label=f"{c} (n={len(d)})", edgecolor="black", linewidth=0.4)
                drew = True
        ax.set_xlabel(f"{label} (%)")
        ax.set_ylabel("models")
        ax.yaxis.set_major_locator(plt.MaxNLocator(integer=True))
        ax.legend(fontsize=8)
        ax.grid(alpha=0.3)
    return save_if_drawn(plt, fig, path, title, drew)


def config_bars_figure(plt, rows, configs, panels, path, title):
    """One model: one panel per (metric, label, scale, unit), one bar per configuration with its
    value written on it (a histogram or box plot over one model would show the same number)."""
    fig, axes = plt.subplots(1, len(panels), figsize=(max(5.0, 1.2 * len(configs) + 2.5) * len(panels), 4.2), squeeze=False)
    drew = False
    for ax, (metric, label, scale, unit) in zip(axes[0], panels):
        pts = [(c, v[0] * scale) for c in configs if (v := values(rows, c, metric))]
        if not pts:
            continue
        bars = ax.bar(range(len(pts)), [p[1] for p in pts], color=[f"C{configs.index(p[0])}" for p in pts])
        for b, (_, v) in zip(bars, pts):
            ax.annotate(f"{v:.4g}{unit}", (b.get_x() + b.get_width() / 2, v), xytext=(0, 3), textcoords="offset points",
                        ha="center", fontsize=8)
        ax.set_xticks(range(len(pts)))
        ax.set_xticklabels([p[0] for p in pts], rotation=30 if len(pts) > 4 else 0)
        ax.set_ylabel(f"{label} ({unit})" if unit else label)
        ax.grid(axis="y", alpha=0.3)
        drew = True
    return save_if_drawn(plt, fig, path, title, drew)


def per_model_bars(plt, rows, configs, metric, ax, scale=100, baseline_metric=None, labels=None):
    models = sorted({r["model"] for r in rows if r.get("status") == "ok"})
    width = 0.8 / (len(configs) + (1 if baseline_metric else 0))
    series = []
    if baseline_metric:
        base = {}
        for r in rows:
            v = parse_number(r.get(baseline_metric))
            if r.get("status") == "ok" and v is not None:
                base.setdefault(r["model"], v)
        series.append(("input", base))
    for c in configs:
        series.append(((labels or {}).get(c, c), {r["model"]: parse_number(r.get(metric)) for r in ok_rows(rows, c)}))
    drew = False
    for k, (name, vals) in enumerate(series):
        xs = [i + k * width for i, m in enumerate(models) if vals.get(m) is not None]
        ys = [scale * vals[m] for m in models if vals.get(m) is not None]
        if ys:
            ax.bar(xs, ys, width=width, label=name)
            drew = True
    ax.set_xticks([i + width * (len(series) - 1) / 2 for i in range(len(models))])
    ax.set_xticklabels(models, rotation=45 if len(models) > 4 else 0, ha="right" if len(models) > 4 else "center",
                       fontsize=8 if len(models) > 10 else 9)
    ax.grid(axis="y", alpha=0.3)
    ax.legend(fontsize=8)
    return drew


def figures(rows, configs, outdir):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    written = []

    def out(name):
        return os.path.join(outdir, name)

    # Figures 16-18 are distributions over models; for one model (a single run's report) they are
    # drawn as one bar per configuration instead.
    single = len({r["model"] for r in rows if r.get("status") == "ok"}) == 1
    if single:
        model = next(r["model"] for r in rows if r.get("status") == "ok")
        for name, panels, title in (
                ("fig16_chart_reduction.png", [("chart_reduction", "chart count reduction", 100, "%")],
                 f"Figure 16 ({model}): chart count reduction"),
                ("fig17_seam_reduction.png", [("seam_3d_reduction", "3D seam length reduction", 100, "%"),
                                              ("uv_border_reduction", "UV border length reduction", 100, "%")],
                 f"Figure 17 ({model}): seam length reduction"),
                ("fig18_distortion.png", [("distortion_arap", "ARAP distortion E", 1, "")],
                 f"Figure 18 ({model}): texture distortion")):
            if config_bars_figure(plt, rows, configs, panels, out(name), title):
                written.append(name)
    if not single and histogram_figure(plt, rows, configs, [("chart_reduction", "relative reduction of the chart count")],
                                       out("fig16_chart_reduction.png"), "Figure 16: chart count reduction per model"):
        written.append("fig16_chart_reduction.png")
    if not single and histogram_figure(plt, rows, configs,
                                       [("seam_3d_reduction", "relative reduction of the 3D seam length"),
                                        ("uv_border_reduction", "relative reduction of the UV border length")],
                                       out("fig17_seam_reduction.png"), "Figure 17: seam length reduction per model"):
        written.append("fig17_seam_reduction.png")

    data = [values(rows, c, "distortion_arap") for c in configs]
    if not single and any(data):
        fig, ax = plt.subplots(figsize=(max(5, 1.6 * len(configs)), 4.2))
        present = [(c, d) for c, d in zip(configs, data) if d]
        ax.boxplot([d for _, d in present], labels=[f"{c}\n(n={len(d)})" for c, d in present], showmeans=True)
        for i, (_, d) in enumerate(present):
            ax.scatter([i + 1] * len(d), d, s=10, alpha=0.5, color="black", zorder=3)
            ax.annotate(f"median {statistics.median(d):.4f}", (i + 1, statistics.median(d)), xytext=(8, 0),
                        textcoords="offset points", fontsize=8)
        ax.set_ylabel("ARAP distortion E")
        ax.set_title("Figure 18: texture distortion")
        ax.grid(axis="y", alpha=0.3)
        fig.tight_layout()
        fig.savefig(out("fig18_distortion.png"), dpi=120)
        plt.close(fig)
        written.append("fig18_distortion.png")

    if any(values(rows, c, "texture_mp_change") for c in configs):
        fig, axes = plt.subplots(2, 1, figsize=(min(16, max(7, 0.6 * len({r['model'] for r in rows}) * len(configs))), 7.5))
        mp_labels = {c: f"{c} (mean {100 * mean(v):+.1f}%)" for c in configs
                     if (v := values(rows, c, "texture_mp_change"))}
        by_labels = {c: f"{c} (mean {100 * mean(v):+.1f}%)" for c in configs
                     if (v := values(rows, c, "texture_bytes_change"))}
        per_model_bars(plt, rows, configs, "texture_mp_change", axes[0], labels=mp_labels)
        axes[0].set_ylabel("texture megapixels change (%)")
        per_model_bars(plt, rows, configs, "texture_bytes_change", axes[1], labels=by_labels)
        axes[1].set_ylabel("texture bytes change (%)")
        for ax in axes:
            ax.axhline(0, color="black", linewidth=0.8)
        axes[0].set_title("Figure 19: texture size change per model (pages' megapixels, and bytes on disk)")
        fig.tight_layout()
        fig.savefig(out("fig19_texture_size.png"), dpi=120)
        plt.close(fig)
        written.append("fig19_texture_size.png")

    if any(values(rows, c, "replication_out") for c in configs):
        fig, ax = plt.subplots(figsize=(min(16, max(7, 0.6 * len({r['model'] for r in rows}) * (len(configs) + 1))), 4.5))
        per_model_bars(plt, rows, configs, "replication_out", ax, scale=1, baseline_metric="replication_in")
        ax.set_ylabel("vertex replication V2 / V3")
        ax.axhline(1, color="black", linewidth=0.8)
        ax.set_title("Figure 20: vertex replication before (input) and after")
        fig.tight_layout()
        fig.savefig(out("fig20_vertex_replication.png"), dpi=120)
        plt.close(fig)
        written.append("fig20_vertex_replication.png")

    if rendered_mip_figure(plt, rows, configs, out("fig21_rendered_mip.png")):
        written.append("fig21_rendered_mip.png")

    # Sweeps: medians against the swept value, one line per base configuration.
    sweeps = {}
    for r in rows:
        if r.get("sweep_key") and r.get("status") == "ok":
            sweeps.setdefault(r["sweep_key"], set()).add(r.get("base_config", ""))
    for key, bases in sorted(sweeps.items()):
        panels = ["chart_reduction", "seam_3d_reduction", "distortion_arap", "texture_mp_change"]
        fig, axes = plt.subplots(1, len(panels), figsize=(4.2 * len(panels), 3.8), squeeze=False)
        for ax, metric in zip(axes[0], panels):
            for base in sorted(bases):
                labels = [c for c in configs if any(r["config"] == c and r.get("base_config") == base
                                                    and r.get("sweep_key") == key for r in rows)]
                pts = []
                for c in labels:
                    v = values(rows, c, metric)
                    sv = next(r.get("sweep_value", "") for r in rows if r["config"] == c)
                    if v:
                        pts.append((sv, statistics.median(v)))
                numeric = all(parse_number(p[0]) is not None for p in pts)
                if numeric:
                    pts.sort(key=lambda p: parse_number(p[0]))
                xs = [parse_number(p[0]) if numeric else i for i, p in enumerate(pts)]
                ax.plot(xs, [p[1] for p in pts], marker="o", label=base)
                if not numeric:
                    ax.set_xticks(range(len(pts)))
                    ax.set_xticklabels([p[0] for p in pts], rotation=30)
            ax.set_xlabel(key)
            ax.set_ylabel(f"median {metric}")
            ax.grid(alpha=0.3)
            ax.legend(fontsize=8)
        fig.tight_layout()
        name = "sweep_" + "".join(ch if ch.isalnum() or ch in "._-" else "_" for ch in key) + ".png"
        fig.savefig(out(name), dpi=120)
        plt.close(fig)
        written.append(name)
    return written


def rendered_mip_figure(plt, rows, configs, path):
    """Rendered fidelity against viewing distance (median over models): PSNR and SSIM of each
    configuration's output, rendered with trilinear MIP-mapping at distance step d (render size
    S / 2^d), against the prefiltered input (docs/eval.md, "Rendered-view fidelity"), and the
    input's own curve. False when no record has rendered views."""
    def curve(config, prefix, what):
        pts = []
        for level in MIP_LEVELS:
            v = [x for x in values(rows, config, f"{prefix}{what}_l{level}") if math.isfinite(x)]
            if v:
                pts.append((level, statistics.median(v)))
        return pts
    if not any(curve(c, "rendered_", "psnr") for c in configs):
        return False
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    for ax, what, unit in ((axes[0], "psnr", "PSNR (dB)"), (axes[1], "ssim", "SSIM")):
        # The input's curve: the same for every configuration (same models), taken from the first.
        base = next((curve(c, "input_rendered_", what) for c in configs if curve(c, "input_rendered_", what)), [])
        if base:
            ax.plot([p[0] for p in base], [p[1] for p in base], color="black", linestyle="--", marker="s", label="input")
        for c in configs:
            pts = curve(c, "rendered_", what)
            if pts:
                ax.plot([p[0] for p in pts], [p[1] for p in pts], marker="o", label=c)
        ax.set_xlabel("distance step d (render size S / 2^d)")
        ax.set_ylabel(f"median {unit} vs prefiltered input")
        ax.set_xticks(list(MIP_LEVELS))
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle("Rendered fidelity against viewing distance (trilinear MIP-mapped renders, fixed views)")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return True


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--results", required=True, help="bench results folder (holds results.csv)")
    ap.add_argument("--csv", help="results CSV (default RESULTS/results.csv)")
    ap.add_argument("--figures", help="folder for the PNG figures (default RESULTS/figures)")
    ap.add_argument("--configs", nargs="*", help="configurations to include, in this order (default: all)")
    ap.add_argument("--summary", help="markdown table to write (default RESULTS/summary.md)")
    args = ap.parse_args(argv)

    csv_path = args.csv or os.path.join(args.results, "results.csv")
    try:
        rows = read_results(csv_path)
    except (OSError, ValueError) as e:
        print(f"plots.py: {e}", file=sys.stderr)
        return 1
    configs = config_order(rows)
    if args.configs:
        unknown = [c for c in args.configs if c not in configs]
        if unknown:
            print(f"plots.py: unknown configuration(s) {', '.join(unknown)}; present: {', '.join(configs)}",
                  file=sys.stderr)
            return 1
        configs = args.configs
        rows = [r for r in rows if r["config"] in configs]
    if not rows:
        print(f"plots.py: {csv_path} has no records", file=sys.stderr)
        return 1

    md = summary_markdown(rows, configs)
    md_path = args.summary or os.path.join(args.results, "summary.md")
    with open(md_path, "w") as f:
        f.write(md + "\n")
    print(f"plots.py: wrote {md_path}")

    try:
        import matplotlib  # noqa: F401
    except ImportError:
        print(f"plots.py: matplotlib is not installed for {sys.executable}; no figures written "
              "(Debian: apt install python3-matplotlib)", file=sys.stderr)
        return 3
    figdir = args.figures or os.path.join(args.results, "figures")
    os.makedirs(figdir, exist_ok=True)
    written = figures(rows, configs, figdir)
    print(f"plots.py: wrote {len(written)} figure(s) in {figdir}: {', '.join(written)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
