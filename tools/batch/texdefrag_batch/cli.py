"""texdefrag batch: defragment a whole production, resumable and fault-tolerant (docs/batch.md).

    texdefrag batch INPUT -o OUT --config C.json [--set K=V]... [-j N | --scheduler tcp://HOST:PORT]
                    [--threads N] [--allow-missing-children] [--timeout S] [--retries N] [--retry-failed] [--dry-run] [--quiet]

One task per tile file and level (`texdefrag tasks INPUT --json`); each runs `texdefrag run` on one
input into its own staging folder, and its outputs are renamed into OUT with the production's
layout. OUT/.texdefrag-batch/journal.sqlite is the single record (only this process writes it).

Exit codes: 0 every task of the production is finished; 1 some task failed (all recorded; the
others went on); 2 the batch could not start (usage, configuration, lock held by another batch,
unreadable journal, scheduler unreachable, missing input); 130 interrupted (finished tasks kept).
"""

import argparse
import os
import re
import shutil
import socket
import subprocess
import sys
import time
import uuid

from . import commit as commit_mod
from . import journal as journal_mod
from . import plan
from . import summary as summary_mod
from .executors import DaskExecutor, ExecutorError, LocalExecutor
from .progress import Progress, fmt_duration


def parse_args(argv):
    ap = argparse.ArgumentParser(prog="texdefrag batch", description=__doc__.split("\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter,
                                 epilog="Exit codes: 0 all finished, 1 some task failed, 2 could not start, "
                                        "130 interrupted. docs/batch.md has the journal, layout and cluster setup.")
    ap.add_argument("input", help="production: a folder of model files (OBJ tiles...) or one model file")
    ap.add_argument("-o", "--output", required=True, help="output folder (same layout as the input)")
    ap.add_argument("-c", "--config", required=True, help="pipeline configuration (JSON)")
    ap.add_argument("--set", action="append", default=[], metavar="K=V", help="option override (as texdefrag run)")
    ap.add_argument("--allow-missing-children", action="store_true",
                    help="process models whose child files (OSGB PagedLOD levels) are missing "
                         "(texdefrag run --allow-missing-children; listed in each run report)")
    ap.add_argument("-j", "--jobs", type=int, default=1, help="local parallel processes (default 1)")
    ap.add_argument("--threads", type=int, metavar="N",
                    help="threads inside each run (texdefrag run --threads; 0 = every core; default: every core)")
    ap.add_argument("--scheduler", help="Dask scheduler address tcp://HOST:PORT: run the tasks on its workers")
    ap.add_argument("--connect-timeout", type=float, default=20, metavar="S",
                    help="seconds to reach the scheduler and see a first worker (default 20)")
    ap.add_argument("--worker-texdefrag", metavar="PATH",
                    help="texdefrag executable on the workers (default: this one's path, on shared storage)")
    ap.add_argument("--timeout", type=float, metavar="S", help="kill an attempt after S seconds (a failed attempt)")
    ap.add_argument("--retries", type=int, default=2,
                    help="attempts after the first for a task that fails, crashes or times out (default 2)")
    ap.add_argument("--retry-failed", action="store_true", help="redo tasks recorded as failed by earlier batches")
    ap.add_argument("--dry-run", action="store_true", help="print what each task would do; run nothing")
    ap.add_argument("--quiet", "-q", action="store_true", help="no progress bar and no per-failure lines")
    ap.add_argument("--texdefrag", required=True, help=argparse.SUPPRESS)  # set by `texdefrag batch`
    ap.add_argument("--plots-dir", help=argparse.SUPPRESS)                 # eval/plots, for summary.md
    a = ap.parse_args(argv)
    if a.jobs < 1:
        ap.error(f"-j must be at least 1 (got {a.jobs})")
    if a.threads is not None and a.threads < 0:
        ap.error(f"--threads must be >= 0 (got {a.threads})")
    if a.retries < 0:
        ap.error(f"--retries must be >= 0 (got {a.retries})")
    if a.timeout is not None and a.timeout <= 0:
        ap.error(f"--timeout must be > 0 seconds (got {a.timeout:g})")
    return a


def safe(task_id):
    return re.sub(r"[^A-Za-z0-9._-]", "_", task_id.replace("/", "__"))[-120:]


def err(msg):
    print(f"texdefrag batch: {msg}", file=sys.stderr)


class Batch:
    def __init__(self, args, argv):
        self.a, self.argv = args, argv
        self.input = os.path.abspath(args.input)
        self.out = os.path.abspath(args.output)
        self.state = os.path.join(self.out, journal_mod.STATE_DIR)
        self.staging_root = os.path.join(self.state, "staging")
        self.config = os.path.abspath(args.config)
        self.label = os.path.splitext(os.path.basename(self.config))[0]
        self.exe = args.worker_texdefrag or args.texdefrag
        self.counts = {"skipped": 0, "ran": 0, "finished": 0, "failed": 0, "attempts": 0, "retried": 0}

    # -- start -------------------------------------------------------------------------------
    def check_paths(self):
        rin, rout = os.path.realpath(self.input), os.path.realpath(self.out)
        if not os.path.exists(self.input):
            raise plan.PlanError(f"{self.a.input}: no such file or folder")
        if rin == rout or (rin + os.sep).startswith(rout + os.sep):
            raise plan.PlanError(f"the output folder {self.out} must not be the input nor contain it ({self.input})")
        if not os.path.isfile(self.config):
            raise plan.PlanError(f"{self.a.config}: no such configuration file")

    def open(self):
        """Lock, journal, plan. Raises PlanError / LockError / JournalError."""
        self.check_paths()
        os.makedirs(self.state, exist_ok=True)
        self.lock = journal_mod.Lock(self.state)
        self.lock.acquire(self.argv)
        self.journal = journal_mod.Journal(os.path.join(self.state, "journal.sqlite"))
        plan.validate_config(self.a.texdefrag, self.config, self.a.set)
        self.chash = plan.config_hash(self.config, self.a.set, self.run_options())
        self.production = plan.list_tasks(self.a.texdefrag, self.input, self.out)
        self.tasks = {t["id"]: t for t in self.production["tasks"]}

    def plan(self):
        """Decides every task; returns [(task, reason, hash, files)] to run. Missing tiles are
        recorded failed here; they never reach an executor."""
        records = self.journal.tasks()
        todo = []
        for tid, t in self.tasks.items():
            rec = records.get(tid)
            if t.get("error"):  # the listing could not read it (a missing content, naming its tileset)
                self.fail_unstarted(t, t["error"])
                continue
            try:
                ihash, files = plan.input_hash(t, rec)
            except OSError as e:
                msg = str(e) if isinstance(e, FileNotFoundError) and e.args and not e.filename else \
                    f"cannot read an input of task {tid}: {e}"
                self.fail_unstarted(t, msg)
                continue
            reason = plan.decide(t, rec, ihash, self.chash, self.out, self.a.retry_failed)
            if reason == "skip":
                self.counts["skipped"] += 1
                self.counts["finished"] += 1
            elif reason == "failed":
                self.counts["failed"] += 1
            else:
                todo.append((t, reason, ihash, files))
            if self.a.dry_run:
                print(f"{tid}\t{reason}")
        return todo

    def fail_unstarted(self, t, msg):
        """A task that cannot start (its file is missing): failed with msg, never submitted."""
        self.counts["failed"] += 1
        if not self.a.dry_run:
            self.journal.fail_unstarted(t, msg)
        if not self.a.quiet or self.a.dry_run:
            err(msg)
        if self.a.dry_run:
            print(f"{t['id']}\tcannot start")

    # -- run ---------------------------------------------------------------------------------
    def run_options(self):
        """The `texdefrag run` options every task gets besides the configuration (they change what a
        run accepts or writes, so they are part of the configuration hash)."""
        return ["--allow-missing-children"] if self.a.allow_missing_children else []

    def spec(self, t):
        name = f"{self.batch_id}-{safe(t['id'])}-{uuid.uuid4().hex[:8]}"
        return {"texdefrag": self.exe, "input": t["input"], "args": list(t.get("args") or []) + self.run_options(), "config": self.config,
                "sets": list(self.a.set), "threads": self.a.threads, "staging": os.path.join(self.staging_root, name),
                "timeout_s": self.a.timeout}

    def make_executor(self):
        if self.a.scheduler:
            return DaskExecutor(self.a.scheduler, self.a.connect_timeout,
                                {"texdefrag executable": self.exe, "configuration": self.config,
                                 "output folder": self.staging_root})
        return LocalExecutor(self.a.jobs)

    def run(self, todo):
        commit_mod.clear_staging(self.staging_root)
        os.makedirs(self.staging_root, exist_ok=True)
        self.executor = self.make_executor()
        self.executor_desc = self.executor.describe()  # note: not asked again once the executor is closed
        if not self.a.quiet:
            err(f"{len(self.tasks)} task(s): {self.counts['skipped']} already finished, "
                f"{len(todo)} to run, {self.counts['failed']} failed and not retried; on {self.executor_desc}")
        capacity = self.a.jobs if not self.a.scheduler else 1 << 30
        queue = []
        for t, reason, ihash, files in todo:
            self.journal.start_task(t, ihash, self.chash, files, reset_attempts=reason != "interrupted")
            queue.append(t["id"])
        self.counts["ran"] = len(queue)
        progress = Progress(len(self.tasks), enabled=None if not self.a.quiet else False)
        ended_now, t0 = 0, time.monotonic()
        try:
            while queue or self.executor.running():
                while queue and self.executor.running() < capacity:
                    tid = queue.pop(0)
                    self.executor.submit(tid, self.spec(self.tasks[tid]))
                progress.update(self.counts["finished"], self.counts["failed"], self.executor.running(), ended_now)
                got = self.executor.next_done(timeout=0.5)
                if got is None:
                    continue
                tid, res = got
                if self.on_result(tid, res):
                    queue.append(tid)
                else:
                    ended_now += 1
                progress.update(self.counts["finished"], self.counts["failed"], self.executor.running(), ended_now,
                                force=True)
        except (KeyboardInterrupt, ExecutorError):
            progress.end()
            self.executor.close(cancel=True)
            raise
        progress.end()
        self.executor.close()
        self.wall_s = time.monotonic() - t0

    def on_result(self, tid, res):
        """Commits or records one ended attempt; True when the task goes back to the queue."""
        t = self.tasks[tid]
        self.counts["attempts"] += 1
        if res["status"] == "ok":
            try:
                outputs = commit_mod.commit(res["staging"], res["files"], self.out, t["output_dir"],
                                            t.get("stem") or os.path.splitext(os.path.basename(t["input"]))[0])
            except OSError as e:
                res = dict(res, status="failed", error=f"commit: {e}")
            else:
                old = self.journal.outputs(tid)
                self.journal.end_attempt(tid, self.batch_id, res, outputs=outputs)
                commit_mod.remove_stale(self.out, old, outputs)
                shutil.rmtree(res["staging"], ignore_errors=True)
                self.counts["finished"] += 1
                return False
        n = self.journal.attempt_count(tid) + 1
        self.keep_log(tid, res)
        if n <= self.a.retries:
            self.journal.end_attempt(tid, self.batch_id, res)
            self.counts["retried"] += 1
            return True
        error = f"{res['error']} (attempt {n} of {self.a.retries + 1}" + (f", host {res['host']})" if res.get("host") else ")")
        self.journal.end_attempt(tid, self.batch_id, res, fail_error=error)
        self.counts["failed"] += 1
        if not self.a.quiet:
            print(f"\rtexdefrag batch: task {tid} failed: {error}", file=sys.stderr)
        return False

    def keep_log(self, tid, res):
        """The standard error of a failed attempt, kept as OUT/.texdefrag-batch/logs/<task>.stderr."""
        src = os.path.join(res.get("staging") or "", "run.stderr")
        if res.get("staging") and os.path.exists(src):
            os.makedirs(os.path.join(self.state, "logs"), exist_ok=True)
            shutil.copyfile(src, os.path.join(self.state, "logs", safe(tid) + ".stderr"))
        if res.get("staging"):
            shutil.rmtree(res["staging"], ignore_errors=True)

    # -- end ---------------------------------------------------------------------------------
    def copy_through(self):
        """The production's pass-through files (copies of the task list); an error fails the batch."""
        ok = True
        for c in self.production.get("copies", []):
            try:
                if commit_mod.copy_through(c["input"], self.out, c["output"]):
                    self.counts["copied"] = self.counts.get("copied", 0) + 1
            except OSError as e:
                err(str(e))
                ok = False
        return ok

    def run_finish(self):
        """The production's last step (a tileset's JSONs and pass-through contents): `texdefrag
        FINISH... OUT`, run here once every task is finished; an error fails the batch."""
        argv = [self.a.texdefrag] + list(self.production["finish"]) + [self.out]
        p = subprocess.run(argv, capture_output=True, text=True)
        if p.returncode != 0:
            err(f"finishing the production failed (`{' '.join(argv)}`, exit code {p.returncode}): {p.stderr.strip()}")
            return False
        self.counts["finish_files"] = len(p.stdout.split())
        return True

    def finish(self, started):
        commit_mod.clear_staging(self.staging_root)
        copied = self.copy_through()
        tasks = {tid: r for tid, r in self.journal.tasks().items() if tid in self.tasks}
        finished = sum(1 for r in tasks.values() if r["status"] == "finished")
        failed = len(self.tasks) - finished
        if self.production.get("finish"):
            # note: only a complete production gets its tileset JSONs, so a partial one never
            # looks complete to a viewer.
            copied = (self.run_finish() if failed == 0 else True) and copied
        info = {"input": self.input, "output": self.out, "config": self.config, "config_hash": self.chash,
                "sets": self.a.set, "executor": getattr(self, "executor_desc", None),
                "batch_id": self.batch_id, "host": socket.gethostname(), "started_at": started,
                "wall_s": getattr(self, "wall_s", 0.0), "this_batch": dict(self.counts)}
        s, md, note = summary_mod.write_all(self.state, tasks, self.out, self.label, info, self.a.plots_dir)
        self.journal.end_batch(self.batch_id, dict(self.counts, finished_total=finished, failed_total=failed))
        if not self.a.quiet:
            if md:
                print(md)
            if note:
                err(note)
            pt = s["per_task"].get("wall_s") or {}
            err(f"{len(self.tasks)} task(s): {finished} finished ({self.counts['skipped']} already, "
                f"{self.counts['ran']} run now in {self.counts['attempts']} attempt(s)), {failed} not finished; "
                f"wall {fmt_duration(info['wall_s'])}"
                + (f", median task {pt['median']:.2f} s" if pt else "")
                + f"; summary {os.path.join(self.state, 'summary.json')}")
            for f in s["failures"][:20]:
                err(f"  failed: {f['id']}: {f['error']}")
        return 0 if failed == 0 and copied else 1


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    a = parse_args(argv)
    b = Batch(a, [x for x in argv if x != a.texdefrag])
    try:
        b.open()
    except (plan.PlanError, journal_mod.LockError, journal_mod.JournalError) as e:
        err(str(e))
        return 2
    except OSError as e:
        err(f"cannot prepare the output folder {b.out}: {e}")
        return 2
    started = time.time()
    b.batch_id = b.journal.begin_batch(argv) if not a.dry_run else 0
    todo = b.plan()
    if a.dry_run:
        return 0
    try:
        b.run(todo)
    except ExecutorError as e:
        err(str(e))
        b.journal.end_batch(b.batch_id, dict(b.counts, error=str(e)))
        return 2
    except KeyboardInterrupt:
        err("interrupted: finished tasks are recorded; run the same command again to continue")
        return 130
    return b.finish(started)
