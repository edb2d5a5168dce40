"""fem_cloth_batch's work (docs/batch.md): the episodes' scene files, the index, resuming, running
on the runner, and verifying that episodes re-run to the same state.

The batch folder holds batch.json (what the batch was made from), index.csv (one row per episode)
and episodes/NNNNNN/ (scene.yaml, summary.json, log.txt and the outputs: episode.bag, or
trajectory.csv and energy.csv). Every path in the index is relative to the batch folder.
"""

import concurrent.futures
import contextlib
import csv
import fcntl
import hashlib
import json
import os
import random
import re
import shutil
import subprocess
import time

from fem_cloth.batch.command import command_task
from fem_cloth.batch.spec import SpecError

INDEX = "index.csv"
MANIFEST = "batch.json"
STATUSES = ("ok", "bad_input", "failed", "error")
# Index columns after the parameters: how the episode ended, then what fem_cloth_sim's summary
# says about its final state (SI units: s, J; stretch l/L - 1).
RESULT_COLUMNS = ["status", "exit_code", "attempts", "error", "wall_s", "cpu_s", "worker", "steps",
                  "simulated_s", "sim_wall_s", "kinetic_j", "strain_j", "bending_j", "gravity_j",
                  "total_j", "external_work_j", "pin_work_j", "contact_work_j", "air_work_j",
                  "live_work_j", "dissipated_j", "balance_error_j",
                  "stretch_mean", "stretch_max", "stretch_max_run", "min_area_ratio", "state_hash",
                  "scene", "output", "scene_sha256"]
_SUMMARY_FIELDS = {"steps": ("steps",), "simulated_s": ("simulated_s",), "sim_wall_s": ("wall_s",),
                   "stretch_mean": ("stretch", "mean"), "stretch_max": ("stretch", "max"),
                   "stretch_max_run": ("stretch", "max_over_run"),
                   "min_area_ratio": ("min_area_ratio",), "state_hash": ("state_hash",)}
for _energy in ("kinetic", "strain", "bending", "gravity", "total", "external_work", "pin_work",
                "contact_work", "air_work", "live_work", "dissipated", "balance_error"):
    _SUMMARY_FIELDS[f"{_energy}_j"] = ("energy", _energy)
_ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))))


class BatchError(Exception):
    """The batch cannot go on (a bad index, a missing program); the message says why."""


def find_program(name, explicit=None):
    """An absolute path to one of fem_cloth's programs: `explicit`, else the build folder of the
    source tree this module is in ($FEM_CLOTH_BUILD or catkin_build), else the sourced catkin
    workspaces, else PATH."""
    if explicit:
        path = shutil.which(explicit) if os.sep not in explicit else explicit
        if not path or not os.access(path, os.X_OK):
            raise BatchError(f"'{explicit}' is not an executable program")
        return os.path.abspath(path)
    build = os.environ.get("FEM_CLOTH_BUILD") or os.path.join(_ROOT, "catkin_build")
    candidates = [os.path.join(build, "devel", "lib", "fem_cloth", name)]
    try:
        from catkin.find_in_workspaces import find_in_workspaces
        candidates += find_in_workspaces(search_dirs=["libexec"], project="fem_cloth", path=name)
    except ImportError:
        pass
    candidates.append(shutil.which(name) or "")
    for path in candidates:
        if path and os.path.isfile(path) and os.access(path, os.X_OK):
            return os.path.abspath(path)
    raise BatchError(f"cannot find {name}: build fem_cloth (scripts/test builds it) or give --sim")


def sha256_file(path):
    digest = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def program_files(path):
    """A program and the fem_cloth libraries it loads (ldd): the physics lives in
    libfem_cloth_core.so, so a change there leaves the executable's own bytes alone."""
    try:
        listing = subprocess.run(["ldd", path], capture_output=True, text=True, check=False).stdout
    except OSError:
        listing = ""
    return [path] + sorted(set(re.findall(r"libfem_cloth\S*\.so\S* => (/\S+)", listing)))


def program_sha256(path):
    """What resuming and verify compare: a changed program or library may change every result."""
    return hashlib.sha256("".join(sha256_file(f) for f in program_files(path)).encode()).hexdigest()


def _number(value):
    if value is None:
        return ""
    return repr(value) if isinstance(value, float) else str(value)


def _rounded(seconds):
    return _number(round(seconds, 4) if seconds is not None else None)


def _field(summary, path):
    for part in path:
        if not isinstance(summary, dict) or part not in summary:
            return None
        summary = summary[part]
    return summary


