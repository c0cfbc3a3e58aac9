"""What a batch has to do: the production's tasks, their hashes, and which of them run.

The task list comes from `texdefrag tasks INPUT --json` (cli/cmd_batch.cpp), the one place that
knows production layouts; this module never guesses a layout. A task is
{"id", "input", "output_dir", "tile", "level"} plus, optionally, "files": the files it reads (the
production reader may list them; otherwise an OBJ's MTLs and their map_* images are found here,
and any other format counts as its one file).
"""

import hashlib
import json
import os
import subprocess


class PlanError(Exception):
    """The batch cannot start; the message names what and where."""


def list_tasks(texdefrag, input_path, exclude):
    """The production's task list (dict with "tasks"); PlanError with texdefrag's message."""
    argv = [texdefrag, "tasks", input_path, "--json", "--exclude", exclude]
    p = subprocess.run(argv, capture_output=True, text=True)
    if p.returncode != 0:
        raise PlanError(p.stderr.strip() or f"`{' '.join(argv)}` failed with exit code {p.returncode}")
    try:
        plan = json.loads(p.stdout)
    except ValueError as e:
        raise PlanError(f"`{' '.join(argv)}` printed no valid JSON: {e}") from None
    ids = set()
    for t in plan.get("tasks", []):
        if t["id"] in ids:
            raise PlanError(f"{input_path}: two tasks share the id {t['id']!r}")
        ids.add(t["id"])
    return plan


def validate_config(texdefrag, config, sets):
    """Raises PlanError with texdefrag's messages when the configuration is invalid."""
    argv = [texdefrag, "validate", "--config", config]
    for s in sets:
        argv += ["--set", s]
    p = subprocess.run(argv, capture_output=True, text=True)
    if p.returncode != 0:
        raise PlanError(p.stderr.strip() or f"{config}: invalid configuration (exit code {p.returncode})")


def config_hash(config, sets, run_options=()):
    """sha256 of the configuration's canonical JSON, the overrides in order, and the run options
    that change what a run accepts or writes (--allow-missing-children); without any, the hash is
    that of the configuration and overrides alone (journals of earlier batches stay valid)."""
    try:
        with open(config) as f:
            cfg = json.load(f)
    except (OSError, ValueError) as e:
        raise PlanError(f"{config}: {e}") from None
    doc = {"config": cfg, "sets": list(sets)}
    if run_options:
        doc["run_options"] = list(run_options)
    text = json.dumps(doc, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()


def _rest_path(folder, tokens):
    """The file named by the end of a statement (options first, the path may hold spaces): the
    longest tail of `tokens` that names an existing file, else None."""
    for i in range(len(tokens)):
        p = os.path.join(folder, " ".join(tokens[i:]))
        if os.path.isfile(p):
            return p
    return None


def obj_dependencies(obj_path):
    """The OBJ, its MTL files and the images they name (map_*), as found on disk. A reference to a
    missing file is left out: the run itself then fails with the reader's FILE:LINE error."""
    files, folder = [obj_path], os.path.dirname(obj_path)
    with open(obj_path, "rb") as f:
        mtls = [_rest_path(folder, line.decode("utf-8", "replace").split()[1:])
                for line in f if line.startswith(b"mtllib")]
    for mtl in mtls:
        if mtl is None or mtl in files:
            continue
        files.append(mtl)
        mfolder = os.path.dirname(mtl)
        with open(mtl, "rb") as f:
            for line in f:
                tok = line.decode("utf-8", "replace").split()
                if tok and tok[0].startswith("map_"):
                    img = _rest_path(mfolder, tok[1:])
                    if img and img not in files:
                        files.append(img)
    return files


def task_files(task):
    files = task.get("files")
    if files:
        return list(files)
    if task["input"].lower().endswith(".obj"):
        return obj_dependencies(task["input"])
    return [task["input"]]


def _sha256_file(path):
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def input_hash(task, cached):
    """(hash, files) of a task's inputs. files = [[path, size, mtime_ns], ...]. When the journal's
    record (cached: its files and hash) has the same stats, its hash is reused without reading.
    Raises FileNotFoundError naming the task's input when it is missing."""
    if not os.path.isfile(task["input"]):
        raise FileNotFoundError(f"tile file {task['input']} (task {task['id']}) is missing")
    old_files = (cached or {}).get("files")
    if old_files and old_files[0][0] == task["input"]:
        try:
            same = all(list(_stat(p)) == [p, s, m] for p, s, m in old_files)
        except OSError:
            same = False
        # The OBJ is unchanged, so it names the same MTLs and images: the old list is complete.
        if same and cached.get("input_hash"):
            return cached["input_hash"], old_files
    files = [list(_stat(p)) for p in task_files(task)]
    h = hashlib.sha256()
    root = os.path.dirname(task["input"])
    for p, _, _ in files:
        h.update(os.path.relpath(p, root).encode() + b"\0" + _sha256_file(p).encode() + b"\n")
    return h.hexdigest(), files


def _stat(p):
    st = os.stat(p)
    return p, st.st_size, st.st_mtime_ns


def decide(task, record, ihash, chash, output_root, retry_failed):
    """What to do with a task given its journal record: "skip" (finished, unchanged, outputs present),
    "failed" (failed before, unchanged, no --retry-failed) or a reason to run it."""
    if record is None:
        return "new"
    if record["input_hash"] != ihash:
        return "input changed"
    if record["config_hash"] != chash:
        return "configuration changed"
    if record["status"] == "finished":
        missing = [o for o in record["outputs"] or [] if not os.path.exists(os.path.join(output_root, o))]
        return f"output {missing[0]} missing" if missing else "skip"
    if record["status"] == "failed":
        return "retry failed" if retry_failed else "failed"
    return "interrupted"
