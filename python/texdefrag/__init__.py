"""texdefrag: texture defragmentation of photogrammetric 3D building models (docs/python.md).

    import texdefrag
    texdefrag.configs()                                   # shipped configurations
    r = texdefrag.run("model.obj", "out", config="best", overrides={"merger.max_distortion": 0.02})
    r.report["output_stats"]["charts"]                    # the run report, as a dict
    r.model["uvs"], r.model["pages"][0]                   # the output as numpy arrays
    texdefrag.run_arrays(positions, faces, uvs, pages, face_uvs=..., config="repack")
    texdefrag.eval("model.obj", "out/model.obj")           # metrics of a pair (docs/eval.md)
    texdefrag.stages(); texdefrag.describe("packers.shelf")

Errors are exceptions carrying the command line's messages: ConfigError ("packer.gutter: ..."),
ModelError ("FILE:LINE: ..."), ImageError, StageError, PluginError; bad arrays raise ValueError
naming the argument and row.
"""
import json as _json
import os as _os
import tempfile as _tempfile
from dataclasses import dataclass as _dataclass

from . import _texdefrag as _t

ConfigError = _t.ConfigError
ConfigNotFound = _t.ConfigNotFound
PluginError = _t.PluginError
ModelError = _t.ModelError
ImageError = _t.ImageError
StageError = _t.StageError

__version__ = _t.version()
__all__ = ["configs", "config", "stages", "describe", "run", "run_arrays", "eval", "RunResult", "set_threads", "threads",
           "ConfigError", "ConfigNotFound", "PluginError", "ModelError", "ImageError", "StageError"]

DEFAULT_CONFIG = "best"


def set_threads(n):
    """Threads inside every later run of this process, like `texdefrag run --threads N` (0 = every
    core, the default). The output files do not depend on it (docs/framework.md, "Threads")."""
    if not isinstance(n, int) or isinstance(n, bool) or n < 0:
        raise ValueError(f"threads must be an integer >= 0 (0 = every core), got {n!r}")
    _t.set_threads(n)


def threads():
    """Threads runs use now (>= 1)."""
    return _t.threads()


def configs():
    """Names of the shipped configurations ("best", "paper", "ablations/arap", ...)."""
    return list(_t.configs())


def _overrides(overrides):
    """{"merger.max_distortion": 0.02} or ["merger.max_distortion=0.02"] -> CLI --set strings."""
    if overrides is None:
        return []
    if isinstance(overrides, dict):
        return ["%s=%s" % (k, _json.dumps(v)) for k, v in overrides.items()]
    if isinstance(overrides, str):
        return [overrides]
    return [str(o) for o in overrides]


def _config_args(config):
    if isinstance(config, dict):
        return "", _json.dumps(config)
    if isinstance(config, (str, _os.PathLike)):
        return _os.fspath(config), ""
    raise TypeError("config: a shipped name, a file path or a dict, not %s" % type(config).__name__)


def config(config=DEFAULT_CONFIG, overrides=None):
    """The validated configuration with overrides and defaults filled in (dict)."""
    name, text = _config_args(config)
    return _json.loads(_t.config_json(name, text, _overrides(overrides)))


def stages():
    """Every stage and the framework's configurable steps, with their options (list of dicts)."""
    return _json.loads(_t.stages_json())


def describe(name):
    """One stage's declaration: description, doc, module file and options."""
    for s in stages():
        if s["name"] == name:
            return s
    raise KeyError("unknown stage '%s' (texdefrag.stages() lists them)" % name)


@_dataclass
class RunResult:
    report: dict        #: the run report (OUTDIR/<stem>.report.json)
    output: str         #: the output OBJ, "" when nothing was written
    model: dict = None  #: the output as arrays (run(..., arrays=True) and run_arrays)


def run(input, output_dir=None, config=DEFAULT_CONFIG, overrides=None, arrays=False, write=True):
    """Runs a configuration on an OBJ file, like `texdefrag run`.

    output_dir: the output folder (created; never the input's folder). None with write=True: a
    temporary folder, removed after the arrays are read (use arrays=True to keep the result).
    arrays: also read the output back as numpy arrays (RunResult.model).
    write: False runs the stages and returns the report only (`--no-write`)."""
    name, text = _config_args(config)
    sets = _overrides(overrides)
    input = _os.fspath(input)
    if not write:
        return RunResult(_json.loads(_t.run_json(name, text, sets, input, "", False)), "")
    tmp = None
    if output_dir is None:
        tmp = _tempfile.TemporaryDirectory(prefix="texdefrag-")
        output_dir = _os.path.join(tmp.name, "out")
    try:
        report = _json.loads(_t.run_json(name, text, sets, input, _os.fspath(output_dir), True))
        stem = report.get("config", {}).get("output", {}).get("name") or _os.path.splitext(_os.path.basename(input))[0]
        out = _os.path.join(_os.fspath(output_dir), stem + ".obj")
        model = _t.read_model(out, True) if (arrays or tmp) else None
        return RunResult(report, "" if tmp else out, model)
    finally:
        if tmp:
            tmp.cleanup()


def run_arrays(positions, faces, uvs, pages, face_uvs=None, face_pages=None, config=DEFAULT_CONFIG,
               overrides=None):
    """Runs a configuration on a model given as numpy arrays; returns RunResult with .model.

    positions (N,3) float; faces (F,3) int into positions; uvs (T,2) float, (u, v) with v up as in
    OBJ; face_uvs (F,3) int into uvs (default: faces, i.e. one uv per position); face_pages (F,)
    int page per face, -1 = untextured (default: all 0); pages: list of uint8 images (H,W[,C]),
    row 0 at the top. The model goes through a temporary OBJ/MTL/PNG folder, so array runs are file
    runs (same checks and messages). Output .model has the same keys; output faces keep the input
    order and positions."""
    import numpy as np
    faces = np.asarray(faces)
    if face_uvs is None:
        face_uvs = faces
    if face_pages is None:
        face_pages = np.zeros(len(faces), dtype=np.int64)
    with _tempfile.TemporaryDirectory(prefix="texdefrag-") as tmp:
        src = _os.path.join(tmp, "in")
        _os.mkdir(src)
        obj = _t.write_model(src, "model", positions, faces, uvs, face_uvs, face_pages, list(pages))
        return run(obj, None, config=config, overrides=overrides)


def eval(input, output, texture=True, samples=0):
    """Metrics of an input model and any tool's output (`texdefrag eval --json`), as a dict."""
    return _json.loads(_t.eval_json(_os.fspath(input), _os.fspath(output), bool(texture), int(samples)))