def read_index(path):
    """The index's rows by episode number; a row cut short (a killed run) is left out."""
    rows = {}
    with open(path, newline="", encoding="utf-8") as f:
        reader = csv.DictReader(f)
        for row in reader:
            if None in row or any(v is None for v in row.values()) or row.get("status") not in STATUSES:
                continue
            try:
                rows[int(row["episode"])] = row
            except ValueError:
                continue
    return rows


def write_csv(path, columns, rows):
    """Written to PATH.partial and renamed: an index under the final name is always whole."""
    partial = path + ".partial"
    with open(partial, "w", newline="", encoding="utf-8") as f:
        writer = csv.DictWriter(f, fieldnames=columns, extrasaction="ignore")
        writer.writeheader()
        writer.writerows(rows)
    os.replace(partial, path)


class EpisodeFiles:
    """Where an episode's files live, and the fem_cloth_sim command that runs it."""

    def __init__(self, folder, output):
        self.folder, self.output = folder, output
        self.scene = os.path.join(folder, "scene.yaml")
        self.summary = os.path.join(folder, "summary.json")
        self.log = os.path.join(folder, "log.txt")
        self.outputs = {"bag": [os.path.join(folder, "episode.bag")],
                        "csv": [os.path.join(folder, "trajectory.csv"), os.path.join(folder, "energy.csv")],
                        "none": []}[output]

    def out_arguments(self):
        if self.output == "none":
            return ["--no-output"]
        return ["--out", self.outputs[0] if self.output == "bag" else self.folder]

    def command(self, sim, scene, every, commands=None):
        argv = [sim] + (["--commands", commands] if commands else [])
        argv += ["--scene", scene, "--quiet", "--summary-json", self.summary] + self.out_arguments()
        return argv + (["--every", str(every)] if every else [])

    def complete(self):
        return all(os.path.isfile(p) for p in [self.scene, self.summary] + self.outputs)


@contextlib.contextmanager
def locked(folder):
    """One fem_cloth_batch at a time in a batch folder (two would write the same files)."""
    os.makedirs(folder, exist_ok=True)
    with open(os.path.join(folder, ".lock"), "w") as lock:
        try:
            fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            raise BatchError(f"another fem_cloth_batch is working in {folder}") from None
        yield


def check_scene(sim, base, overrides, write=None):
    """fem_cloth_sim --check (and --write-scene): None if the scene is valid, else the error."""
    argv = [sim, "--scene", base, "--check"] + [a for o in overrides for a in ("--set", o)]
    argv += ["--write-scene", write] if write else []
    done = subprocess.run(argv, capture_output=True, text=True, check=False,
                          env=dict(os.environ, OMP_NUM_THREADS="1", OMP_WAIT_POLICY="passive"))
    if done.returncode == 0:
        return None
    lines = [line for line in done.stderr.splitlines() if line.strip()]
    return lines[-1] if lines else f"fem_cloth_sim --check: exit status {done.returncode}"


