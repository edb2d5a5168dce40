"""fem_cloth_batch's spec: distributions, sweeps, the random streams, and refusals naming the key.

Expected values come from the distributions' definitions (moments, supports, frequencies, with
bounds of four standard errors), from the stream formula docs/batch.md documents, computed here
again, and from hand-written lists; no fem_cloth program runs in this file.
"""

import hashlib
import math
import os
import random
import shutil
import tempfile
import unittest

from fem_cloth.batch.spec import Spec, SpecError, yaml_text

BASE_SCENE = "name: base\nmesh: {type: grid, rows: 3, cols: 3}\nduration: 0.1\n"


class SpecTestCase(unittest.TestCase):
    def setUp(self):
        self.folder = tempfile.mkdtemp(prefix="fem_cloth_test_spec-")
        with open(os.path.join(self.folder, "base.yaml"), "w") as f:
            f.write(BASE_SCENE)

    def tearDown(self):
        shutil.rmtree(self.folder)

    def spec(self, text):
        path = os.path.join(self.folder, "spec.yaml")
        with open(path, "w") as f:
            f.write("scene: base.yaml\n" + text)
        return Spec(path)

    def refused(self, text, *fragments):
        with self.assertRaises(SpecError) as caught:
            self.spec(text)
        for fragment in fragments:
            self.assertIn(fragment, str(caught.exception))
        return str(caught.exception)


def stream_value(seed, draw, key):
    """The first random() of a key's stream, from the formula in docs/batch.md."""
    digest = hashlib.sha256(f"fem_cloth_batch/{seed}/{draw}/{key}".encode()).digest()
    return random.Random(int.from_bytes(digest[:8], "big")).random()


class TestDistributions(SpecTestCase):
    N = 4000

    def values(self, key, template):
        spec = self.spec(f"episodes: {self.N}\nseed: 7\nrandom:\n  {key}: {template}\n")
        return [e.values[key] for e in spec.all_episodes()]

    def assert_mean(self, values, mean, std):
        # Four standard errors of the mean: a fixed seed, so this either always passes or never.
        self.assertLess(abs(sum(values) / len(values) - mean), 4 * std / math.sqrt(len(values)))

    def test_uniform_follows_the_documented_stream(self):
        spec = self.spec("episodes: 5\nseed: 3\nrandom:\n  material.youngs_modulus: {uniform: [1.0e7, 3.0e7]}\n")
        for episode in spec.all_episodes():
            expected = 1.0e7 + 2.0e7 * stream_value(3, episode.draw, "material.youngs_modulus")
            self.assertEqual(episode.values["material.youngs_modulus"], expected)

    def test_uniform_moments_and_support(self):
        values = self.values("damping.mass", "{uniform: [0.2, 0.6]}")
        self.assertTrue(all(0.2 <= v <= 0.6 for v in values))
        self.assert_mean(values, 0.4, 0.4 / math.sqrt(12))

    def test_loguniform_is_uniform_in_the_logarithm(self):
        values = self.values("bending.stiffness", "{loguniform: [1.0e-6, 1.0e-2]}")
        self.assertTrue(all(1e-6 <= v <= 1e-2 for v in values))
        logs = [math.log10(v) for v in values]
        self.assert_mean(logs, -4.0, 4.0 / math.sqrt(12))
        # A quarter of the decades, a quarter of the values.
        share = sum(1 for v in logs if v < -5.0) / len(logs)
        self.assertLess(abs(share - 0.25), 4 * math.sqrt(0.25 * 0.75 / len(logs)))

    def test_normal_moments(self):
        values = self.values("damping.mass", "{normal: {mean: 2.0, std: 0.5}}")
        self.assert_mean(values, 2.0, 0.5)
        variance = sum((v - 2.0) ** 2 for v in values) / len(values)
        # Standard error of the sample variance of a normal: sigma^2 sqrt(2 / n).
        self.assertLess(abs(variance - 0.25), 4 * 0.25 * math.sqrt(2.0 / len(values)))

    def test_truncated_normal_stays_in_its_window(self):
        values = self.values("damping.mass", "{normal: {mean: 0.0, std: 1.0, min: 0.0, max: 1.0}}")
        self.assertTrue(all(0.0 <= v <= 1.0 for v in values))
        # Mean of the standard normal truncated to [0, 1]: (phi(0) - phi(1)) / (Phi(1) - Phi(0)).
        phi = lambda x: math.exp(-x * x / 2) / math.sqrt(2 * math.pi)  # noqa: E731
        mass = 0.5 * math.erf(1 / math.sqrt(2))
        self.assert_mean(values, (phi(0) - phi(1)) / mass, 0.3)

    def test_integer_covers_its_range_evenly(self):
        values = self.values("mesh.rows", "{integer: [3, 6]}")
        self.assertEqual(set(values), {3, 4, 5, 6})
        self.assertTrue(all(isinstance(v, int) for v in values))
        for k in range(3, 7):
            share = values.count(k) / len(values)
            self.assertLess(abs(share - 0.25), 4 * math.sqrt(0.25 * 0.75 / len(values)))

    def test_weighted_choice_frequencies(self):
        values = self.values("material.model", "{choice: {values: [stvk, arap, linear], weights: [1, 3, 0]}}")
        self.assertNotIn("linear", values)
        share = values.count("arap") / len(values)
        self.assertLess(abs(share - 0.75), 4 * math.sqrt(0.75 * 0.25 / len(values)))

    def test_vector_templates_draw_each_component(self):
        spec = self.spec("episodes: 50\nrandom:\n  mesh.origin: [0, {uniform: [1, 2]}, {integer: [5, 5]}]\n")
        for episode in spec.all_episodes():
            x, y, z = episode.values["mesh.origin"]
            self.assertEqual((x, z), (0, 5))
            self.assertTrue(1 <= y <= 2)


