#!/usr/bin/env python3
"""Test of plots.py on a small hand-written results CSV (run by ctest as test_plots).

Checks the summary table's medians, means and winners against hand-computed values, the
failure list, and that every figure is written as a PNG. Exit 77 (ctest skip) when matplotlib
is missing, after checking the table (which needs only the standard library).
"""

import argparse
import csv
import os
import shutil
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
COLUMNS = ["config", "base_config", "kind", "sweep_key", "sweep_value", "model", "status", "failed_step", "error",
           "chart_reduction", "seam_3d_reduction", "uv_border_reduction", "distortion_arap", "texture_mp_change",
           "texture_bytes_change", "replication_in", "replication_out", "psnr_db",
           "rendered_psnr_l0", "rendered_psnr_l1", "rendered_ssim_l0", "rendered_ssim_l1",
           "input_rendered_psnr_l0", "input_rendered_psnr_l1", "input_rendered_ssim_l0", "input_rendered_ssim_l1"]


def row(config, model, status="ok", kind="pipeline", sweep=("", ""), base=None, **metrics):
    r = {c: "" for c in COLUMNS}
    r.update(config=config, base_config=base or config, kind=kind, sweep_key=sweep[0], sweep_value=sweep[1],
             model=model, status=status)
    r.update({k: str(v) for k, v in metrics.items()})
    return r


def rows():
    out = []
    # ours: chart reductions 0.90, 0.94, 0.92 -> median 92.0%, mean 92.0%; ARAP 0.010, 0.012, 0.011 -> median 0.011
    for m, cr, arap, mp in (("m1", 0.90, 0.010, -0.20), ("m2", 0.94, 0.012, -0.10), ("m3", 0.92, 0.011, -0.30)):
        out.append(row("paper", m, chart_reduction=cr, seam_3d_reduction=0.7, uv_border_reduction=0.75,
                       distortion_arap=arap, texture_mp_change=mp, texture_bytes_change=mp, replication_in=1.8,
                       replication_out=1.2, psnr_db="inf", rendered_psnr_l0=31.0, rendered_psnr_l1=27.5,
                       rendered_ssim_l0=0.95, rendered_ssim_l1=0.9, input_rendered_psnr_l0="inf",
                       input_rendered_psnr_l1=26.0, input_rendered_ssim_l0=1.0, input_rendered_ssim_l1=0.88))
    # the other: 0.85, 0.80 and one failure -> median 82.5%; ARAP 0.017, 0.020
    for m, cr, arap, mp in (("m1", 0.85, 0.017, -0.05), ("m2", 0.80, 0.020, -0.08)):
        out.append(row("mmethod", m, kind="external", chart_reduction=cr, seam_3d_reduction=0.8,
                       uv_border_reduction=0.7, distortion_arap=arap, texture_mp_change=mp, texture_bytes_change=mp,
                       replication_in=1.8, replication_out=1.4, psnr_db=30.5))
    out.append(row("mmethod", "m3", status="failed", kind="external", failed_step="eval", error="exit code 1: bad, mesh"))
    for g, cr in (("2", 0.5), ("8", 0.4)):
        out.append(row(f"repack[gutter={g}]", "m1", base="repack", sweep=("packer.gutter", g), chart_reduction=cr,
                       distortion_arap=0.0, texture_mp_change=0.1))
    return out


