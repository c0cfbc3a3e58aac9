"""Shared helpers of the batch tests: a small synthetic production made by the real `texdefrag synth`,
the batch run through the real `texdefrag batch`, and journal / output checks."""

import hashlib
import json
import os
import shutil
import sqlite3
import stat
import subprocess

EXE = os.environ.get("TEXDEFRAG_EXE", "")
SOURCE = os.environ.get("TEXDEFRAG_SOURCE_DIR", "")
WORKDIR = os.environ.get("TEXDEFRAG_TEST_WORKDIR", "")
CONFIG = os.path.join(SOURCE, "configs", "repack.json")


def make_production(folder, n, seed=1, min_faces=1000, max_faces=2000):
    """n synthetic buildings as a folder of OBJ tiles (bNNNN/bNNNN.obj...), made once per folder."""
    if os.path.exists(os.path.join(folder, "manifest.json")):
        return folder
    tmp = folder + ".tmp"
    shutil.rmtree(tmp, ignore_errors=True)
    subprocess.run([EXE, "synth", "--count", str(n), "--seed", str(seed), "--min-faces", str(min_faces),
                    "--max-faces", str(max_faces), "-o", tmp], check=True, capture_output=True)
    for root, _, files in os.walk(tmp):  # truth files are not tiles' inputs; keep the folder lean
        for f in files:
            if f.endswith(".truth.json"):
                os.remove(os.path.join(root, f))
    os.rename(tmp, folder)
    return folder


def fresh_dir(*parts):
    """The empty folder WORKDIR/parts... (what an earlier run left there is removed first)."""
    d = os.path.join(WORKDIR, *parts)
    shutil.rmtree(d, ignore_errors=True)
    os.makedirs(d)
    return d


def copy_production(src, dst):
    shutil.rmtree(dst, ignore_errors=True)
    shutil.copytree(src, dst)
    return dst


def batch(*args, exe=None, timeout=300):
    """Runs `texdefrag batch ARGS`; returns the CompletedProcess (text)."""
    return subprocess.run([exe or EXE, "batch", *args], capture_output=True, text=True, timeout=timeout)


def journal_rows(out):
    db = sqlite3.connect(os.path.join(out, ".texdefrag-batch", "journal.sqlite"))
    tasks = {r[0]: {"status": r[1], "attempts": r[2], "error": r[3], "outputs": json.loads(r[4] or "[]")}
             for r in db.execute("SELECT id, status, attempts, error, outputs FROM tasks")}
    attempts = [dict(zip(("task_id", "status", "error", "batch_id"), r))
                for r in db.execute("SELECT task_id, status, error, batch_id FROM attempts ORDER BY rowid")]
    db.close()
    return tasks, attempts


def model_files(out):
    """{relative path: sha256} of the model files under out (report JSON and batch state excluded:
    the report holds times)."""
    res = {}
    for root, dirs, files in os.walk(out):
        dirs[:] = [d for d in dirs if not d.startswith(".")]
        for f in files:
            if f.endswith(".report.json"):
                continue
            p = os.path.join(root, f)
            with open(p, "rb") as fh:
                res[os.path.relpath(p, out)] = hashlib.sha256(fh.read()).hexdigest()
    return res


def leftovers(out):
    """Files that must not exist after a batch: staging content and temporary names."""
    bad = []
    staging = os.path.join(out, ".texdefrag-batch", "staging")
    if os.path.isdir(staging) and os.listdir(staging):
        bad += [os.path.join(staging, x) for x in os.listdir(staging)]
    for root, _, files in os.walk(out):
        bad += [os.path.join(root, f) for f in files if ".tmp" in f]
    return bad


def write_wrapper(path, real_exe):
    """An executable that behaves as texdefrag, except that `run` on an input whose path contains
    "crashme" dies with SIGSEGV and on "slowme" hangs (a crashing and a hanging tile)."""
    with open(path, "w") as f:
        f.write(f"""#!/bin/sh
if [ "$1" = run ]; then
  case "$2" in
    *crashme*) echo "about to crash on $2" >&2; kill -SEGV $$ ;;
    *slowme*) exec sleep 600 ;;
  esac
fi
exec {real_exe} "$@"
""")
    os.chmod(path, os.stat(path).st_mode | stat.S_IXUSR | stat.S_IXGRP | stat.S_IXOTH)
    return path
