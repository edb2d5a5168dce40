"""fem_cloth_fit (docs/fitting.md): recordings that cannot be fitted get one line naming the
culprit; the shipped synthetic recording, made from known parameters (test/data/fit/truth.yaml),
is fitted back to them from a start 3 times off.

Expected values: the parameters that made the recording, and the marker noise it was made with
(a fit that explains the motion leaves residuals of the noise: RMS distance sigma sqrt(3)).
"""
import contextlib
import io
import json
import math
import os
import shutil
import sys
import tempfile
import unittest

import numpy as np
import yaml

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "src"))
sys.path.insert(0, os.path.join(ROOT, "test", "data", "fit"))

from fem_cloth.fit import cli  # noqa: E402
from fem_cloth.fit.data import NODE  # noqa: E402
import make_recording  # noqa: E402

RECORDING = os.path.join(ROOT, "test", "data", "fit", "grasp_markers.bag")
COMMANDS = os.path.join(ROOT, "test", "data", "small_grasp.bag")


def run_fit(*argv):
    """(exit status, stdout, stderr) of fem_cloth_fit."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        status = cli.main([str(a) for a in argv])
    return status, out.getvalue(), err.getvalue()


def write_recording(path, markers):
    """The commands of small_grasp.bag and the given marker frames [(vertices, points)], stamped
    at the first recorded states' stamps."""
    import rosbag
    with rosbag.Bag(COMMANDS) as source, rosbag.Bag(path, "w") as out:
        stamps = []
        for topic, msg, t in source.read_messages():
            if topic == f"{NODE}/state":
                stamps.append(msg.header.stamp)
            else:
                out.write(topic, msg, t)
        for stamp, (vertices, points) in zip(stamps, markers):
            out.write("/mocap/markers", make_recording.marker_cloud(stamp, "world", vertices, points), stamp)


class Errors(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.mkdtemp(prefix="test_fit-")

    def tearDown(self):
        shutil.rmtree(self.tmp, ignore_errors=True)

    def fit(self, recording, *extra, params=("bending.stiffness=1e-3:1",)):
        argv = [recording, "--out", os.path.join(self.tmp, "out"), "--workers", 1, "--quiet"]
        for p in params:
            argv += ["--param", p]
        return run_fit(*argv, *extra)

    def test_no_observations(self):
        # The commands bag alone: scene, mesh, pins, tf and states, but nothing a camera saw.
        status, _, err = self.fit(COMMANDS)
        self.assertEqual(status, 2)
        self.assertIn("has no observations", err)
        self.assertIn("small_grasp.bag", err)

    def test_markers_off_the_mesh(self):
        # The small cloth has 9 x 9 = 81 vertices: a marker on vertex 81 is on none of them.
        bag = os.path.join(self.tmp, "bad.bag")
        write_recording(bag, [(np.array([0, 8]), np.zeros((2, 3))), (np.array([0, 81]), np.zeros((2, 3)))])
        status, _, err = self.fit(bag)
        self.assertEqual(status, 2)
        self.assertIn("/mocap/markers message 2", err)
        self.assertIn("marker on vertex 81", err)
        self.assertIn("81 vertices", err)

    def test_parameter_without_bounds(self):
        status, _, err = self.fit(RECORDING, params=("damping.mass=0.1:10", "bending.stiffness"))
        self.assertEqual(status, 2)
        self.assertIn("parameter 'bending.stiffness' has no bounds", err)

    def test_bounds_the_scene_refuses(self):
        # docs/scenes.md: material.poisson_ratio must be below 0.5.
        status, _, err = self.fit(RECORDING, params=("material.poisson_ratio=0.1:0.6",))
        self.assertEqual(status, 2)
        self.assertIn("parameter 'material.poisson_ratio': bound 0.6", err)

    def test_exact_vertex_cloud_is_not_an_observation(self):
        status, _, err = self.fit(RECORDING, "--markers", f"{NODE}/points")
        self.assertEqual(status, 2)
        self.assertIn("not an observation", err)


class SyntheticRecovery(unittest.TestCase):
    """The smaller case of docs/fitting.md's worked example: bending stiffness and mass damping
    from 3 times their true values, and the stretch stiffness, which a cloth hanging from a
    gripper barely strains, as weakly determined."""

    @classmethod
    def setUpClass(cls):
        with open(os.path.join(ROOT, "test", "data", "fit", "truth.yaml"), encoding="utf-8") as f:
            cls.truth = yaml.safe_load(f)
        cls.out = tempfile.mkdtemp(prefix="test_fit-recovery-")
        bending, damping = cls.truth["bending.stiffness"], cls.truth["damping.mass"]
        cls.status, cls.stdout, cls.stderr = run_fit(
            RECORDING, "--out", cls.out, "--workers", 2, "--quiet", "--profile-points", 0,
            "--param", "bending.stiffness=1e-3:1", "--start", f"bending.stiffness={3 * bending}",
            "--param", "damping.mass=0.05:20", "--start", f"damping.mass={damping / 3}",
            "--param", "material.youngs_modulus=2e7:2e9",
            "--start", f"material.youngs_modulus={3 * float(cls.truth['scene']['material.youngs_modulus'])}")
        if cls.status != 0:
            raise AssertionError(f"fem_cloth_fit exit {cls.status}: {cls.stderr}")
        with open(os.path.join(cls.out, "fit.json"), encoding="utf-8") as f:
            cls.report = json.load(f)
        cls.by_key = {p["key"]: p for p in cls.report["parameters"]}

    @classmethod
    def tearDownClass(cls):
        shutil.rmtree(cls.out, ignore_errors=True)

    def test_recovers_bending_and_damping_within_10_percent(self):
        for key in ("bending.stiffness", "damping.mass"):
            fitted = self.by_key[key]["fitted"]
            self.assertLess(abs(fitted / self.truth[key] - 1), 0.10, f"{key}: {fitted} vs {self.truth[key]}")
            self.assertEqual(self.by_key[key]["verdict"], "determined")
            low, high = self.by_key[key]["interval95"]
            self.assertTrue(low <= fitted <= high)

    def test_stretch_stiffness_is_not_claimed(self):
        self.assertIn(self.by_key["material.youngs_modulus"]["verdict"],
                      ("weakly determined", "not identifiable from this recording"))
        self.assertIn("material.youngs_modulus", self.stdout)

    def test_residual_is_the_marker_noise(self):
        # Noise sigma per coordinate: an RMS marker distance of sigma sqrt(3) when the motion is
        # explained; the start (3 times off) is far worse.
        noise = self.truth["markers"]["noise"] * math.sqrt(3)
        self.assertLess(abs(self.report["loss_after"] / noise - 1), 0.15)
        self.assertGreater(self.report["loss_before"], 3 * noise)

    def test_outputs(self):
        for name in ("fit.yaml", "scene.yaml", "loss.png", "observed_vs_simulated.png"):
            self.assertTrue(os.path.isfile(os.path.join(self.out, name)), name)
        with open(os.path.join(self.out, "scene.yaml"), encoding="utf-8") as f:
            scene = yaml.safe_load(f)
        self.assertEqual(scene["bending"]["stiffness"], self.by_key["bending.stiffness"]["in_scene"])
        self.assertEqual(scene["damping"]["mass"], self.by_key["damping.mass"]["in_scene"])


if __name__ == "__main__":
    unittest.main()
