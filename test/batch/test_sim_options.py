"""fem_cloth_sim's options for programs (fem_cloth_batch uses them): --check, --write-scene and
--summary-json, run as a program.

Expected values: the grid's vertex and triangle counts by hand; the energies of a free fall under
symplectic Euler in closed form (v_n = g n h, z_n = z_0 - g h^2 n (n + 1) / 2, 1 kg of cloth);
the state hash from its definition (64-bit FNV-1a over the bytes of the positions, then the
velocities: ClothState.msg), computed here over the positions the trajectory file gives.
"""

import csv
import json
import os
import shutil
import struct
import subprocess
import tempfile
import unittest

import yaml

from fem_cloth.batch.batch import find_program

SIM = find_program("fem_cloth_sim")
FREE_FALL = """name: free_fall
mesh: {type: grid, rows: 5, cols: 5, width: 1.0, height: 1.0}
material: {model: stvk, youngs_modulus: 2.0e7, poisson_ratio: 0.3, thickness: 5.0e-4, density: 2000.0}
gravity: [0.0, 0.0, -9.81]
integrator: {name: symplectic_euler, dt: 0.0005, auto_substep: false}
duration: 0.1
"""


def fnv1a64(data):
    h = 14695981039346656037
    for byte in data:
        h = ((h ^ byte) * 1099511628211) % (1 << 64)
    return f"{h:016x}"


class SimTestCase(unittest.TestCase):
    def setUp(self):
        self.folder = tempfile.mkdtemp(prefix="fem_cloth_test_sim-")

    def tearDown(self):
        shutil.rmtree(self.folder)

    def path(self, name):
        return os.path.join(self.folder, name)

    def scene(self, text, name="scene.yaml"):
        with open(self.path(name), "w") as f:
            f.write(text)
        return self.path(name)

    def sim(self, *args):
        done = subprocess.run([SIM, "--quiet", *args], cwd=self.folder, capture_output=True, text=True,
                              timeout=120, env=dict(os.environ, OMP_NUM_THREADS="1"))
        return done.returncode, done.stdout, done.stderr

    def summary(self, *args):
        code, _, stderr = self.sim(*args, "--summary-json", self.path("summary.json"))
        self.assertEqual(code, 0, stderr)
        with open(self.path("summary.json")) as f:
            return json.load(f)


class TestCheck(SimTestCase):
    def test_a_valid_scene_is_checked_without_running(self):
        scene = self.scene(FREE_FALL)
        code, stdout, stderr = self.sim("--scene", scene, "--check")
        self.assertEqual(code, 0, stderr)
        lines = stdout.splitlines()
        self.assertEqual(len(lines), 1)
        # 5 x 5 vertices; 4 x 4 quads of two triangles.
        self.assertIn("25 vertices, 32 triangles", lines[0])
        self.assertEqual(sorted(os.listdir(self.folder)), ["scene.yaml"])  # no output written

    def test_an_unknown_key_is_refused_naming_it(self):
        code, stdout, stderr = self.sim("--scene", self.scene(FREE_FALL), "--set", "material.youngs_moduls=1", "--check")
        self.assertEqual(code, 2)
        self.assertEqual(len(stderr.splitlines()), 1)
        self.assertIn("unknown key 'material.youngs_moduls'", stderr)
        self.assertEqual(stdout, "")

    def test_what_only_building_finds_is_refused(self):
        # Projective dynamics takes ARAP cloth only: known when the simulation is built, not parsed.
        code, _, stderr = self.sim("--scene", self.scene(FREE_FALL), "--integrator", "projective_dynamics", "--check")
        self.assertEqual(code, 2)
        self.assertIn("arap", stderr.lower())

    def test_write_scene_repeats_the_run(self):
        base = self.scene(FREE_FALL)
        sets = ["--set", "mesh.rows=4", "--set", "material.poisson_ratio=0.2512345678901234",
                "--set", "initial.velocity=[0.1, 0, 0]"]
        code, _, stderr = self.sim("--scene", base, *sets, "--check", "--write-scene", self.path("written.yaml"))
        self.assertEqual(code, 0, stderr)
        with open(self.path("written.yaml")) as f:
            written = yaml.safe_load(f)
        self.assertEqual(written["mesh"]["rows"], 4)
        self.assertEqual(written["material"]["poisson_ratio"], 0.2512345678901234)
        self.assertEqual(written["initial"]["velocity"], [0.1, 0, 0])
        self.assertEqual(written["integrator"]["dt"], 0.0005)  # the rest of the base scene
        alone = self.summary("--scene", self.path("written.yaml"), "--no-output")
        with_sets = self.summary("--scene", base, *sets, "--no-output")
        self.assertEqual(alone["state_hash"], with_sets["state_hash"])
        self.assertEqual(alone["steps"], 200)

    def test_no_scene_is_written_for_an_invalid_one(self):
        code, _, stderr = self.sim("--scene", self.scene(FREE_FALL), "--set", "material.poisson_ratio=0.7",
                                   "--write-scene", self.path("written.yaml"))
        self.assertEqual(code, 2)
        self.assertIn("material.poisson_ratio", stderr)
        self.assertFalse(os.path.exists(self.path("written.yaml")))


