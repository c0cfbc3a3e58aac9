#!/usr/bin/env python3
"""The environment `texdefrag batch` gives each `texdefrag run` (docs/batch.md): glibc's malloc asked
for huge pages (so the run need not restart itself for it, cli/huge_pages.cpp), after the user's own
tunables; nothing added with TEXDEFRAG_HUGE_PAGES=0 or when the user set that tunable. A wrapper
executable records the variable, then runs the real texdefrag on two synthetic tiles.

Run by ctest (test_batch_env)."""

import os
import stat
import subprocess
import sys
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402


@unittest.skipUnless(common.EXE, "TEXDEFRAG_EXE not set (run through ctest)")
class RunEnvironmentTest(unittest.TestCase):
    def setUp(self):
        self.work = common.fresh_dir("env")
        self.prod = common.make_production(os.path.join(common.WORKDIR, "prod2_env"), 2, seed=9)
        self.seen = os.path.join(self.work, "seen.txt")
        self.wrapper = os.path.join(self.work, "wrapper.sh")
        with open(self.wrapper, "w") as f:
            f.write(f"""#!/bin/sh
[ "$1" = run ] && echo "${{GLIBC_TUNABLES-<unset>}}" >> {self.seen}
exec {common.EXE} "$@"
""")
        os.chmod(self.wrapper, os.stat(self.wrapper).st_mode | stat.S_IXUSR)

    def tunables_seen(self, name, **env):
        if os.path.exists(self.seen):
            os.remove(self.seen)
        full = dict(os.environ)
        for k in ("GLIBC_TUNABLES", "TEXDEFRAG_HUGE_PAGES"):
            full.pop(k, None)
        full.update(env)
        p = subprocess.run([common.EXE, "batch", self.prod, "-o", os.path.join(self.work, name), "--config",
                            common.CONFIG, "-j", "1", "--quiet", "--worker-texdefrag", self.wrapper],
                           capture_output=True, text=True, timeout=300, env=full)
        self.assertEqual(p.returncode, 0, p.stderr)
        with open(self.seen) as f:
            return sorted(set(f.read().split()))

    def test_huge_pages_tunable(self):
        self.assertEqual(self.tunables_seen("plain"), ["glibc.malloc.hugetlb=1"])
        self.assertEqual(self.tunables_seen("user", GLIBC_TUNABLES="glibc.malloc.arena_max=2"),
                         ["glibc.malloc.arena_max=2:glibc.malloc.hugetlb=1"])
        self.assertEqual(self.tunables_seen("own", GLIBC_TUNABLES="glibc.malloc.hugetlb=0"),
                         ["glibc.malloc.hugetlb=0"])
        self.assertEqual(self.tunables_seen("off", TEXDEFRAG_HUGE_PAGES="0"), ["<unset>"])


if __name__ == "__main__":
    unittest.main(verbosity=2)
