"""One task of a batch, as a Dask worker runs it: a program (fem_cloth_sim, fem_cloth_report) in a
subprocess with a given number of OpenMP threads, its output kept in a log, its JSON summary read
back. Standard library only: the runner ships this module to the workers by value, so a worker
needs Python, Dask and the program, not fem_cloth's Python package.
"""

import ctypes
import json
import os
import resource
import shutil
import signal
import socket
import subprocess
import time

# fem_cloth's exit statuses (fem_cloth_sim --help): anything else is an error of the run itself
# (a signal, a timeout, a program that could not start).
EXIT_STATUS = {0: "ok", 2: "bad_input", 3: "failed"}


def command_task(key, argv, threads=1, timeout=None, log=None, summary=None, remove_after=(),
                 ok_exit_codes=(0,)):
    """What to run, as a plain dict (Dask pickles task arguments by reference to their class,
    which a worker without this package could not load). `summary`: a JSON file the program
    writes, read back into the result; `remove_after`: files the run leaves that nobody keeps
    (verify's re-run outputs); `ok_exit_codes`: the exit statuses that count as done (the report's
    4, a non-finite cell, is a result to report, not a failed run)."""
    return {"key": key, "argv": list(argv), "threads": threads, "timeout": timeout, "log": log,
            "summary": summary, "remove_after": list(remove_after), "ok_exit_codes": list(ok_exit_codes)}


def _die_with_parent():
    """In the child: SIGTERM when the worker that started it dies (Linux prctl PR_SET_PDEATHSIG),
    so a stopped batch leaves no simulation running."""
    try:
        ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGTERM)
    except (OSError, AttributeError):
        pass


def _worker_name():
    try:
        from distributed import get_worker
        return get_worker().address
    except (ImportError, ValueError):
        return f"{socket.gethostname()}:{os.getpid()}"


def _error_line(stderr, code):
    lines = [line for line in stderr.splitlines() if line.strip() and "warning:" not in line]
    if lines:
        return lines[-1].strip()
    return f"exit status {code}" if code >= 0 else f"killed by signal {-code}"


def run_command(task):
    """Runs the task; returns a dict: key, status (ok, bad_input, failed, error), exit_code,
    error, wall_s, cpu_s, worker, summary (the JSON the program wrote, or None)."""
    argv, summary, log = task["argv"], task["summary"], task["log"]
    env = dict(os.environ, OMP_NUM_THREADS=str(task["threads"]), OMP_WAIT_POLICY="passive")
    worker = _worker_name()
    result = {"key": task["key"], "status": "error", "exit_code": None, "error": "", "wall_s": None,
              "cpu_s": None, "worker": worker, "summary": None}
    if summary and os.path.exists(summary):
        os.remove(summary)  # a summary from an earlier run must not pass for this one's
    start = time.monotonic()
    # The children's CPU time of this worker process: this run's, as long as the worker runs one
    # task at a time (one thread, as the local cluster's workers and docs/batch.md's do).
    cpu_before = resource.getrusage(resource.RUSAGE_CHILDREN)
    try:
        done = subprocess.run(argv, stdin=subprocess.DEVNULL, capture_output=True, text=True, env=env,
                              timeout=task["timeout"], preexec_fn=_die_with_parent, check=False)
        code, stdout, stderr = done.returncode, done.stdout, done.stderr
        result["error"] = "" if code == 0 else _error_line(stderr, code)
    except subprocess.TimeoutExpired as expired:
        code = None
        stdout, stderr = [s.decode(errors="replace") if isinstance(s, bytes) else (s or "")
                          for s in (expired.stdout, expired.stderr)]
        result["error"] = f"timed out after {task['timeout']} s"
    except OSError as error:
        code, stdout, stderr = None, "", ""
        result["error"] = f"cannot run {argv[0]} on {worker}: {error.strerror}"
    result["wall_s"] = wall = time.monotonic() - start
    cpu = resource.getrusage(resource.RUSAGE_CHILDREN)
    result["cpu_s"] = cpu.ru_utime - cpu_before.ru_utime + cpu.ru_stime - cpu_before.ru_stime
    result["exit_code"] = code
    done_ok = code in task["ok_exit_codes"]
    result["status"] = "ok" if done_ok else EXIT_STATUS.get(code, "error")
    if done_ok:
        result["error"] = ""
    if log:
        try:
            with open(log, "w", encoding="utf-8") as f:
                f.write(f"$ {' '.join(argv)}\n# OMP_NUM_THREADS={task['threads']}, worker {worker}, "
                        f"exit {code}, {wall:.3f} s\n{stdout}{stderr}")
        except OSError as error:
            result["status"], result["error"] = "error", f"cannot write the log {log}: {error.strerror}"
    # A finished run must have written its summary; a failed one may have (the state reached).
    if summary and (done_ok or (code == 3 and os.path.exists(summary))):
        try:
            with open(summary, encoding="utf-8") as f:
                result["summary"] = json.load(f)
        except (OSError, ValueError) as error:
            result["status"] = "error"
            result["error"] = f"no summary from {os.path.basename(argv[0])} ({summary}: {error})"
    for path in task["remove_after"]:
        if os.path.isdir(path):
            shutil.rmtree(path, ignore_errors=True)
        elif os.path.lexists(path):
            os.remove(path)
    return result
