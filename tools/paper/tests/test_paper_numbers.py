#!/usr/bin/env python3
"""test_paper_numbers: tools/paper/paper_numbers.py on a hand-built results.csv with known answers."""
import csv
import os
import sys
import tempfile

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
import paper_numbers  # noqa: E402

COLS = ["config", "model", "status", "meta.kind", "chart_reduction", "seam_3d_reduction", "uv_border_reduction",
        "distortion_arap", "texture_mp_change", "texture_bytes_change", "replication_in", "replication_out"]


def row(config, model, cr, arap, mp, rout, status="ok", kind="real"):
    return {"config": config, "model": model, "status": status, "meta.kind": kind, "chart_reduction": cr,
            "seam_3d_reduction": cr - 0.2, "uv_border_reduction": cr - 0.1, "distortion_arap": arap,
            "texture_mp_change": mp, "texture_bytes_change": mp / 2, "replication_in": 2.5, "replication_out": rout}


def check(cond, msg):
    if not cond:
        print("FAIL: " + msg, file=sys.stderr)
        sys.exit(1)


def main():
    rows = [
        row("paper", "a", 0.92, 0.010, -0.30, 1.5), row("paper", "b", 0.93, 0.012, 0.10, 1.6),
        row("paper", "c", 0.85, 0.020, -0.20, 1.4), row("paper", "d", 0.99, 0.001, -0.5, 1.1),
        row("mmethod_orig", "a", 0.88, 0.017, -0.05, 1.6), row("mmethod_orig", "b", 0.91, 0.018, -0.10, 1.5),
        row("mmethod_orig", "c", 0.80, 0.016, 0.02, 1.5), row("mmethod_orig", "d", 0.5, 0.5, 0.0, 2.0, status="failed"),
        row("paper", "s", 0.50, 0.002, 0.0, 1.0, kind="synthetic"), row("mmethod_orig", "s", 0.6, 0.003, 0.0, 1.0, kind="synthetic"),
    ]
    with tempfile.TemporaryDirectory() as d:
        with open(os.path.join(d, "results.csv"), "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=COLS)
            w.writeheader()
            w.writerows(rows)
        out = os.path.join(d, "n.md")
        check(paper_numbers.main(["--results", d, "--configs", "paper", "mmethod_orig", "--kind", "real", "--out", out]) == 0,
              "exit code")
        text = open(out).read()
        lines = {l.split("|")[2].strip(): [c.strip() for c in l.split("|")[4:-1]] for l in text.splitlines()
                 if l.startswith("| 1") or l.startswith("| 2")}
        # d failed for mmethod_orig: only a, b, c are common; s is synthetic.
        check("Models: 3 (kind real)" in text, text)
        check(lines["median chart reduction"] == ["92.0%", "88.0%"], str(lines["median chart reduction"]))
        check(lines["models with chart reduction >= 90%"] == ["66.7%", "33.3%"], str(lines))
        check(lines["models in 90-95%"] == ["66.7%", "33.3%"], str(lines))
        check(lines["models in 80-95%"] == ["100.0%", "100.0%"], str(lines))
        check(lines["5% bin holding most models"] == ["90..95% (2 of 3)", "80..85% (1 of 3)"], str(lines))
        check(lines["models with 3D seam reduction > 70%"] == ["66.7%", "33.3%"], str(lines))
        check(lines["median ARAP distortion"] == ["0.0120", "0.0170"], str(lines))
        check(lines["max ARAP distortion"] == ["0.0200", "0.0180"], str(lines))
        check(lines["mean texture megapixel change"] == ["-13.3%", "-4.3%"], str(lines))
        check(lines["models whose texture grew"] == ["33.3%", "33.3%"], str(lines))
        check(lines["median V2/V3, output"] == ["1.500", "1.500"], str(lines))
        check(lines["models with V2/V3 below mmethod_orig's"] == ["66.7%", "-"], str(lines))
        # --exclude leaves out models by name: without "a", b and c remain.
        check(paper_numbers.main(["--results", d, "--configs", "paper", "mmethod_orig", "--kind", "real",
                                  "--exclude", "a", "--out", out]) == 0, "exclude exit code")
        ex = open(out).read()
        check("Models: 2 (kind real, not *a*)" in ex and "| 16 | median chart reduction | -90..-95% peak | 89.0% | 85.5% |" in ex, ex)
        # An absent configuration is left out, not fatal.
        check(paper_numbers.main(["--results", d, "--configs", "paper", "nothing", "--out", out]) == 0,
              "an absent configuration is left out, not fatal")
        check("left out): nothing" in open(out).read(), open(out).read())
        check(paper_numbers.main(["--results", os.path.join(d, "none")]) == 1, "missing CSV")
    print("test_paper_numbers: ok")


if __name__ == "__main__":
    main()
