"""fem_cloth_batch end to end, run as a program on 2-worker Dask clusters bound to 127.0.0.1 (one
started here as docs/batch.md says, by dask-scheduler and dask-worker, with workers that do not
have fem_cloth's Python package, reached with --scheduler; and the program's own local cluster):
episodes and
index complete, the drawn values in the scene files, an episode re-run alone ends in the same
state, a bad spec refused naming the key, failing episodes reported without stopping the batch,
resume skipping what is done, verify across thread counts (and catching a wrong hash), and no
process left behind.
"""

import csv
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import unittest
import uuid

import yaml

from fem_cloth.batch.batch import RESULT_COLUMNS, find_program, program_files

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
BATCH = os.path.join(ROOT, "scripts", "fem_cloth_batch")
SIM = find_program("fem_cloth_sim")
REPORT = find_program("fem_cloth_report")
HANGING = os.path.join(ROOT, "config", "hanging_cloth.yaml")
CLUSTER = {}


def setUpModule():
    """A scheduler and a worker with two processes of one thread, as on a cluster: started by
    hand, from another folder, without PYTHONPATH (so without fem_cloth's package)."""
    folder = tempfile.mkdtemp(prefix="fem_cloth_test_cluster-")
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    address_file = os.path.join(folder, "scheduler.json")
    log = open(os.path.join(folder, "cluster.log"), "w")
    common = dict(cwd=folder, env=env, stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
    CLUSTER.update(folder=folder, log=log, processes=[])
    CLUSTER["processes"].append(subprocess.Popen(
        [shutil.which("dask-scheduler"), "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
         "--scheduler-file", address_file], **common))
    deadline = time.monotonic() + 60
    while not os.path.exists(address_file) and time.monotonic() < deadline:
        time.sleep(0.1)
    CLUSTER["processes"].append(subprocess.Popen(
        [shutil.which("dask-worker"), "--scheduler-file", address_file, "--nworkers", "2", "--nthreads", "1",
         "--host", "127.0.0.1", "--no-dashboard", "--dashboard-address", "127.0.0.1:0",
         "--local-directory", folder], **common))
    import distributed
    with open(address_file) as f:
        CLUSTER["address"] = json.load(f)["address"]
    with distributed.Client(CLUSTER["address"], timeout=60) as client:
        client.wait_for_workers(2, timeout=60)


def tearDownModule():
    for process in reversed(CLUSTER["processes"]):
        os.killpg(process.pid, signal.SIGTERM)
        try:
            process.wait(timeout=30)
        except subprocess.TimeoutExpired:
            os.killpg(process.pid, signal.SIGKILL)
            process.wait()
    CLUSTER["log"].close()
    shutil.rmtree(CLUSTER["folder"], ignore_errors=True)


def batch(*args, env=None):
    done = subprocess.run([sys.executable, BATCH, *args], capture_output=True, text=True, timeout=300,
                          env=env)
    return done.returncode, done.stdout, done.stderr


def on_cluster(*args):
    return batch(*args, "--scheduler", CLUSTER["address"], "--quiet")


def read_index(path):
    with open(path, newline="") as f:
        reader = csv.DictReader(f)
        return reader.fieldnames, list(reader)


class BatchTestCase(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.folder = tempfile.mkdtemp(prefix="fem_cloth_test_batch-")

    @classmethod
    def tearDownClass(cls):
        shutil.rmtree(cls.folder)

    @classmethod
    def write_spec(cls, name, text):
        path = os.path.join(cls.folder, name)
        with open(path, "w") as f:
            f.write(f"scene: {HANGING}\n" + text)
        return path


class TestRun(BatchTestCase):
    """Six episodes: three draws at each of two sweep points; at the second the explicit step is
    above the scene's stable step with substepping off, so every episode there fails (exit 3)."""

    SPEC = """episodes: 3
seed: 11
set: {mesh.rows: 7, mesh.cols: 7, duration: 0.2}
sweep:
  integrator.auto_substep: [true, false]
random:
  material.youngs_modulus: {loguniform: [1.0e7, 4.0e7]}
  damping.mass: {uniform: [0.05, 0.2]}
  pins.0.grid_vertices: [[0, 0], [0, {integer: [3, 6]}]]
  mesh.origin: [0, 0, {uniform: [0.0, 0.5]}]
output: bag
"""

    @classmethod
    def setUpClass(cls):
        super().setUpClass()
        cls.out = os.path.join(cls.folder, "out")
        cls.code, cls.stdout, cls.stderr = on_cluster(cls.write_spec("spec.yaml", cls.SPEC), "--out", cls.out)
        cls.columns, cls.rows = read_index(os.path.join(cls.out, "index.csv"))

    def test_index_has_every_episode_and_column(self):
        self.assertEqual([int(r["episode"]) for r in self.rows], list(range(6)))
        varied = ["integrator.auto_substep", "material.youngs_modulus", "damping.mass",
                  "pins.0.grid_vertices", "mesh.origin"]
        self.assertEqual(self.columns, ["episode", "draw", "seed"] + varied + RESULT_COLUMNS)
        self.assertEqual([int(r["draw"]) for r in self.rows], [0, 1, 2, 0, 1, 2])

    def test_episodes_complete(self):
        for row in self.rows[:3]:
            self.assertEqual((row["status"], row["exit_code"], row["attempts"]), ("ok", "0", "1"), row["error"])
            self.assertEqual(int(row["steps"]), 20)  # 0.2 s at dt 0.01
            self.assertAlmostEqual(float(row["simulated_s"]), 0.2, delta=1e-12)
            self.assertRegex(row["state_hash"], r"^[0-9a-f]{16}$")
            for column in ("kinetic_j", "gravity_j", "total_j", "stretch_max"):
                float(row[column])  # present and a number
            # One OpenMP thread: the run's CPU time is within its wall time (and is not zero).
            self.assertTrue(0 < float(row["cpu_s"]) <= float(row["wall_s"]) + 0.01, row)
            self.assertTrue(row["worker"].startswith("tcp://127.0.0.1:"))
            with open(os.path.join(self.out, row["output"]), "rb") as bag:
                self.assertEqual(bag.read(13), b"#ROSBAG V2.0\n")
        self.assertEqual(len({r["state_hash"] for r in self.rows[:3]}), 3)

    def test_drawn_values_are_in_the_scene_files(self):
        for row in self.rows:
            with open(os.path.join(self.out, row["scene"])) as f:
                scene = yaml.safe_load(f)
            e = scene["material"]["youngs_modulus"]
            self.assertEqual(e, float(row["material.youngs_modulus"]))
            self.assertTrue(1.0e7 <= e <= 4.0e7)
            self.assertTrue(0.05 <= scene["damping"]["mass"] <= 0.2)
            (r0, c0), (r1, c1) = scene["pins"][0]["grid_vertices"]
            self.assertEqual((r0, c0, r1), (0, 0, 0))
            self.assertIn(c1, range(3, 7))
            self.assertEqual(yaml.safe_load(row["pins.0.grid_vertices"]), [[0, 0], [0, c1]])
            self.assertEqual(scene["mesh"]["rows"], 7)  # from set
            self.assertEqual(scene["integrator"]["auto_substep"], row["integrator.auto_substep"] == "true")
            self.assertEqual(scene["integrator"]["name"], "symplectic_euler")  # from the base scene

    def test_failing_episodes_are_reported_and_the_batch_goes_on(self):
        self.assertEqual(self.code, 3, self.stderr)
        for row in self.rows[3:]:
            self.assertEqual((row["status"], row["exit_code"], row["attempts"]), ("failed", "3", "2"))
            self.assertIn("above the stable step", row["error"])
            self.assertIn(f"episode {row['episode']}: failed (exit 3, 2 attempts)", self.stdout)
        self.assertIn("6 episodes: 3 ok, 3 not ok", self.stdout)

    def test_an_episode_reruns_alone_to_the_same_state(self):
        row = self.rows[1]
        scene = os.path.join(self.out, row["scene"])
        for threads in ("1", "2"):
            summary = os.path.join(self.folder, f"alone-{threads}.json")
            done = subprocess.run([SIM, "--scene", scene, "--no-output", "--quiet", "--summary-json", summary],
                                  cwd=self.folder, capture_output=True, text=True, timeout=120,
                                  env=dict(os.environ, OMP_NUM_THREADS=threads))
            self.assertEqual(done.returncode, 0, done.stderr)
            with open(summary) as f:
                self.assertEqual(json.load(f)["state_hash"], row["state_hash"])


class TestRefusals(BatchTestCase):
    def refused(self, text, *fragments):
        out = os.path.join(self.folder, "refused")
        code, stdout, stderr = batch(self.write_spec("bad.yaml", text), "--out", out)
        self.assertEqual(code, 2, stdout + stderr)
        self.assertEqual(len(stderr.splitlines()), 1, stderr)
        for fragment in fragments:
            self.assertIn(fragment, stderr)
        self.assertFalse(os.path.exists(os.path.join(out, "index.csv")))

    def test_unknown_spec_key(self):
        self.refused("episods: 2\n", "unknown key 'episods'")

    def test_unknown_scene_key(self):
        self.refused("random: {material.youngs_moduls: {uniform: [1.0e7, 2.0e7]}}\n",
                     "episode 0", "unknown key 'material.youngs_moduls'")

    def test_bad_distribution(self):
        self.refused("random: {damping.mass: {uniform: [0.3]}}\n", "'damping.mass'", "uniform needs a list of 2")

    def test_a_drawn_value_out_of_range(self):
        # A normal distribution for Poisson's ratio reaches beyond 0.5 in some episode.
        self.refused("episodes: 40\nset: {mesh.rows: 3, mesh.cols: 3}\n"
                     "random: {material.poisson_ratio: {normal: {mean: 0.4, std: 0.1}}}\n",
                     "material.poisson_ratio must be in [0, 0.5)")


    def test_a_dry_run_writes_and_checks_the_scenes_only(self):
        out = os.path.join(self.folder, "dry")
        spec = self.write_spec("dry.yaml", "episodes: 3\nrandom: {damping.mass: {uniform: [0.0, 0.3]}}\n")
        code, stdout, stderr = batch(spec, "--out", out, "--dry-run")
        self.assertEqual(code, 0, stdout + stderr)
        self.assertIn("3 written and checked", stdout)
        self.assertEqual(sorted(os.listdir(os.path.join(out, "episodes"))), ["000000", "000001", "000002"])
        self.assertEqual(os.listdir(os.path.join(out, "episodes", "000001")), ["scene.yaml"])
        self.assertFalse(os.path.exists(os.path.join(out, "index.csv")))

    def test_one_batch_at_a_time_in_a_folder(self):
        import fcntl
        out = os.path.join(self.folder, "busy")
        os.makedirs(out)
        with open(os.path.join(out, ".lock"), "w") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)  # as a running fem_cloth_batch holds it
            code, stdout, stderr = batch(self.write_spec("busy.yaml", "set: {duration: 0.1}\n"), "--out", out)
        self.assertEqual(code, 2, stdout + stderr)
        self.assertIn(f"another fem_cloth_batch is working in {out}", stderr)
        self.assertEqual(os.listdir(out), [".lock"])


class TestResume(BatchTestCase):
    SPEC = "episodes: 3\nset: {mesh.rows: 5, mesh.cols: 5, duration: 0.1}\n" \
           "random: {damping.mass: {uniform: [0.0, 0.3]}}\noutput: csv\n"

    def logs(self):
        return {i: os.stat(os.path.join(self.out, "episodes", f"{i:06d}", "log.txt")).st_mtime_ns for i in range(3)}

    def test_resume_runs_only_what_is_missing(self):
        self.out = os.path.join(self.folder, "resume")
        spec = self.write_spec("resume.yaml", self.SPEC)
        code, stdout, stderr = on_cluster(spec, "--out", self.out)
        self.assertEqual(code, 0, stdout + stderr)
        _, first = read_index(os.path.join(self.out, "index.csv"))
        before = self.logs()

        code, stdout, stderr = on_cluster(spec, "--out", self.out)
        self.assertEqual(code, 0, stdout + stderr)
        self.assertIn("0 written and checked", stdout)
        self.assertIn("3 episodes already done (skipped)", stdout)
        self.assertEqual(self.logs(), before)

        # Episode 1 loses an output; the index's last row (episode 2) is cut short, as by a kill.
        os.remove(os.path.join(self.out, "episodes", "000001", "trajectory.csv"))
        index = os.path.join(self.out, "index.csv")
        with open(index) as f:
            text = f.read()
        with open(index, "w") as f:
            f.write(text[: text.rstrip("\n").rfind("\n") + 40])
        code, stdout, stderr = on_cluster(spec, "--out", self.out)
        self.assertEqual(code, 0, stdout + stderr)
        self.assertIn("2 written and checked", stdout)
        after = self.logs()
        self.assertEqual(after[0], before[0])
        self.assertNotEqual(after[1], before[1])
        self.assertNotEqual(after[2], before[2])
        _, last = read_index(index)
        self.assertEqual([(r["episode"], r["status"], r["state_hash"]) for r in last],
                         [(r["episode"], r["status"], r["state_hash"]) for r in first])


    def test_a_changed_program_runs_everything_again(self):
        # The physics is in libfem_cloth_core.so: the fingerprint covers the libraries too.
        self.assertIn("libfem_cloth_core.so", " ".join(program_files(SIM)))
        out = os.path.join(self.folder, "changed")
        program = os.path.join(self.folder, "fem_cloth_sim_copy")
        shutil.copy2(SIM, program)
        spec = self.write_spec("changed.yaml", self.SPEC)
        code, stdout, stderr = on_cluster(spec, "--out", out, "--sim", program)
        self.assertEqual(code, 0, stdout + stderr)
        with open(program, "ab") as f:
            f.write(b"\0")  # other bytes, the same program (an ELF file ignores what follows it)
        code, stdout, stderr = on_cluster(spec, "--out", out, "--sim", program)
        self.assertEqual(code, 0, stdout + stderr)
        self.assertIn("fem_cloth_sim (or its libraries) changed", stdout)
        self.assertIn("3 written and checked", stdout)


class TestTimeout(BatchTestCase):
    def test_an_episode_over_its_time_is_stopped(self):
        # 100 s of a 33 x 33 cloth takes minutes: stopped after 0.5 s, twice (one retry).
        out = os.path.join(self.folder, "timeout")
        spec = self.write_spec("timeout.yaml", "set: {duration: 100.0}\ntimeout: 0.5\noutput: none\n")
        code, stdout, stderr = on_cluster(spec, "--out", out)
        self.assertEqual(code, 3, stdout + stderr)
        _, rows = read_index(os.path.join(out, "index.csv"))
        self.assertEqual([(r["status"], r["attempts"]) for r in rows], [("error", "2")])
        self.assertEqual(rows[0]["error"], "timed out after 0.5 s")
        scene = os.path.join(out, rows[0]["scene"])
        self.assertEqual(subprocess.run(["pgrep", "-f", scene], capture_output=True).stdout, b"")


class TestVerify(BatchTestCase):
    # Episode 0 is 48 x 48 vertices, 2 x 47 x 47 = 4418 triangles: above the 4096 elements from
    # which the element loops run in parallel (kParallelElementThreshold), so two threads take
    # another path through the code than one.
    SPEC = """episodes: 1
set: {duration: 0.05, material.model: arap, integrator.name: projective_dynamics}
sweep: {mesh.rows: [48, 6], mesh.cols: [48]}
random: {damping.mass: {uniform: [0.0, 0.3]}}
output: none
"""

    def test_verify_across_threads_and_a_wrong_hash(self):
        out = os.path.join(self.folder, "verify")
        code, stdout, stderr = on_cluster(self.write_spec("verify.yaml", self.SPEC), "--out", out)
        self.assertEqual(code, 0, stdout + stderr)
        index = os.path.join(out, "index.csv")
        code, stdout, stderr = on_cluster("verify", index, "--threads", "1,2")
        self.assertEqual(code, 0, stdout + stderr)
        self.assertIn("2 episodes x threads 1,2: 4 runs", stdout)
        _, checked = read_index(os.path.join(out, "verify.csv"))
        self.assertEqual([(r["episode"], r["threads"], r["match"]) for r in checked],
                         [("0", "1", "1"), ("0", "2", "1"), ("1", "1", "1"), ("1", "2", "1")])
        self.assertFalse(os.path.exists(os.path.join(out, "verify")))  # re-run outputs removed
        code, stdout, stderr = on_cluster("verify", index, "--threads", "2", "--sample", "1")
        self.assertEqual(code, 0, stdout + stderr)
        self.assertIn("1 episodes x threads 2: 1 runs", stdout)

        columns, rows = read_index(index)
        rows[1]["state_hash"] = "0123456789abcdef"
        tampered = os.path.join(out, "tampered.csv")
        with open(tampered, "w", newline="") as f:
            writer = csv.DictWriter(f, fieldnames=columns)
            writer.writeheader()
            writer.writerows(rows)
        code, stdout, stderr = on_cluster("verify", tampered, "--threads", "1")
        self.assertEqual(code, 4, stdout + stderr)
        self.assertRegex(stdout, r"episode 1 threads 1 \(tcp://127\.0\.0\.1:\d+\): state [0-9a-f]{16}, "
                                 r"index 0123456789abcdef")


def marked_processes(marker):
    """The processes whose environment carries the marker: all the batch started."""
    found = []
    for pid in filter(str.isdigit, os.listdir("/proc")):
        try:
            with open(f"/proc/{pid}/environ", "rb") as f:
                if f"FEM_CLOTH_TEST_MARKER={marker}".encode() in f.read():
                    found.append(int(pid))
        except OSError:
            pass
    return found


class TestReportRunner(BatchTestCase):
    """The accuracy report's stability cells as runner tasks give the report that running them
    in the report's own process gives (all but the wall times)."""

    SELECTION = ["--small", "--study", "stability", "--cases", "pull_corner", "--materials", "stvk",
                 "--dts", "0.03333333333333333", "-q"]

    @staticmethod
    def matrix(out):
        with open(os.path.join(out, "stability.csv"), newline="") as f:
            rows = list(csv.DictReader(f))
        for row in rows:
            row.pop("wall_s")
        return rows

    def test_cells_on_the_runner_make_the_same_report(self):
        here, there = os.path.join(self.folder, "in_process"), os.path.join(self.folder, "runner")
        done = subprocess.run([REPORT, *self.SELECTION, "--out", here], capture_output=True, text=True, timeout=300)
        self.assertEqual(done.returncode, 0, done.stderr)
        code, stdout, stderr = batch("report", "--scheduler", CLUSTER["address"], "--quiet", "--report", REPORT,
                                     "--", *self.SELECTION, "--out", there)
        self.assertEqual(code, 0, stdout + stderr)
        self.assertIn("5 stability cells in", stdout)
        # 1 case x 1 material x 1 stiffness x 5 integrators x 1 step.
        self.assertEqual(len(self.matrix(here)), 5)
        self.assertEqual(self.matrix(there), self.matrix(here))
        matrix = lambda out: open(os.path.join(out, "summary.txt")).read().split("report:")[0]  # noqa: E731
        self.assertEqual(matrix(there), matrix(here))

        # A cell without its result: the report refuses, naming it.
        results = os.path.join(there, "stability_cells", "results")
        first = sorted(os.listdir(results))[0]
        os.remove(os.path.join(results, first))
        done = subprocess.run([REPORT, *self.SELECTION, "--out", there, "--from-cell-results", results],
                              capture_output=True, text=True, timeout=300)
        self.assertEqual(done.returncode, 2)
        self.assertIn("no result for cell 0 (pull_corner stvk cotton symplectic_euler dt 1/30)", done.stderr)


class TestLocalCluster(BatchTestCase):
    def test_own_cluster_on_localhost_leaves_nothing_running(self):
        import psutil
        marker = uuid.uuid4().hex
        spec = self.write_spec("local.yaml", "episodes: 4\nset: {mesh.rows: 9, mesh.cols: 9, duration: 0.5}\n"
                                             "random: {damping.mass: {uniform: [0.0, 0.3]}}\noutput: none\n")
        out = os.path.join(self.folder, "local")
        process = subprocess.Popen([sys.executable, BATCH, spec, "--out", out, "--workers", "2"],
                                   stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                   env=dict(os.environ, FEM_CLOTH_TEST_MARKER=marker))
        # While it runs: every socket the batch's processes listen on is on the loopback interface.
        listening = set()
        while process.poll() is None:
            pids = set(marked_processes(marker))
            for connection in psutil.net_connections(kind="inet"):
                if connection.pid in pids and connection.status == psutil.CONN_LISTEN:
                    listening.add((connection.pid, connection.laddr.ip, connection.laddr.port))
            time.sleep(0.05)
        stdout, stderr = process.communicate()
        self.assertEqual(process.returncode, 0, stdout + stderr)
        self.assertIn("local cluster on 127.0.0.1, 2 workers", stdout)
        self.assertTrue(listening)
        self.assertEqual({ip for _, ip, _ in listening}, {"127.0.0.1"}, listening)
        _, rows = read_index(os.path.join(out, "index.csv"))
        self.assertEqual([r["status"] for r in rows], ["ok"] * 4)
        self.assertTrue(all(re.match(r"tcp://127\.0\.0\.1:\d+$", r["worker"]) for r in rows))
        # Scheduler, nannies, workers, simulations: none may be left.
        self.assertEqual(marked_processes(marker), [])