class Batch:
    """A spec's episodes in a batch folder."""

    def __init__(self, spec, out, sim, say=print):
        self.spec, self.out, self.sim, self.say = spec, os.path.abspath(out), sim, say
        self.index_path = os.path.join(self.out, INDEX)
        self.columns = ["episode", "draw", "seed"] + spec.varied_keys + RESULT_COLUMNS
        self.manifest = {"spec": spec.path, "scene": os.path.abspath(spec.scene),
                         "scene_sha256": sha256_file(spec.scene), "sim": sim,
                         "sim_sha256": program_sha256(sim), "set": spec.fixed_overrides(),
                         "output": spec.output, "every": spec.every, "columns": self.columns,
                         "commands": spec.commands,
                         "commands_sha256": sha256_file(spec.commands) if spec.commands else None}

    def files(self, index):
        return EpisodeFiles(os.path.join(self.out, "episodes", f"{index:06d}"), self.spec.output)

    # -- resuming ---------------------------------------------------------------------------------
    def _earlier_rows(self):
        """Rows of an earlier run of this batch that can stand, or {} with the reason."""
        manifest_path = os.path.join(self.out, MANIFEST)
        if not os.path.isfile(manifest_path) or not os.path.isfile(self.index_path):
            return {}
        try:
            with open(manifest_path, encoding="utf-8") as f:
                earlier = json.load(f)
        except (OSError, ValueError):
            earlier = {}
        changed = [k for k in ("scene_sha256", "sim_sha256", "set", "output", "every", "columns",
                               "commands_sha256")
                   if earlier.get(k) != self.manifest[k]]
        if changed:
            what = {"scene_sha256": "the base scene", "sim_sha256": "fem_cloth_sim (or its libraries)", "set": "set",
                    "output": "output", "every": "every", "columns": "the varied keys",
                    "commands_sha256": "the commands bag"}
            self.say(f"resume: {', '.join(what[k] for k in changed)} changed since {self.index_path} "
                     f"was written: every episode runs again")
            return {}
        return read_index(self.index_path)

    def _done(self, episode, row):
        if row is None or row["status"] != "ok" or row["seed"] != str(episode.seed):
            return False
        if any(row[k] != v for k, v in episode.value_texts().items()):
            return False
        files = self.files(episode.index)
        return files.complete() and sha256_file(files.scene) == row["scene_sha256"]

    # -- scenes -----------------------------------------------------------------------------------
    def _write_scene(self, episode):
        """The episode's scene file (fem_cloth_sim --write-scene, a header of where it comes
        from); None, or the error naming the key."""
        files = self.files(episode.index)
        os.makedirs(files.folder, exist_ok=True)
        error = check_scene(self.sim, self.spec.scene, self.spec.overrides(episode), write=files.scene)
        if error:
            values = ", ".join(f"{k}={v}" for k, v in episode.value_texts().items())
            return f"episode {episode.index}{f' ({values})' if values else ''}: {error}"
        with open(files.scene, encoding="utf-8") as f:
            body = f.read()
        rerun = " ".join(["fem_cloth_sim --scene scene.yaml"] + [
            os.path.relpath(a, files.folder) if a.startswith(files.folder) else a
            for a in files.out_arguments()])
        header = (f"# fem_cloth_batch episode {episode.index} (draw {episode.draw}, seed {episode.seed})"
                  f" of {self.spec.path}\n")
        for key, value in episode.value_texts().items():
            header += f"#   {key}: {value}\n"
        header += f"# Runs alone, from this folder: {rerun}\n"
        with open(files.scene + ".partial", "w", encoding="utf-8") as f:
            f.write(header + body)
        os.replace(files.scene + ".partial", files.scene)
        return None

    def prepare(self, jobs):
        """Draws every episode, keeps what an earlier run finished, writes and checks the scene of
        every other one. Raises SpecError naming the key if any scene is invalid."""
        error = check_scene(self.sim, self.spec.scene, self.spec.fixed_overrides())
        if error:
            raise SpecError(f"{self.spec.path}: scene with set: {error}")
        episodes = self.spec.all_episodes()
        earlier = self._earlier_rows()
        kept = {e.index: earlier[e.index] for e in episodes if self._done(e, earlier.get(e.index))}
        todo = [e for e in episodes if e.index not in kept]
        start = time.monotonic()
        errors = []
        if todo:
            # The first alone: a wrong key shows up once, not once per episode.
            first = self._write_scene(todo[0])
            errors = [first] if first else []
        if todo and not errors:
            with concurrent.futures.ThreadPoolExecutor(max_workers=max(1, jobs)) as pool:
                errors = [e for e in pool.map(self._write_scene, todo[1:]) if e]
        if errors:
            more = f" (and {len(errors) - 1} more episodes)" if len(errors) > 1 else ""
            raise SpecError(f"{self.spec.path}: {errors[0]}{more}")
        self.say(f"scenes: {len(todo)} written and checked in {time.monotonic() - start:.1f} s; "
                 f"{len(kept)} episodes already done (skipped)")
        return episodes, kept, todo

    # -- running ----------------------------------------------------------------------------------
    def _row(self, episode, result):
        files = self.files(episode.index)
        row = {"episode": episode.index, "draw": episode.draw, "seed": episode.seed,
               **episode.value_texts(), "status": result["status"],
               "exit_code": _number(result["exit_code"]), "attempts": result["attempts"],
               "error": " | ".join(dict.fromkeys(result["earlier_errors"] + [result["error"]]))
               if result["status"] != "ok" else "",
               "wall_s": _rounded(result["wall_s"]), "cpu_s": _rounded(result["cpu_s"]),
               "worker": result["worker"],
               "scene": os.path.relpath(files.scene, self.out),
               "output": os.path.relpath(files.outputs[0] if self.spec.output == "bag" else files.folder, self.out)
               if self.spec.output != "none" else "",
               "scene_sha256": sha256_file(files.scene)}
        for column, path in _SUMMARY_FIELDS.items():
            row[column] = _number(_field(result["summary"], path))
        return row

    def run(self, runner, episodes, kept, todo, retries):
        """Runs the episodes in `todo`; the index gets a row per episode as it ends (appended, so
        a stopped batch keeps what finished), and is rewritten in episode order at the end.
        Returns the rows of the episodes that did not end ok."""
        os.makedirs(self.out, exist_ok=True)
        with open(os.path.join(self.out, MANIFEST), "w", encoding="utf-8") as f:
            json.dump(self.manifest, f, indent=2)
        rows = dict(kept)
        write_csv(self.index_path, self.columns, [rows[i] for i in sorted(rows)])
        by_key = {}
        tasks = []
        for episode in todo:
            files = self.files(episode.index)
            task = command_task(f"episode {episode.index}", files.command(self.sim, files.scene, self.spec.every, self.spec.commands),
                                threads=1, timeout=self.spec.timeout, log=files.log, summary=files.summary)
            by_key[task["key"]] = episode
            tasks.append(task)
        with open(self.index_path, "a", newline="", encoding="utf-8") as index:
            writer = csv.DictWriter(index, fieldnames=self.columns, extrasaction="ignore")

            def record(task, result):
                episode = by_key[task["key"]]
                rows[episode.index] = self._row(episode, result)
                writer.writerow(rows[episode.index])
                index.flush()

            try:
                runner.run(tasks, record, retries=retries)
            finally:
                index.flush()
        write_csv(self.index_path, self.columns, [rows[i] for i in sorted(rows)])
        return [rows[i] for i in sorted(rows) if rows[i]["status"] != "ok"]


