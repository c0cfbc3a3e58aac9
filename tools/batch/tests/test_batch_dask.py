#!/usr/bin/env python3
"""`texdefrag batch --scheduler` on a real Dask cluster on 127.0.0.1 (docs/batch.md): a
dask-scheduler and two dask-worker processes (random free ports), a production of 8 tiles plus one
that always crashes; one worker is SIGKILLed in the middle. Checks: every good task ends finished
exactly once in the journal, outputs bit-identical to a local run, nothing half-written, the
crashing tile failed with its error after its retries. Label `slow` (about a minute).

Run by ctest (test_batch_dask); skips (exit 77) when Dask distributed is not installed.
"""

import os
import shutil
import signal
import socket
import subprocess
import sys
import time
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402
from common import batch, journal_rows, leftovers, model_files  # noqa: E402

PY = sys.executable


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def which(name):
    for d in ("/usr/bin", "/usr/local/bin", *os.environ.get("PATH", "").split(":")):
        if d and os.access(os.path.join(d, name), os.X_OK):
            return os.path.join(d, name)
    return None


class DaskBatchTest(unittest.TestCase):
    procs = []

    @classmethod
    def start(cls, argv, log):
        with open(log, "w") as f:
            p = subprocess.Popen(argv, stdout=f, stderr=subprocess.STDOUT, start_new_session=True)
        cls.procs.append(p)
        return p

    @classmethod
    def setUpClass(cls):
        cls.work = common.fresh_dir("dask")
        cls.prod = common.make_production(os.path.join(common.WORKDIR, "prod8"), 8, seed=11,
                                          min_faces=2000, max_faces=4000)
        port = free_port()
        cls.addr = f"tcp://127.0.0.1:{port}"
        cls.start([which("dask-scheduler"), "--host", "127.0.0.1", "--port", str(port), "--dashboard-address", ":0",
                   "--no-show"], os.path.join(cls.work, "scheduler.log"))
        # --no-nanny: a SIGKILLed worker stays dead (a nanny would restart it), one task at a time each.
        cls.workers = [cls.start([which("dask-worker"), cls.addr, "--nthreads", "1", "--no-nanny",
                                  "--host", "127.0.0.1", "--dashboard-address", ":0", "--name", f"w{i}",
                                  "--local-directory", os.path.join(cls.work, f"w{i}")],
                                 os.path.join(cls.work, f"worker{i}.log")) for i in range(2)]

    @classmethod
    def tearDownClass(cls):
        for p in cls.procs:
            if p.poll() is None:
                os.killpg(p.pid, signal.SIGTERM)
        for p in cls.procs:
            try:
                p.wait(timeout=10)
            except subprocess.TimeoutExpired:
                os.killpg(p.pid, signal.SIGKILL)
                p.wait()

    def test_worker_killed_and_crashing_tile(self):
        inp = common.copy_production(self.prod, os.path.join(self.work, "in"))
        shutil.copytree(os.path.join(inp, "b0000"), os.path.join(inp, "crashme"))
        wrapper = common.write_wrapper(os.path.join(self.work, "wrapper.sh"), common.EXE)

        # Reference: a local run of the good tiles.
        ref_in = common.copy_production(self.prod, os.path.join(self.work, "ref_in"))
        ref_out = os.path.join(self.work, "ref_out")
        p = batch(ref_in, "-o", ref_out, "--config", common.CONFIG, "-j", "2")
        self.assertEqual(p.returncode, 0, p.stderr)

        out = os.path.join(self.work, "out")
        cmd = [common.EXE, "batch", inp, "-o", out, "--config", common.CONFIG, "--scheduler", self.addr,
               "--retries", "2", "--worker-texdefrag", wrapper, "--connect-timeout", "60"]
        run = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        # Kill worker 0 once some tasks are finished and some are not.
        journal = os.path.join(out, ".texdefrag-batch", "journal.sqlite")
        killed_at = None
        deadline = time.monotonic() + 90
        while time.monotonic() < deadline and run.poll() is None:
            time.sleep(0.1)
            if not os.path.exists(journal):
                continue
            try:
                tasks, _ = journal_rows(out)
            except Exception:  # noqa: BLE001 (the journal is being created)
                continue
            done = sum(1 for t in tasks.values() if t["status"] == "finished")
            if 2 <= done <= 6:
                self.workers[0].send_signal(signal.SIGKILL)
                killed_at = done
                break
        stdout, stderr = run.communicate(timeout=120)
        self.assertIsNotNone(killed_at, "the batch ended before a worker could be killed in the middle:\n" + stderr)
        self.assertEqual(self.workers[0].wait(timeout=10), -signal.SIGKILL)
        self.assertEqual(run.returncode, 1, stderr)  # the crashing tile failed; the rest finished

        tasks, attempts = journal_rows(out)
        self.assertEqual(len(tasks), 9)
        for tid, t in tasks.items():
            finished = [a for a in attempts if a["task_id"] == tid and a["status"] == "finished"]
            if tid == "crashme/b0000":
                self.assertEqual(t["status"], "failed")
                self.assertEqual(t["attempts"], 3)
                self.assertIn("crashed with signal 11 (SIGSEGV)", t["error"])
                self.assertIn("attempt 3 of 3", t["error"])
                self.assertEqual(finished, [])
            else:
                self.assertEqual(t["status"], "finished", (tid, t))
                self.assertEqual(len(finished), 1, (tid, finished))
        # Dask's rerun of the lost worker's attempt is the same attempt (its own staging folder).
        self.assertEqual(len(attempts), 8 + 3, attempts)
        self.assertEqual(leftovers(out), [])
        got = {k: v for k, v in model_files(out).items() if not k.startswith("crashme")}
        self.assertEqual(got, model_files(ref_out))
        self.assertFalse(os.path.exists(os.path.join(out, "crashme")))
        print(f"worker 0 killed after {killed_at} finished tasks; {len(attempts)} attempts recorded", file=sys.stderr)