class TestSweepsAndStreams(SpecTestCase):
    def test_sweep_forms(self):
        spec = self.spec("sweep:\n  a.b: {linspace: [0.0, 1.0, 5]}\n  c: {logspace: [1.0e-3, 1.0e-1, 3]}\n"
                         "  d: {range: [2, 9, 3]}\n  e: [x, y]\n")
        self.assertEqual(spec.sweep["a.b"], [0.0, 0.25, 0.5, 0.75, 1.0])
        for got, want in zip(spec.sweep["c"], [1e-3, 1e-2, 1e-1]):
            self.assertAlmostEqual(got, want, delta=1e-15)
        self.assertEqual(spec.sweep["d"], [2, 5, 8])
        self.assertEqual(len(spec), 5 * 3 * 3 * 2)

    def test_episode_order_and_common_random_numbers(self):
        spec = self.spec("episodes: 3\nsweep:\n  material.model: [stvk, arap]\n"
                         "random:\n  damping.mass: {uniform: [0, 1]}\n")
        episodes = spec.all_episodes()
        self.assertEqual([(e.values["material.model"], e.draw) for e in episodes],
                         [("stvk", 0), ("stvk", 1), ("stvk", 2), ("arap", 0), ("arap", 1), ("arap", 2)])
        # Draw r has the same random values at every sweep point.
        for r in range(3):
            self.assertEqual(episodes[r].values["damping.mass"], episodes[3 + r].values["damping.mass"])
            self.assertEqual(episodes[r].seed, episodes[3 + r].seed)
        self.assertEqual(len({e.values["damping.mass"] for e in episodes}), 3)

    def test_adding_a_key_leaves_the_other_draws_alone(self):
        one = self.spec("episodes: 4\nrandom:\n  damping.mass: {uniform: [0, 1]}\n").all_episodes()
        two = self.spec("episodes: 4\nrandom:\n  bending.stiffness: {uniform: [0, 1]}\n"
                        "  damping.mass: {uniform: [0, 1]}\n").all_episodes()
        self.assertEqual([e.values["damping.mass"] for e in one], [e.values["damping.mass"] for e in two])

    def test_the_seed_changes_the_draws(self):
        a = self.spec("seed: 1\nepisodes: 3\nrandom: {damping.mass: {uniform: [0, 1]}}\n").all_episodes()
        b = self.spec("seed: 2\nepisodes: 3\nrandom: {damping.mass: {uniform: [0, 1]}}\n").all_episodes()
        self.assertNotEqual([e.values for e in a], [e.values for e in b])

    def test_overrides_are_exact_text(self):
        spec = self.spec("episodes: 20\nset: {mesh.rows: 5}\nrandom: {material.youngs_modulus: {uniform: [1.0e6, 1.0e8]}}\n")
        for episode in spec.all_episodes():
            overrides = spec.overrides(episode)
            self.assertEqual(overrides[0], "mesh.rows=5")
            key, text = overrides[1].split("=")
            self.assertEqual(key, "material.youngs_modulus")
            self.assertEqual(float(text), episode.values[key])  # reads back to the same double

    def test_yaml_text(self):
        self.assertEqual(yaml_text([[0, 0], [0, -1]]), "[[0, 0], [0, -1]]")
        self.assertEqual(yaml_text("neo_hookean"), "neo_hookean")
        self.assertEqual(yaml_text("yes"), '"yes"')
        self.assertEqual(yaml_text(True), "true")
        self.assertEqual(yaml_text(0.1), "0.1")

    def test_yaml_numbers_as_the_scenes_read_them(self):
        spec = self.spec("set: {a: 1e7, b: 2.0e7, c: 1.5E-3, d: 3}\n")
        self.assertEqual(spec.fixed, {"a": 1e7, "b": 2e7, "c": 1.5e-3, "d": 3})


