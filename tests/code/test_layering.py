#!/usr/bin/env python3
"""Layering of the sources (ctest: test_layering; issue 11, "eval ... names no stage; commands live
in cli/").

- No source under eval/ includes a header of cli/: the command-line commands live in cli/ and use
  eval's libraries, never the other way round (eval's commands once included cli/commands.h).
- The measures and the benchmark harness (eval/metrics, eval/bench, eval/report) name no stage
  (`detectors.none`, ...): they take the stages a configuration names and get a detector's regions
  from the pipeline (RunOptions::stop_after / on_stage) instead of running one by hand (the views
  benchmark once named detectors.none and re-ran a detector itself).
Test sources (tests/ folders, test_*.cpp) are exempt: a test may name the stages it exercises.
"""

import os
import re
import sys
import unittest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SOURCE_EXTENSIONS = (".cpp", ".h", ".hpp", ".cc")
CLI_INCLUDE = re.compile(r'^\s*#\s*include\s*[<"](?:\.\./)*(?:cli/|commands\.h)', re.M)
STAGE_NAME = re.compile(r'"(?:detectors|mergers|packers)\.[a-z_][a-z0-9_]*"')


def sources(folder):
    """Non-test C++ sources under ROOT/folder, as (relative path, text)."""
    base = os.path.join(ROOT, folder)
    for root, dirs, files in os.walk(base):
        dirs[:] = sorted(d for d in dirs if d != "tests")
        for f in sorted(files):
            if f.endswith(SOURCE_EXTENSIONS) and not f.startswith("test_"):
                path = os.path.join(root, f)
                with open(path, encoding="utf-8", errors="replace") as fh:
                    yield os.path.relpath(path, ROOT), fh.read()


def violations(folders, pattern):
    """'path:line: text' of every match of `pattern` in the sources of `folders`."""
    found = []
    for folder in folders:
        for rel, text in sources(folder):
            for m in pattern.finditer(text):
                line = text.count("\n", 0, m.start()) + 1
                found.append(f"{rel}:{line}: {m.group(0).strip()}")
    return found


class Layering(unittest.TestCase):
    def test_eval_includes_no_cli_header(self):
        self.assertTrue(any(sources("eval")), "no eval sources found: wrong root?")
        self.assertEqual(violations(["eval"], CLI_INCLUDE), [])

    def test_measures_and_benchmarks_name_no_stage(self):
        folders = ["eval/metrics", "eval/bench", "eval/report"]
        for f in folders:
            self.assertTrue(os.path.isdir(os.path.join(ROOT, f)), f)
        self.assertEqual(violations(folders, STAGE_NAME), [])

    def test_the_patterns_find_what_they_forbid(self):
        # So the checks above cannot pass by matching nothing.
        self.assertTrue(CLI_INCLUDE.search('#include "cli/commands.h"'))
        self.assertTrue(CLI_INCLUDE.search('#include "../../cli/commands.h"'))
        self.assertTrue(STAGE_NAME.search('reg.create("detectors.none")'))
        self.assertFalse(STAGE_NAME.search('"detectors"'))


if __name__ == "__main__":
    sys.exit(unittest.main())