# -- verify ---------------------------------------------------------------------------------------
VERIFY_COLUMNS = ["episode", "threads", "match", "state_hash", "index_state_hash", "worker",
                  "index_worker", "status", "error"]


def verify(index_path, runner, sample=None, seed=0, threads=(1, 2), sim=None, retries=1, say=print):
    """Re-runs the index's finished episodes (all, or a sample of `sample` drawn with `seed`), each
    once per thread count, in the batch's output mode, and compares the final state hash with the
    index's. Writes verify.csv next to the index; returns (runs, mismatches)."""
    out = os.path.dirname(os.path.abspath(index_path))
    try:
        with open(os.path.join(out, MANIFEST), encoding="utf-8") as f:
            manifest = json.load(f)
        rows = read_index(index_path)
    except (OSError, ValueError) as error:
        raise BatchError(f"cannot read the batch in {out}: {error}") from None
    program = find_program("fem_cloth_sim", sim or manifest.get("sim"))
    if program_sha256(program) != manifest.get("sim_sha256"):
        say(f"verify: note: {program} (or a library it loads) is not the fem_cloth_sim that ran the batch")
    done = [rows[i] for i in sorted(rows) if rows[i]["status"] == "ok"]
    if not done:
        raise BatchError(f"{index_path}: no episode ended ok: nothing to verify")
    if sample is not None and sample < len(done):
        done = sorted(random.Random(seed).sample(done, sample), key=lambda r: int(r["episode"]))
    tasks, expected = [], {}
    for row in done:
        for n in threads:
            files = EpisodeFiles(os.path.join(out, "verify", f"{int(row['episode']):06d}-t{n}"),
                                 manifest["output"])
            os.makedirs(files.folder, exist_ok=True)
            task = command_task(f"episode {row['episode']} threads {n}",
                                files.command(program, os.path.join(out, row["scene"]), manifest.get("every"),
                                              manifest.get("commands")),
                                threads=n, summary=files.summary, remove_after=[files.folder])
            tasks.append(task)
            expected[task["key"]] = (row, n)
    checked = []

    def record(task, result):
        row, n = expected[task["key"]]
        state_hash = _field(result["summary"], ("state_hash",)) or ""
        checked.append({"episode": int(row["episode"]), "threads": n, "state_hash": state_hash,
                        "index_state_hash": row["state_hash"],
                        "match": int(result["status"] == "ok" and state_hash == row["state_hash"]),
                        "worker": result["worker"], "index_worker": row["worker"],
                        "status": result["status"], "error": result["error"]})

    runner.run(tasks, record, retries=retries, label="verify")
    shutil.rmtree(os.path.join(out, "verify"), ignore_errors=True)
    checked.sort(key=lambda r: (r["episode"], r["threads"]))
    write_csv(os.path.join(out, "verify.csv"), VERIFY_COLUMNS, checked)
    return checked, [r for r in checked if not r["match"]]
