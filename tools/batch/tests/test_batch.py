#!/usr/bin/env python3
"""`texdefrag batch` on one machine with the real engine (docs/batch.md): layout, journal, resume,
changed inputs, failing / crashing / hanging tiles, lock, unreadable journal, missing files,
unreachable scheduler, and `texdefrag tasks`.

Run by ctest (test_batch): TEXDEFRAG_EXE, TEXDEFRAG_SOURCE_DIR and TEXDEFRAG_TEST_WORKDIR are set.
"""

import fcntl
import json
import os
import shutil
import socket
import subprocess
import sys
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402
from common import batch, journal_rows, leftovers, model_files  # noqa: E402


def read_json(out, name):
    with open(os.path.join(out, ".texdefrag-batch", name)) as f:
        return json.load(f)


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class BatchTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.work = os.path.join(common.WORKDIR, "local")
        os.makedirs(cls.work, exist_ok=True)
        cls.prod = common.make_production(os.path.join(common.WORKDIR, "prod4"), 4, seed=3, min_faces=1000, max_faces=1200)

    def fresh(self, name):
        d = common.fresh_dir("local", name)
        return os.path.join(d, "in"), os.path.join(d, "out")

    def test_tasks_command(self):
        inp, _ = self.fresh("tasks")
        common.copy_production(self.prod, inp)
        os.makedirs(os.path.join(inp, ".hidden"))
        shutil.copy(os.path.join(inp, "b0000", "b0000.obj"), os.path.join(inp, ".hidden", "x.obj"))
        p = subprocess.run([common.EXE, "tasks", inp, "--json", "--exclude", os.path.join(inp, "b0003")],
                           capture_output=True, text=True, check=True)
        t = json.loads(p.stdout)
        self.assertEqual(t["kind"], "folder")
        self.assertEqual([x["id"] for x in t["tasks"]], [f"b000{i}/b000{i}" for i in range(3)])
        self.assertEqual(t["tasks"][0]["output_dir"], "b0000")
        self.assertEqual(t["tasks"][0]["input"], os.path.join(inp, "b0000", "b0000.obj"))
        # ContextCapture naming: the level from the file name; a root metadata.xml passes through.
        prod = os.path.join(self.work, "tasks", "cc")
        os.makedirs(os.path.join(prod, "Tile_+000_+001"))
        for f in os.listdir(os.path.join(inp, "b0000")):
            dst = "Tile_+000_+001_L17_0.obj" if f.endswith(".obj") else f
            shutil.copy(os.path.join(inp, "b0000", f), os.path.join(prod, "Tile_+000_+001", dst))
        with open(os.path.join(prod, "metadata.xml"), "w") as f:
            f.write("<ModelMetadata version=\"1\"><SRS>EPSG:4326</SRS></ModelMetadata>\n")
        t = json.loads(subprocess.run([common.EXE, "tasks", prod, "--json"], capture_output=True, text=True,
                                      check=True).stdout)
        self.assertEqual([(x["id"], x["level"], x["tile"]) for x in t["tasks"]],
                         [("Tile_+000_+001/Tile_+000_+001_L17_0", 17, "Tile_+000_+001")])
        self.assertEqual(t["copies"], [{"input": os.path.join(prod, "metadata.xml"), "output": "metadata.xml"}])
        out = os.path.join(self.work, "tasks", "cc_out")
        p = batch(prod, "-o", out, "--config", common.CONFIG)
        self.assertEqual(p.returncode, 0, p.stderr)
        with open(os.path.join(out, "metadata.xml")) as f:
            self.assertIn("EPSG:4326", f.read())
        self.assertTrue(os.path.isfile(os.path.join(out, "Tile_+000_+001", "Tile_+000_+001_L17_0.obj")))

        p = subprocess.run([common.EXE, "tasks", os.path.join(inp, "nope")], capture_output=True, text=True)
        self.assertEqual(p.returncode, 1)
        self.assertIn("nope: no such file or folder", p.stderr)

    def test_run_resume_change(self):
        inp, out = self.fresh("resume")
        common.copy_production(self.prod, inp)
        before = model_files(inp)
        p = batch(inp, "-o", out, "--config", common.CONFIG, "-j", "2")
        self.assertEqual(p.returncode, 0, p.stderr)
        tasks, attempts = journal_rows(out)
        self.assertEqual(len(tasks), 4)
        self.assertTrue(all(t["status"] == "finished" and t["attempts"] == 1 for t in tasks.values()), tasks)
        self.assertEqual(sorted(a["task_id"] for a in attempts if a["status"] == "finished"), sorted(tasks))
        # Same layout as the input: OUT/bNNNN/bNNNN.obj + .mtl + pages + report.
        for tid, t in tasks.items():
            self.assertIn(f"{tid}.obj", t["outputs"])
            self.assertEqual(t["outputs"][-1], f"{tid}.report.json")  # committed last
            for o in t["outputs"]:
                self.assertTrue(os.path.isfile(os.path.join(out, o)), o)
        self.assertEqual(leftovers(out), [])
        self.assertEqual(model_files(inp), before, "an input file changed")
        for f in ("summary.json", "results.csv", "summary.md"):
            self.assertTrue(os.path.isfile(os.path.join(out, ".texdefrag-batch", f)), f)
        self.assertEqual(read_json(out, "summary.json")["tasks"], {"total": 4, "finished": 4, "failed": 0})
        with open(os.path.join(out, ".texdefrag-batch", "summary.md")) as f:
            self.assertIn("chart count reduction", f.read())
        first = model_files(out)

        # A rerun skips everything.
        p = batch(inp, "-o", out, "--config", common.CONFIG)
        self.assertEqual(p.returncode, 0, p.stderr)
        self.assertEqual(len(journal_rows(out)[1]), 4, "a finished task ran again")

        # A changed page, a removed output and a changed configuration are each seen.
        page = sorted(f for f in os.listdir(os.path.join(inp, "b0002")) if f.endswith(".jpg"))[0]
        with open(os.path.join(inp, "b0002", page), "ab") as f:
            f.write(b"\0")
        os.remove(os.path.join(out, "b0003", "b0003.mtl"))
        p = batch(inp, "-o", out, "--config", common.CONFIG, "--dry-run")
        self.assertEqual(p.returncode, 0, p.stderr)
        decisions = dict(line.split("\t") for line in p.stdout.splitlines())
        self.assertEqual(decisions["b0002/b0002"], "input changed")
        self.assertEqual(decisions["b0003/b0003"], "output b0003/b0003.mtl missing")
        self.assertEqual(decisions["b0000/b0000"], "skip")
        p = batch(inp, "-o", out, "--config", common.CONFIG, "--dry-run", "--set", "packer.gutter=3")
        decisions = dict(line.split("\t") for line in p.stdout.splitlines())
        self.assertEqual(decisions.pop("b0002/b0002"), "input changed")
        self.assertEqual(set(decisions.values()), {"configuration changed"})
        p = batch(inp, "-o", out, "--config", common.CONFIG)
        self.assertEqual(p.returncode, 0, p.stderr)
        _, attempts = journal_rows(out)
        self.assertEqual(sorted(a["task_id"] for a in attempts[4:]), ["b0002/b0002", "b0003/b0003"])
        again = model_files(out)
        self.assertEqual({k: v for k, v in again.items() if not k.startswith("b0002")},
                         {k: v for k, v in first.items() if not k.startswith("b0002")})

    def test_failures_and_retries(self):
        inp, out = self.fresh("fail")
        common.copy_production(self.prod, inp)
        # A malformed tile (the real reader's error), a tile whose page is missing, a crashing tile
        # (the wrapper executable), and good ones.
        with open(os.path.join(inp, "b0001", "b0001.obj"), "a") as f:
            f.write("f 1 2 banana\n")
        for x in os.listdir(os.path.join(inp, "b0003")):
            if x.endswith(".jpg"):
                os.remove(os.path.join(inp, "b0003", x))
                break
        os.rename(os.path.join(inp, "b0002"), os.path.join(inp, "crashme"))
        wrapper = common.write_wrapper(os.path.join(self.work, "fail", "wrapper.sh"), common.EXE)
        p = batch(inp, "-o", out, "--config", common.CONFIG, "-j", "2", "--retries", "1",
                  "--worker-texdefrag", wrapper)
        self.assertEqual(p.returncode, 1, p.stderr)
        tasks, attempts = journal_rows(out)
        self.assertEqual(tasks["b0000/b0000"]["status"], "finished")
        for tid in ("b0001/b0001", "b0003/b0003", "crashme/b0002"):
            self.assertEqual(tasks[tid]["status"], "failed", tid)
            self.assertEqual(tasks[tid]["attempts"], 2, tid)
            self.assertEqual([a["status"] for a in attempts if a["task_id"] == tid].count("finished"), 0)
        self.assertIn("b0001.obj:", tasks["b0001/b0001"]["error"])
        self.assertIn("banana", tasks["b0001/b0001"]["error"])
        self.assertIn(".jpg", tasks["b0003/b0003"]["error"])
        self.assertIn("crashed with signal 11 (SIGSEGV)", tasks["crashme/b0002"]["error"])
        self.assertIn("attempt 2 of 2", tasks["crashme/b0002"]["error"])
        self.assertIn("task crashme/b0002 failed", p.stderr)
        self.assertEqual(leftovers(out), [])
        self.assertFalse(os.path.exists(os.path.join(out, "b0001", "b0001.obj")))
        self.assertTrue(os.path.isfile(os.path.join(out, ".texdefrag-batch", "logs", "b0001__b0001.stderr")))
        self.assertEqual(read_json(out, "summary.json")["tasks"], {"total": 4, "finished": 1, "failed": 3})

        # Failed tasks are not retried without --retry-failed; a fixed tile is redone (input changed).
        n = len(attempts)
        p = batch(inp, "-o", out, "--config", common.CONFIG, "--worker-texdefrag", wrapper)
        self.assertEqual(p.returncode, 1)
        self.assertEqual(len(journal_rows(out)[1]), n)
        shutil.copy(os.path.join(self.prod, "b0001", "b0001.obj"), os.path.join(inp, "b0001", "b0001.obj"))
        p = batch(inp, "-o", out, "--config", common.CONFIG, "--worker-texdefrag", wrapper, "--retries", "0")
        self.assertEqual(p.returncode, 1)
        tasks, attempts = journal_rows(out)
        self.assertEqual(tasks["b0001/b0001"]["status"], "finished")
        self.assertEqual(len(attempts), n + 1)
        # --retry-failed redoes the failed ones (they fail again, one attempt each with --retries 0).
        p = batch(inp, "-o", out, "--config", common.CONFIG, "--worker-texdefrag", wrapper, "--retries", "0",
                  "--retry-failed")
        self.assertEqual(p.returncode, 1)
        tasks, attempts = journal_rows(out)
        self.assertEqual(len(attempts), n + 3)
        self.assertEqual(tasks["crashme/b0002"]["attempts"], 1)

    def test_timeout(self):
        # A hanging tile alone (a timeout long enough for a real run would slow the whole test).
        inp, out = self.fresh("timeout")
        shutil.copytree(os.path.join(self.prod, "b0000"), os.path.join(inp, "slowme"))
        wrapper = common.write_wrapper(os.path.join(self.work, "timeout", "wrapper.sh"), common.EXE)
        p = batch(inp, "-o", out, "--config", common.CONFIG, "--retries", "1", "--timeout", "2",
                  "--worker-texdefrag", wrapper)
        self.assertEqual(p.returncode, 1, p.stderr)
        tasks, attempts = journal_rows(out)
        self.assertEqual(tasks["slowme/b0000"]["status"], "failed")
        self.assertIn("timed out after 2 s (killed) (attempt 2 of 2", tasks["slowme/b0000"]["error"])
        self.assertEqual([a["status"] for a in attempts], ["timeout", "timeout"])
        self.assertEqual(leftovers(out), [])

    def test_lock_journal_scheduler_errors(self):
        inp, out = self.fresh("errors")
        common.copy_production(self.prod, inp)
        shutil.rmtree(os.path.join(inp, "b0002"))
        shutil.rmtree(os.path.join(inp, "b0003"))
        self.assertEqual(batch(inp, "-o", out, "--config", common.CONFIG).returncode, 0)
        outputs = model_files(out)

        # Another batch holds the folder.
        state = os.path.join(out, ".texdefrag-batch")
        fd = os.open(os.path.join(state, "lock"), os.O_RDWR)
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        os.ftruncate(fd, 0)
        os.write(fd, b'{"host": "elsewhere", "pid": 4242}\n')
        try:
            p = batch(inp, "-o", out, "--config", common.CONFIG)
        finally:
            os.close(fd)
        self.assertEqual(p.returncode, 2)
        self.assertIn("another batch is running on this output folder", p.stderr)
        self.assertIn(os.path.join(state, "lock"), p.stderr)
        self.assertIn('"pid": 4242', p.stderr)

        # A scheduler nobody listens on: clear error, the journal keeps every finished task.
        addr = f"tcp://127.0.0.1:{free_port()}"
        p = batch(inp, "-o", out, "--config", common.CONFIG, "--scheduler", addr, "--connect-timeout", "2",
                  "--retry-failed")
        self.assertEqual(p.returncode, 2, p.stderr)
        self.assertIn(f"cannot reach the Dask scheduler at {addr}", p.stderr)
        tasks, _ = journal_rows(out)
        self.assertTrue(all(t["status"] == "finished" for t in tasks.values()))

        # An unreadable journal: named, left as it is, nothing else touched.
        path = os.path.join(state, "journal.sqlite")
        os.rename(path, path + ".good")
        with open(path, "wb") as f:
            f.write(b"this is not a journal" * 100)
        p = batch(inp, "-o", out, "--config", common.CONFIG)
        self.assertEqual(p.returncode, 2)
        self.assertIn(f"{path}: unreadable journal", p.stderr)
        with open(path, "rb") as f:
            self.assertEqual(f.read(), b"this is not a journal" * 100)
        self.assertEqual(model_files(out), outputs)
        os.replace(path + ".good", path)

        # Missing input, output inside-out, a bad configuration: exit 2 before anything runs.
        p = batch(os.path.join(inp, "nope"), "-o", out, "--config", common.CONFIG)
        self.assertEqual(p.returncode, 2)
        self.assertIn("nope: no such file or folder", p.stderr)
        p = batch(inp, "-o", inp, "--config", common.CONFIG)
        self.assertEqual(p.returncode, 2)
        self.assertIn("must not be the input nor contain it", p.stderr)
        p = batch(inp, "-o", out, "--config", common.CONFIG, "--set", "packer.guttr=3")
        self.assertEqual(p.returncode, 2)
        self.assertIn("did you mean 'gutter'", p.stderr)
        self.assertEqual(model_files(out), outputs)

    def test_missing_tile_file_at_planning(self):
        sys.path.insert(0, os.path.join(common.SOURCE, "tools", "batch"))
        from texdefrag_batch import plan
        with self.assertRaises(FileNotFoundError) as cm:
            plan.input_hash({"id": "t/x", "input": "/nonexistent/t/x.obj"}, None)
        self.assertIn("tile file /nonexistent/t/x.obj (task t/x) is missing", str(cm.exception))


if __name__ == "__main__":
    unittest.main(verbosity=2)
