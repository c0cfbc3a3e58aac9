#!/usr/bin/env python3
"""`texdefrag batch`'s progress line (docs/batch.md): counts and an ETA on a terminal, nothing when
standard error is not a terminal or with --quiet. Unit checks of the Progress class, then the real
`texdefrag batch` on two synthetic tiles run once on a pseudo-terminal and once on a pipe.

Run by ctest (test_batch_progress)."""

import io
import os
import pty
import re
import select
import subprocess
import sys
import time
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
import common  # noqa: E402
from texdefrag_batch.progress import Progress, fmt_duration  # noqa: E402


class TtyStream(io.StringIO):
    def isatty(self):
        return True


class ProgressUnitTest(unittest.TestCase):
    def test_durations(self):
        self.assertEqual(fmt_duration(None), "?")
        self.assertEqual(fmt_duration(59.4), "59s")
        self.assertEqual(fmt_duration(61), "1m01s")
        self.assertEqual(fmt_duration(3600 + 120), "1h02m")

    def test_line_has_counts_and_eta(self):
        s = TtyStream()
        p = Progress(10, stream=s)
        p.t0 = time.monotonic() - 20  # 20 s elapsed, 4 tasks ended: 5 s per task, 6 left: 30 s
        p.update(finished=3, failed=1, running=2, ended_now=4, force=True)
        line = s.getvalue()
        self.assertTrue(line.startswith("\r["), line)
        self.assertIn("4/10 (3 finished, 1 failed, 2 running)", line)
        self.assertIn("elapsed 20s", line)
        eta = re.search(r"ETA (\d+)s", line)
        self.assertIsNotNone(eta, line)
        self.assertIn(int(eta.group(1)), (29, 30, 31))
        self.assertEqual(line.count("#"), 12)  # 4 of 10 of a 30-character bar

    def test_no_eta_before_the_first_task_ends(self):
        s = TtyStream()
        Progress(5, stream=s).update(0, 0, 2, 0, force=True)
        self.assertIn("ETA ?", s.getvalue())

    def test_silent_when_not_a_terminal(self):
        s = io.StringIO()
        p = Progress(3, stream=s)
        p.update(1, 0, 1, 1, force=True)
        p.end()
        self.assertEqual(s.getvalue(), "")


def read_all(fd, proc, timeout=240):
    """Everything written to a pty master until the child exits (and the pty is drained)."""
    out, deadline = b"", time.monotonic() + timeout
    while time.monotonic() < deadline:
        r, _, _ = select.select([fd], [], [], 0.2)
        if r:
            try:
                chunk = os.read(fd, 65536)
            except OSError:  # EIO: the child side is closed
                break
            if not chunk:
                break
            out += chunk
        elif proc.poll() is not None:
            break
    return out.decode("utf-8", "replace")


@unittest.skipUnless(common.EXE, "TEXDEFRAG_EXE not set (run through ctest)")
class ProgressOnATerminalTest(unittest.TestCase):
    def setUp(self):
        self.work = common.fresh_dir("progress")
        self.prod = common.make_production(os.path.join(common.WORKDIR, "prod2_progress"), 2, seed=5)

    def run_on(self, out, on_tty, *extra):
        args = [common.EXE, "batch", self.prod, "-o", out, "--config", common.CONFIG, "-j", "1", *extra]
        if not on_tty:
            return subprocess.run(args, capture_output=True, text=True, timeout=240).stderr
        master, slave = pty.openpty()
        proc = subprocess.Popen(args, stdin=slave, stdout=slave, stderr=slave, close_fds=True)
        os.close(slave)
        text = read_all(master, proc)
        os.close(master)
        self.assertEqual(proc.wait(timeout=60), 0, text)
        return text

    def test_terminal_gets_the_bar_a_pipe_does_not(self):
        tty_text = self.run_on(os.path.join(self.work, "tty"), True)
        self.assertRegex(tty_text, r"\[#* *\] \d/2 \(\d finished, 0 failed, \d running\) elapsed \d+s ETA ")
        pipe_text = self.run_on(os.path.join(self.work, "pipe"), False)
        self.assertNotIn("ETA", pipe_text)
        quiet_text = self.run_on(os.path.join(self.work, "quiet"), True, "--quiet")
        self.assertNotIn("ETA", quiet_text)


if __name__ == "__main__":
    unittest.main(verbosity=2)
