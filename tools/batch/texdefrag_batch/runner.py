"""One attempt of one task, run where the work happens (this process or a Dask worker).

Standard library only: the Dask executor ships this module to the workers by value
(cloudpickle.register_pickle_by_value), so a worker needs the texdefrag executable and the shared
storage, not this package.

An attempt runs `texdefrag run INPUT --config C [--set K=V]... -o STAGING/out --quiet --report` in a
child process and writes nothing outside its own staging folder STAGING (unique per attempt, so an
attempt orphaned by a lost worker can never touch another attempt's files). The client moves the
outputs into place (commit.py); the worker never writes the journal nor a final output name.
"""

import ctypes
import json
import os
import shutil
import signal
import socket
import threading
import time

PR_SET_PDEATHSIG = 1


def _run_env():
    """The environment of a `texdefrag run`: this worker's, with glibc's malloc asked for huge pages
    (`glibc.malloc.hugetlb=1`), which `texdefrag run` otherwise restarts itself once to get
    (cli/huge_pages.cpp: about 0.05 CPU s per task, a tenth of a small tile); unchanged when the
    user set that tunable or TEXDEFRAG_HUGE_PAGES=0."""
    env = dict(os.environ)
    tunables = env.get("GLIBC_TUNABLES", "")
    if env.get("TEXDEFRAG_HUGE_PAGES") != "0" and "glibc.malloc.hugetlb" not in tunables:
        env["GLIBC_TUNABLES"] = (tunables + ":" if tunables else "") + "glibc.malloc.hugetlb=1"
    return env


def _die_with_parent_fn():
    """A preexec function for the child: SIGKILL it when the thread that started it dies (a worker
    killed with SIGKILL must not leave its texdefrag runs behind). That thread blocks in wait4 until
    the child ends, so it cannot end first by itself. prctl is looked up here, before the fork."""
    try:
        prctl = ctypes.CDLL(None, use_errno=True).prctl
    except (OSError, AttributeError):
        return None
    return lambda: prctl(PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)


def _tail(path, limit=2000):
    try:
        with open(path, "rb") as f:
            f.seek(0, os.SEEK_END)
            size = f.tell()
            f.seek(max(0, size - limit))
            return f.read().decode("utf-8", "replace").strip()
    except OSError:
        return ""


def _report_figures(report):
    """The figures of a run report (docs/framework.md) kept in the journal."""
    out = {}
    ins, outs = report.get("input_stats") or {}, report.get("output_stats") or {}
    charts_in = (ins.get("charts") or {}).get("charts") if isinstance(ins.get("charts"), dict) else ins.get("charts")
    out["faces"] = ins.get("faces")
    out["charts_in"] = charts_in
    out["charts_out"] = outs.get("charts")
    out["mp_in"] = ins.get("megapixels")
    out["mp_out"] = outs.get("megapixels")
    out["time_s"] = report.get("total_time_s")
    return out


