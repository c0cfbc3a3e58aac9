"""The Python module (docs/python.md): configurations, stages, runs on files and arrays, eval, and
errors as exceptions carrying the command line's messages. Run by ctest (test_python) with
PYTHONPATH=<build>/python."""
import json
import os
import tempfile
import unittest

import numpy as np
import texdefrag


def example():
    return os.path.join(texdefrag._t.install_root(), "share", "texdefrag", "examples", "building", "building.obj")


def quad_model():
    """Two triangles of a unit square, each its own chart, on one 8x8 RGB page."""
    positions = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], dtype=float)
    faces = np.array([[0, 1, 2], [0, 2, 3]])
    uvs = np.array([[0.1, 0.1], [0.4, 0.1], [0.4, 0.4], [0.6, 0.6], [0.9, 0.9], [0.6, 0.9]])
    face_uvs = np.array([[0, 1, 2], [3, 4, 5]])
    page = (np.arange(8 * 8 * 3) % 251).astype(np.uint8).reshape(8, 8, 3)
    return positions, faces, uvs, face_uvs, [page]


class ConfigTest(unittest.TestCase):
    def test_shipped_names(self):
        names = texdefrag.configs()
        for n in ("best", "paper", "mmethod", "repack", "ablations/arap"):
            self.assertIn(n, names)

    def test_name_path_and_dict_agree(self):
        by_name = texdefrag.config("paper")
        path = texdefrag._t.resolve_config("paper")
        self.assertEqual(texdefrag.config(path), by_name)
        with open(path) as f:
            self.assertEqual(texdefrag.config(json.load(f)), by_name)

    def test_overrides_dict_and_list(self):
        a = texdefrag.config("repack", overrides={"packer.gutter": 8})
        b = texdefrag.config("repack", overrides=["packer.gutter=8"])
        self.assertEqual(a["packer"]["gutter"], 8)
        self.assertEqual(a, b)

    def test_config_error_names_the_key(self):
        with self.assertRaises(texdefrag.ConfigError) as e:
            texdefrag.config("repack", overrides={"packer.gutter": -1})
        self.assertRegex(str(e.exception), r"packer.*gutter.*-1 outside \[0, 64\]")
        self.assertIsInstance(e.exception, ValueError)

    def test_unknown_name(self):
        with self.assertRaises(texdefrag.ConfigNotFound) as e:
            texdefrag.config("no_such_config")
        self.assertIn("not a shipped configuration", str(e.exception))
        self.assertIsInstance(e.exception, texdefrag.ConfigError)

    def test_bad_json_file_names_file_and_line(self):
        bad = os.path.join(texdefrag._t.install_root(), "share", "texdefrag", "configs", "bad", "syntax_error.json")
        if not os.path.exists(bad):
            self.skipTest("configs/bad is not installed (build tree only)")
        with self.assertRaises(texdefrag.ConfigError) as e:
            texdefrag.config(bad)
        self.assertIn("syntax_error.json", str(e.exception))


class StagesTest(unittest.TestCase):
    def test_stages_and_options(self):
        stages = {s["name"]: s for s in texdefrag.stages()}
        for n in ("detectors.region_growing", "mergers.arap", "packers.shelf", "texture.resample", "writers.obj"):
            self.assertIn(n, stages)
        keys = [o["key"] for o in texdefrag.describe("packers.shelf")["options"]]
        self.assertIn("gutter", keys)
        with self.assertRaises(KeyError):
            texdefrag.describe("packers.nope")


class RunTest(unittest.TestCase):
    def test_run_file_report_and_arrays(self):
        with tempfile.TemporaryDirectory() as d:
            r = texdefrag.run(example(), os.path.join(d, "out"), config="repack", arrays=True)
            self.assertTrue(os.path.exists(r.output))
            self.assertEqual(r.report["output_stats"]["faces"], r.report["input_stats"]["faces"])
            self.assertEqual(len(r.model["faces"]), r.report["output_stats"]["faces"])
            self.assertEqual(r.model["pages"][0].dtype, np.uint8)
            with open(os.path.join(d, "out", "building.report.json")) as f:
                self.assertEqual(json.load(f)["output_stats"], r.report["output_stats"])
            m = texdefrag.eval(example(), r.output)
            self.assertGreater(m["fidelity"]["psnr_db"], 30)

    def test_threads_setting_reaches_the_report_and_not_the_output(self):
        outputs = {}
        try:
            for n in (1, 3):
                texdefrag.set_threads(n)
                self.assertEqual(texdefrag.threads(), n)
                with tempfile.TemporaryDirectory() as d:
                    r = texdefrag.run(example(), os.path.join(d, "out"), config="repack")
                    self.assertEqual(r.report["threads"], n)
                    with open(r.output, "rb") as f:
                        outputs[n] = f.read()
            self.assertEqual(outputs[1], outputs[3])
            with self.assertRaises(ValueError):
                texdefrag.set_threads(-1)
        finally:
            texdefrag.set_threads(0)

    def test_no_write(self):
        r = texdefrag.run(example(), config="repack", write=False)
        self.assertEqual(r.output, "")
        self.assertIn("stages", r.report)

    def test_model_error_names_file_and_line(self):
        with tempfile.TemporaryDirectory() as d:
            bad = os.path.join(d, "bad.obj")
            with open(bad, "w") as f:
                f.write("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n")
            with self.assertRaises(texdefrag.ModelError) as e:
                texdefrag.run(bad, os.path.join(d, "out"), config="repack")
            self.assertIn("bad.obj:4", str(e.exception))

    def test_arrays_round_trip(self):
        positions, faces, uvs, face_uvs, pages = quad_model()
        r = texdefrag.run_arrays(positions, faces, uvs, pages, face_uvs=face_uvs, config="repack")
        out = r.model
        np.testing.assert_array_equal(out["positions"], positions)
        np.testing.assert_array_equal(out["faces"], faces)
        self.assertEqual(out["face_pages"].tolist(), [0, 0])
        self.assertEqual(r.report["output_stats"]["charts"], 2)
        self.assertTrue(((out["uvs"] >= 0) & (out["uvs"] <= 1)).all())
        self.assertEqual(out["pages"][0].shape[2], 3)

    def test_arrays_untextured_faces(self):
        positions, faces, uvs, face_uvs, pages = quad_model()
        r = texdefrag.run_arrays(positions, faces, uvs, pages, face_uvs=face_uvs, face_pages=[0, -1], config="repack")
        self.assertEqual(r.model["face_pages"].tolist(), [0, -1])

    def test_bad_arrays_name_argument_and_row(self):
        positions, faces, uvs, face_uvs, pages = quad_model()
        with self.assertRaisesRegex(ValueError, r"faces\[1\]: index 7 outside \[0, 4\)"):
            texdefrag.run_arrays(positions, np.array([[0, 1, 2], [0, 2, 7]]), uvs, pages, face_uvs=face_uvs)
        with self.assertRaisesRegex(ValueError, "faces: expected an integer array"):
            texdefrag.run_arrays(positions, faces.astype(float) + 0.5, uvs, pages, face_uvs=face_uvs)
        with self.assertRaisesRegex(ValueError, r"positions\[2\]: not finite"):
            p = positions.copy()
            p[2, 0] = np.nan
            texdefrag.run_arrays(p, faces, uvs, pages, face_uvs=face_uvs)
        with self.assertRaisesRegex(ValueError, r"pages\[0\]: expected a uint8 array"):
            texdefrag.run_arrays(positions, faces, uvs, [pages[0].astype(float)], face_uvs=face_uvs)


if __name__ == "__main__":
    unittest.main()
