"""scripts/sameness on two small shipped scenes (issue 29, item 5): the scene as shipped (backward
Euler, Newton at the default tolerance) and backward Euler with L-BFGS end within a quarter of
backward Euler's own time-discretisation error of Newton at a tight tolerance.

Expected values: the bound is backward Euler's own error, measured by the independent run at dt/8
(never by the candidates under test), times 0.25. The script's distances are checked against
the bags themselves, read here (RMS vertex distance of the last states, by hand with numpy).
"""
import json
import os
import shutil
import subprocess
import tempfile
import unittest

import numpy as np
import rosbag

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.realpath(__file__))))
SCRIPT = os.path.join(ROOT, "scripts", "sameness")


def last_positions(path):
    last = None
    with rosbag.Bag(path) as bag:
        for _, msg, _ in bag.read_messages(topics=["/fem_cloth_node/state"]):
            last = msg
    return np.array([[p.x, p.y, p.z] for p in last.positions])


class Sameness(unittest.TestCase):
    def setUp(self):
        self.folder = tempfile.mkdtemp(prefix="fem_cloth_test_sameness-")

    def tearDown(self):
        shutil.rmtree(self.folder)

    def test_small_scenes_are_within_a_quarter_of_backward_eulers_own_error(self):
        rows_file = os.path.join(self.folder, "rows.json")
        done = subprocess.run(["/usr/bin/python3", SCRIPT, "--scenes", "planar_sheet,seed_triangle",
                               "--duration", "0.1", "--out", self.folder, "--json", rows_file],
                              capture_output=True, text=True, timeout=600)
        self.assertEqual(done.returncode, 0, done.stdout + done.stderr)
        with open(rows_file) as f:
            rows = json.load(f)
        self.assertEqual(sorted((r["scene"], r["candidate"]) for r in rows),
                         [("planar_sheet.yaml", "backward_euler lbfgs"),
                          ("planar_sheet.yaml", "shipped: backward_euler newton"),
                          ("seed_triangle.yaml", "backward_euler lbfgs"),
                          ("seed_triangle.yaml", "shipped: backward_euler newton")])
        for r in rows:
            what = f"{r['scene']} {r['candidate']}"
            self.assertNotIn("error", r, what)
            # Backward Euler's own error is a real, measurable distance (the dt/8 run moved).
            self.assertGreater(r["be_end"], 1e-5, what)
            self.assertLessEqual(r["end"], 0.25 * r["be_end"], what)
            self.assertLessEqual(r["max"], 0.25 * r["be_max"], what)
            self.assertTrue(r["pass"], what)
            self.assertGreater(r["substeps"], 0, what)
        # The script's RMS distance at the end, recomputed from the bags.
        for scene in ("planar_sheet", "seed_triangle"):
            ref = last_positions(os.path.join(self.folder, f"{scene}.reference.bag"))
            for label in ("shipped_backward_euler_newton", "backward_euler_lbfgs"):
                cand = last_positions(os.path.join(self.folder, f"{scene}.{label}.bag"))
                rms = float(np.sqrt(np.mean(np.sum((cand - ref) ** 2, axis=1))))
                row = next(r for r in rows if r["scene"] == scene + ".yaml"
                           and r["candidate"].replace(":", "").replace(" ", "_") == label)
                self.assertAlmostEqual(row["end"], rms, delta=1e-3 * rms + 1e-12)

    def test_bad_input_is_one_line_and_status_2(self):
        for args, mention in ((["--scenes", "nonesuch"], "nonesuch.yaml"),
                              (["--scenes", "gripper_pinch"], "skipped: gripper_pinch.yaml"),
                              (["--duration", "-1"], "--duration")):
            done = subprocess.run(["/usr/bin/python3", SCRIPT, "--out", self.folder, *args],
                                  capture_output=True, text=True, timeout=60)
            self.assertEqual(done.returncode, 2, done.stderr)
            self.assertEqual(len(done.stderr.strip().splitlines()), 1, done.stderr)
            self.assertIn(mention, done.stderr)


if __name__ == "__main__":
    unittest.main()
