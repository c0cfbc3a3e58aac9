# %% [markdown]
# # An ablation sweep from Python (docs/python.md)
# Runs configs/best.json on the bundled example with three distortion budgets and without the
# planar regions, evaluates each output, and plots chart count against ARAP distortion.
# Notebook style: each "# %%" is a cell (VS Code, Jupyter via jupytext). Also a test
# (test_python_example): `python3 docs/python_example.py --out DIR`.

# %%
import argparse
import os

import numpy as np
import texdefrag

parser = argparse.ArgumentParser()
parser.add_argument("--out", default="python_example_out", help="folder for outputs and the figure")
args = parser.parse_args()
os.makedirs(args.out, exist_ok=True)
model = os.path.join(texdefrag._t.install_root(), "share", "texdefrag", "examples", "building", "building.obj")
print(texdefrag.__version__, "shipped configurations:", ", ".join(texdefrag.configs()))

# %% The options a sweep can touch
merger = texdefrag.config("best")["merger"]
print("best.json merger:", merger["type"], "global_bound =", merger["global_bound"])
bound = next(o for o in texdefrag.describe(merger["type"])["options"] if o["key"] == "global_bound")
print("global_bound:", bound["help"], "range", bound.get("min"), "-", bound.get("max"))

# %% The sweep: one run per setting, each evaluated like `texdefrag eval`
runs = [("best", {"merger.global_bound": b}, "global_bound=%g" % b) for b in (0.005, 0.01, 0.025)]
runs.append(("best", {}, "best"))
runs.append(("ablations/no_regions", {}, "no_regions"))
rows = []
for config, overrides, label in runs:
    out_dir = os.path.join(args.out, label.replace("=", "_"))
    r = texdefrag.run(model, out_dir, config=config, overrides=overrides)
    m = texdefrag.eval(model, r.output, texture=False)
    rows.append((label, r.report["output_stats"]["charts"], m["distortion"]["arap"], r.report["total_time_s"]))
    print("%-22s %5d charts  ARAP %.4f  %.2f s" % rows[-1])

# %% Checks (this file is a test): a larger budget never leaves more charts
charts = {label: n for label, n, _, _ in rows}
assert charts["global_bound=0.005"] >= charts["global_bound=0.01"] >= charts["global_bound=0.025"], charts
assert all(r[1] > 0 for r in rows)

# %% Arrays in, arrays out: the same model from numpy (e.g. a mesh made or edited in Python)
src = texdefrag._t.read_model(model, True)
res = texdefrag.run_arrays(src["positions"], src["faces"], src["uvs"], src["pages"],
                           face_uvs=src["face_uvs"], face_pages=src["face_pages"], config="repack")
out = res.model
assert np.array_equal(out["positions"], src["positions"]) and np.array_equal(out["faces"], src["faces"])
print("arrays: %d faces, %d output pages %s" % (len(out["faces"]), len(out["pages"]), out["pages"][0].shape))

# %% The plot
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt

fig, ax = plt.subplots(figsize=(5, 3.5))
for label, n, d, _ in rows:
    ax.scatter(d, n)
    ax.annotate(label, (d, n), textcoords="offset points", xytext=(4, 4), fontsize=8)
ax.set_xlabel("mean ARAP distortion (texdefrag eval)")
ax.set_ylabel("output charts")
ax.set_title("building.obj: distortion budget vs charts")
fig.tight_layout()
figure = os.path.join(args.out, "sweep.png")
fig.savefig(figure, dpi=100)
assert os.path.getsize(figure) > 0
print("figure:", figure)