def run_attempt(spec):
    """Runs one attempt; never raises for a failing run (the result says what happened).

    spec (dict): texdefrag (executable path), input (file), config (file), sets (list of K=V),
      staging (absolute path prefix: this execution writes into STAGING.<random>/, created here),
      timeout_s (float or None).
    Returns a dict: status ("ok", "failed", "timeout", "crashed", "unreachable"), error (text or
      None), exit_code, signal, wall_s, cpu_s (child user + system), max_rss_kb, host, started_at,
      finished_at, files (names in STAGING/out when ok), figures (run report figures when ok).
    """
    t0 = time.time()
    # Each execution gets its own folder: Dask reruns an attempt whose worker was lost, and the
    # lost execution's folder (maybe still being written by an orphan) must not be reused.
    staging = f"{spec['staging']}.{os.urandom(4).hex()}"
    res = {"host": socket.gethostname(), "started_at": t0, "exit_code": None, "signal": None,
           "max_rss_kb": None, "cpu_s": None, "files": [], "figures": {}, "error": None,
           "staging": staging}

    def done(status, error=None):
        res["status"], res["error"] = status, error
        res["finished_at"] = time.time()
        res["wall_s"] = res["finished_at"] - t0
        return res

    for what, path in (("input file", spec["input"]), ("texdefrag executable", spec["texdefrag"]),
                       ("configuration", spec["config"])):
        if not os.path.exists(path):
            return done("unreachable", f"{what} {path} is missing on host {res['host']}"
                        + (" (shared storage not mounted at the same path?)" if what != "input file" else ""))
    out_dir = os.path.join(staging, "out")
    try:
        os.makedirs(out_dir)
    except OSError as e:
        return done("unreachable", f"cannot create the staging folder {out_dir} on host {res['host']}: {e.strerror}")
    argv = [spec["texdefrag"], "run", spec["input"]] + list(spec.get("args") or []) + \
        ["--config", spec["config"], "-o", out_dir, "--quiet", "--report"]
    for s in spec.get("sets") or []:
        argv += ["--set", s]
    if spec.get("threads") is not None:
        argv += ["--threads", str(spec["threads"])]
    stdout_path, stderr_path = os.path.join(staging, "run.stdout"), os.path.join(staging, "run.stderr")
    with open(stdout_path, "wb") as so, open(stderr_path, "wb") as se:
        import subprocess  # noqa: PLC0415 (kept local: the module is shipped by value)
        try:
            proc = subprocess.Popen(argv, stdout=so, stderr=se, stdin=subprocess.DEVNULL, env=_run_env(),
                                    preexec_fn=_die_with_parent_fn(), close_fds=True)
        except OSError as e:
            return done("failed", f"cannot start {spec['texdefrag']}: {e.strerror}")
    timed_out = threading.Event()

    def kill():
        timed_out.set()
        try:
            os.kill(proc.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass

    timer = None
    if spec.get("timeout_s"):
        timer = threading.Timer(spec["timeout_s"], kill)
        timer.daemon = True
        timer.start()
    try:
        _, status, rusage = os.wait4(proc.pid, 0)
    finally:
        if timer:
            timer.cancel()
    proc.returncode = 0  # reaped by wait4; keep Popen from waiting again
    res["max_rss_kb"] = rusage.ru_maxrss
    res["cpu_s"] = rusage.ru_utime + rusage.ru_stime
    err_tail = _tail(stderr_path)
    if os.WIFSIGNALED(status):
        sig = os.WTERMSIG(status)
        res["signal"] = sig
        if timed_out.is_set():
            return done("timeout", f"timed out after {spec['timeout_s']:g} s (killed)" + (f": {err_tail}" if err_tail else ""))
        name = signal.Signals(sig).name if sig in signal.Signals._value2member_map_ else str(sig)
        return done("crashed", f"crashed with signal {sig} ({name})" + (f": {err_tail}" if err_tail else ""))
    res["exit_code"] = os.WEXITSTATUS(status)
    if res["exit_code"] != 0:
        return done("failed", f"exit code {res['exit_code']}" + (f": {err_tail}" if err_tail else ""))
    try:
        with open(stdout_path) as f:
            res["figures"] = _report_figures(json.load(f))
    except (OSError, ValueError) as e:
        return done("failed", f"exit code 0 but no readable run report on standard output ({e})")
    res["files"] = output_files(out_dir)
    if not res["files"]:
        return done("failed", "exit code 0 but no output file")
    return done("ok")


def output_files(out_dir):
    """The files a run wrote, as '/'-separated paths relative to out_dir, sorted; hidden names (the
    run's own lock and staging, `.texdefrag*`) are not outputs."""
    files = []
    for root, dirs, names in os.walk(out_dir):
        dirs[:] = sorted(d for d in dirs if not d.startswith("."))
        rel = os.path.relpath(root, out_dir)
        files += [n if rel == "." else f"{rel}/{n}" for n in names if not n.startswith(".")]
    return sorted(files)


def probe(paths):
    """Worker check before a Dask batch: which of `paths` (name -> path) are missing here."""
    missing = {k: p for k, p in paths.items() if not os.path.exists(p)}
    return {"host": socket.gethostname(), "missing": missing}


def discard(staging):
    """Removes an attempt's staging folder (ignoring errors: an orphan may still write into it)."""
    shutil.rmtree(staging, ignore_errors=True)