class TestRefusals(SpecTestCase):
    def test_unknown_key(self):
        self.refused("episods: 3\n", "unknown key 'episods'", "known: scene, episodes")

    def test_key_given_twice(self):
        self.refused("seed: 1\nseed: 2\n", "key 'seed' given twice")

    def test_unknown_distribution(self):
        self.refused("random: {damping.mass: {unifrom: [0, 1]}}\n", "'damping.mass'", "unknown distribution 'unifrom'")

    def test_bad_arguments(self):
        self.refused("random: {damping.mass: {uniform: [1, 0]}}\n", "'damping.mass'", "low 1 is above high 0")
        self.refused("random: {damping.mass: {loguniform: [0, 1]}}\n", "'damping.mass'", "0 < low")
        self.refused("random: {damping.mass: {normal: {mean: 0}}}\n", "'damping.mass'", "needs {mean, std}")
        self.refused("random: {damping.mass: {normal: {mean: 0, std: 1, min: 9, max: 10}}}\n",
                     "'damping.mass'", "holds only")
        self.refused("random: {mesh.rows: {integer: [1.5, 3]}}\n", "'mesh.rows'", "integers")
        self.refused("random: {material.model: {choice: []}}\n", "'material.model'", "non-empty list")
        self.refused("random: {mesh.origin: [0, {uniform: [0]}, 0]}\n", "'mesh.origin[1]'", "2 finite numbers")
        self.refused("random: {damping.mass: 0.3}\n", "'damping.mass' draws nothing")
        self.refused("sweep: {integrator.dt: {linspace: [0.01, 0.02]}}\n", "'integrator.dt'", "3 finite numbers")
        self.refused("sweep: {integrator.dt: []}\n", "'integrator.dt' has no values")

    def test_conflicting_keys(self):
        self.refused("set: {mesh.rows: 3}\nsweep: {mesh.rows: [3, 4]}\n", "'mesh.rows' is in both set and sweep")
        self.refused("set: {pins.0: {vertices: [0]}}\nrandom: {pins.0.offset: [0, 0, {uniform: [0, 1]}]}\n",
                     "'pins.0.offset' is inside 'pins.0'")

    def test_bad_values(self):
        self.refused("episodes: 0\n", "episodes must be an integer >= 1")
        self.refused("output: bags\n", "output must be one of bag, csv, none")
        self.refused("set: {'mesh rows': 3}\n", "'mesh rows' is not a scene key")
        with self.assertRaises(SpecError) as caught:
            path = os.path.join(self.folder, "spec.yaml")
            with open(path, "w") as f:
                f.write("scene: missing.yaml\n")
            Spec(path)
        self.assertIn("no such file 'missing.yaml'", str(caught.exception))

    def test_commands_bag(self):
        # Issue 33: episodes driven by a recorded run's commands; the bag is relative to the spec,
        # and every episode's fem_cloth_sim command replays it on the episode's scene.
        from fem_cloth.batch.batch import EpisodeFiles
        self.refused("commands: missing.bag\n", "commands: no such file 'missing.bag'")
        self.refused("commands: [a.bag]\n", "commands must be the path of a bag")
        open(os.path.join(self.folder, "run.bag"), "w").close()
        spec = self.spec("commands: run.bag\n")
        self.assertEqual(spec.commands, os.path.join(self.folder, "run.bag"))
        files = EpisodeFiles(os.path.join(self.folder, "episodes", "000000"), "none")
        argv = files.command("fem_cloth_sim", "scene.yaml", None, spec.commands)
        self.assertEqual(argv[:5], ["fem_cloth_sim", "--commands", spec.commands, "--scene", "scene.yaml"])
        self.assertIsNone(self.spec("").commands)

    def test_huge_batches_are_counted_before_they_are_built(self):
        # Issue 31: episodes 1e8 and range [3, 1e9, 1] were built in memory until killed. Refused
        # at once, naming the count (999999997 = 1e9 - 3 values) and the limit.
        self.refused("episodes: 100000000\n", "100000000 episodes", "--max-episodes")
        self.refused("sweep: {mesh.rows: {range: [3, 1000000000, 1]}}\n", "'mesh.rows'", "999999997 values",
                     "100000", "--max-episodes")
        self.refused("sweep: {integrator.dt: {linspace: [0.001, 0.01, 100000000]}}\n", "100000000 values")
        # The product of the sweeps: 400 x 300 = 120000 points.
        self.refused("sweep: {mesh.rows: {range: [3, 403, 1]}, mesh.cols: {range: [3, 303, 1]}}\n",
                     "120000 episodes", "400 x 300 sweep values x 1 episodes")
        # At the limit it is taken; a higher limit takes more.
        self.assertEqual(len(self.spec("episodes: 100000\n")), 100000)
        path = os.path.join(self.folder, "spec.yaml")
        with open(path, "w") as f:
            f.write("scene: base.yaml\nepisodes: 100001\n")
        self.assertEqual(len(Spec(path, max_episodes=200000)), 100001)

    def test_malformed_yaml(self):
        self.refused("random: [\n", "malformed YAML")