class DaskSchedulerLostTest(unittest.TestCase):
    """The scheduler SIGKILLed in the middle of a batch: the batch stops with an error naming the
    scheduler's address (exit 2), the journal keeps every finished task and records none as failed
    for the loss; the dead address is then unreachable (exit 2, journal unchanged); a rerun on a
    new scheduler finishes the rest without redoing a finished task, outputs as a local run's."""
    procs = []
    start = classmethod(DaskBatchTest.start.__func__)
    tearDownClass = classmethod(DaskBatchTest.tearDownClass.__func__)

    @classmethod
    def cluster(cls, name, workers):
        port = free_port()
        addr = f"tcp://127.0.0.1:{port}"
        sched = cls.start([which("dask-scheduler"), "--host", "127.0.0.1", "--port", str(port), "--dashboard-address",
                           ":0", "--no-show"], os.path.join(cls.work, f"{name}-scheduler.log"))
        for i in range(workers):
            cls.start([which("dask-worker"), addr, "--nthreads", "1", "--no-nanny", "--host", "127.0.0.1",
                       "--dashboard-address", ":0", "--name", f"{name}-w{i}",
                       "--local-directory", os.path.join(cls.work, f"{name}-w{i}")],
                      os.path.join(cls.work, f"{name}-worker{i}.log"))
        return addr, sched

    @classmethod
    def setUpClass(cls):
        cls.work = common.fresh_dir("dask_lost")
        cls.prod = common.make_production(os.path.join(common.WORKDIR, "prod8_lost"), 8, seed=11,
                                          min_faces=2000, max_faces=4000)

    def test_scheduler_lost_mid_batch(self):
        inp = common.copy_production(self.prod, os.path.join(self.work, "in"))
        ref_in = common.copy_production(self.prod, os.path.join(self.work, "ref_in"))
        ref_out = os.path.join(self.work, "ref_out")
        p = batch(ref_in, "-o", ref_out, "--config", common.CONFIG, "-j", "2")
        self.assertEqual(p.returncode, 0, p.stderr)

        addr, sched = self.cluster("first", 2)
        out = os.path.join(self.work, "out")
        cmd = [common.EXE, "batch", inp, "-o", out, "--config", common.CONFIG, "--scheduler", addr,
               "--connect-timeout", "60"]
        run = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        journal = os.path.join(out, ".texdefrag-batch", "journal.sqlite")
        killed_at, deadline = None, time.monotonic() + 120
        while time.monotonic() < deadline and run.poll() is None:
            time.sleep(0.1)
            if not os.path.exists(journal):
                continue
            try:
                tasks, _ = journal_rows(out)
            except Exception:  # noqa: BLE001 (the journal is being created)
                continue
            done = sum(1 for t in tasks.values() if t["status"] == "finished")
            if 2 <= done <= 5:
                sched.send_signal(signal.SIGKILL)
                killed_at = done
                break
        stdout, stderr = run.communicate(timeout=240)
        self.assertIsNotNone(killed_at, "the batch ended before the scheduler could be killed:\n" + stderr)
        self.assertEqual(run.returncode, 2, stderr)
        self.assertIn(f"lost the Dask scheduler at {addr}", stderr)
        tasks, attempts = journal_rows(out)
        finished = {tid for tid, t in tasks.items() if t["status"] == "finished"}
        self.assertGreaterEqual(len(finished), killed_at)
        self.assertLess(len(finished), 8, "every task finished: the loss came too late to test anything")
        self.assertEqual([t for t in tasks.values() if t["status"] == "failed"], [], "a task failed for the loss")
        for tid in finished:
            for o in tasks[tid]["outputs"]:
                self.assertTrue(os.path.isfile(os.path.join(out, o)), o)
        n_attempts = len(attempts)

        # The dead address: unreachable, a clear error, the journal unchanged.
        p = batch(inp, "-o", out, "--config", common.CONFIG, "--scheduler", addr, "--connect-timeout", "3")
        self.assertEqual(p.returncode, 2, p.stderr)
        self.assertIn(f"cannot reach the Dask scheduler at {addr}", p.stderr)
        self.assertEqual(journal_rows(out), (tasks, attempts))

        # A new scheduler finishes the rest; the finished tasks are not redone.
        addr2, _ = self.cluster("second", 1)
        p = batch(inp, "-o", out, "--config", common.CONFIG, "--scheduler", addr2, "--connect-timeout", "60")
        self.assertEqual(p.returncode, 0, p.stderr)
        tasks2, attempts2 = journal_rows(out)
        self.assertTrue(all(t["status"] == "finished" for t in tasks2.values()), tasks2)
        self.assertEqual(attempts2[:n_attempts], attempts)
        redone = [a["task_id"] for a in attempts2[n_attempts:]]
        self.assertEqual(sorted(redone), sorted(set(tasks2) - finished), "a finished task ran again")
        self.assertEqual(leftovers(out), [])
        self.assertEqual(model_files(out), model_files(ref_out))
        print(f"scheduler killed after {killed_at} finished tasks; {len(finished)} kept, {len(redone)} redone "
              "on a new scheduler", file=sys.stderr)


if __name__ == "__main__":
    try:
        import distributed  # noqa: F401
    except ImportError:
        print("test_batch_dask: skipped, Dask distributed is not installed for", PY)
        sys.exit(77)
    if not (which("dask-scheduler") and which("dask-worker")):
        print("test_batch_dask: skipped, dask-scheduler / dask-worker not found")
        sys.exit(77)
    unittest.main(verbosity=2)