class TestSummaryJson(SimTestCase):
    def test_free_fall_energies_in_closed_form(self):
        g, h, n = 9.81, 5e-4, 200
        csv_run = self.summary("--scene", self.scene(FREE_FALL), "--out", self.path("csv"))
        bag_run = self.summary("--scene", self.scene(FREE_FALL), "--out", self.path("run.bag"))
        for run in (csv_run, bag_run):
            self.assertEqual(run["status"], "ok")
            self.assertEqual(run["steps"], n)
            self.assertAlmostEqual(run["simulated_s"], n * h, delta=1e-12)
            e = run["energy"]
            self.assertAlmostEqual(e["kinetic"], 0.5 * (g * n * h) ** 2, delta=1e-12)
            self.assertAlmostEqual(e["gravity"], -g * g * h * h * n * (n + 1) / 2, delta=1e-12)
            self.assertAlmostEqual(e["strain"], 0.0, delta=1e-12)  # a rigid motion
            self.assertAlmostEqual(e["total"], e["kinetic"] + e["gravity"] + e["strain"] + e["bending"], delta=1e-12)
            self.assertLess(abs(run["stretch"]["max"]), 1e-12)
        self.assertEqual(csv_run["state_hash"], bag_run["state_hash"])
        self.assertEqual(bag_run["outputs"], [self.path("run.bag")])
        self.assertTrue(os.path.isfile(self.path("run.bag")))

    def test_state_hash_is_fnv1a_of_positions_then_velocities(self):
        # Every vertex pinned where it rests: the velocities are zero, the positions those the
        # trajectory file gives (17 significant digits: exact doubles).
        scene = self.scene("name: pinned\nmesh: {type: grid, rows: 3, cols: 4, width: 0.3, height: 0.7}\n"
                           "material: {model: stvk, youngs_modulus: 2.0e7, poisson_ratio: 0.3}\n"
                           "integrator: {name: backward_euler, dt: 0.01}\npins: [{grid_edge: all}]\n"
                           "duration: 0.05\n")
        run = self.summary("--scene", scene, "--out", self.path("out"))
        with open(self.path("out/trajectory.csv")) as f:
            last = list(csv.reader(f))[-1]
        x = [float(v) for v in last[2:]]
        self.assertEqual(len(x), 3 * 12)
        expected = fnv1a64(struct.pack(f"<{len(x)}d", *x) + struct.pack(f"<{len(x)}d", *([0.0] * len(x))))
        self.assertEqual(run["state_hash"], expected)

    def test_a_failed_run_says_why(self):
        scene = self.scene(FREE_FALL.replace("dt: 0.0005", "dt: 0.01"))
        code, _, stderr = self.sim("--scene", scene, "--no-output", "--summary-json", self.path("summary.json"))
        self.assertEqual(code, 3)
        with open(self.path("summary.json")) as f:
            run = json.load(f)
        self.assertEqual(run["status"], "failed")
        self.assertEqual(run["steps"], 0)
        self.assertIn("stable step", run["error"])
        self.assertIn(run["error"], stderr)