def fail(msg):
    print("FAIL:", msg)
    sys.exit(1)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--workdir", required=True)
    args = ap.parse_args()
    shutil.rmtree(args.workdir, ignore_errors=True)
    os.makedirs(args.workdir)
    with open(os.path.join(args.workdir, "results.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=COLUMNS)
        w.writeheader()
        w.writerows(rows())

    # Only the two compared configurations in the table.
    p = subprocess.run([sys.executable, os.path.join(HERE, "plots.py"), "--results", args.workdir,
                        "--configs", "paper", "mmethod"], capture_output=True, text=True)
    md = open(os.path.join(args.workdir, "summary.md")).read()
    print(md)
    if p.returncode not in (0, 3):
        fail(f"plots.py exit {p.returncode}: {p.stderr}")
    lines = md.splitlines()

    def line_of(label):
        hits = [l for l in lines if l.startswith(f"| {label} |")]
        if not hits:
            fail(f"no table row '{label}'")
        return hits[0]

    # Fair table: models both succeeded on (m1, m2): paper 0.90, 0.94 -> median 92.0%; mmethod 85, 80 -> 82.5%.
    if "(n = 2)" not in md:
        fail("the common-models table should have n = 2")
    chart = line_of("chart count reduction")
    if "**92.0% / 92.0% (2)**" not in chart or "82.5% / 82.5% (2)" not in chart or not chart.endswith("| paper |"):
        fail(f"chart row wrong: {chart}")
    arap = line_of("ARAP distortion")
    if "**0.011 / 0.011 (2)**" not in arap or "0.0185 / 0.0185 (2)" not in arap or not arap.endswith("| paper |"):
        fail(f"ARAP row wrong: {arap}")
    seam = line_of("3D seam length reduction")
    if not seam.endswith("| mmethod |"):
        fail(f"seam winner should be mmethod: {seam}")
    rep_in = line_of("vertex replication, input")
    if not rep_in.endswith("|  |"):
        fail(f"input replication is not compared: {rep_in}")
    if "inf / inf (2)" not in line_of("texture PSNR"):
        fail("PSNR of identical textures should read inf")
    # All-records table (m3 only for paper): median of 0.90, 0.94, 0.92 = 92.0%, n = 3.
    if "All successful records" not in md or "92.0% / 92.0% (3)" not in md:
        fail("the all-records table is missing or wrong")
    if "mmethod / m3 (eval): exit code 1: bad, mesh" not in md:
        fail("the failure list is missing")
    if "| mmethod | external |  | 2 | 1 | 0 |" not in md:
        fail("counts row wrong")

    # Unknown configuration: a clear error.
    bad = subprocess.run([sys.executable, os.path.join(HERE, "plots.py"), "--results", args.workdir,
                          "--configs", "nope"], capture_output=True, text=True)
    if bad.returncode != 1 or "unknown configuration" not in bad.stderr:
        fail(f"unknown config: exit {bad.returncode} {bad.stderr}")

    # Without matplotlib (a shadowing package that fails to import): exit 3, the table still written.
    fake = os.path.join(args.workdir, "no_matplotlib")
    os.makedirs(os.path.join(fake, "matplotlib"), exist_ok=True)
    with open(os.path.join(fake, "matplotlib", "__init__.py"), "w") as f:
        f.write("raise ImportError('matplotlib hidden by test_plots')\n")
    os.remove(os.path.join(args.workdir, "summary.md"))
    env = dict(os.environ, PYTHONPATH=fake)
    hidden = subprocess.run([sys.executable, os.path.join(HERE, "plots.py"), "--results", args.workdir],
                            capture_output=True, text=True, env=env)
    if hidden.returncode != 3 or "matplotlib is not installed" not in hidden.stderr:
        fail(f"without matplotlib: exit {hidden.returncode} {hidden.stderr}")
    if not os.path.isfile(os.path.join(args.workdir, "summary.md")):
        fail("without matplotlib the table must still be written")

    if p.returncode == 3:
        print("matplotlib missing: figures not tested")
        return 77
    # Everything, with the sweep.
    p = subprocess.run([sys.executable, os.path.join(HERE, "plots.py"), "--results", args.workdir],
                       capture_output=True, text=True)
    if p.returncode != 0:
        fail(f"plots.py exit {p.returncode}: {p.stderr}")
    figdir = os.path.join(args.workdir, "figures")
    for name in ("fig16_chart_reduction.png", "fig17_seam_reduction.png", "fig18_distortion.png",
                 "fig19_texture_size.png", "fig20_vertex_replication.png", "fig21_rendered_mip.png",
                 "sweep_packer.gutter.png"):
        path = os.path.join(figdir, name)
        if not os.path.isfile(path):
            fail(f"missing figure {name}: {p.stdout} {p.stderr}")
        with open(path, "rb") as f:
            if f.read(8) != b"\x89PNG\r\n\x1a\n":
                fail(f"{name} is not a PNG")
        if os.path.getsize(path) < 5000:
            fail(f"{name} is suspiciously small")
    # One model (a single run's report): Figures 16-18 become per-configuration bars, 19-21 stay.
    single_dir = os.path.join(args.workdir, "single")
    os.makedirs(single_dir)
    with open(os.path.join(single_dir, "results.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=COLUMNS)
        w.writeheader()
        w.writerows([r for r in rows() if r["model"] == "m1" and not r["sweep_key"]])
    p = subprocess.run([sys.executable, os.path.join(HERE, "plots.py"), "--results", single_dir],
                       capture_output=True, text=True)
    if p.returncode != 0:
        fail(f"plots.py on one model: exit {p.returncode}: {p.stderr}")
    expected = ["fig16_chart_reduction.png", "fig17_seam_reduction.png", "fig18_distortion.png",
                "fig19_texture_size.png", "fig20_vertex_replication.png", "fig21_rendered_mip.png"]
    got = sorted(os.listdir(os.path.join(single_dir, "figures")))
    if got != expected:
        fail(f"one model: figures {got}, expected {expected}")
    if "wrote 6 figure(s)" not in p.stdout + p.stderr:
        fail(f"one model: {p.stdout} {p.stderr}")
    print("ok")
    return 0


if __name__ == "__main__":
    sys.exit(main())
