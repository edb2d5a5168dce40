"""The runner: command tasks (fem_cloth.batch.command) on Dask distributed, with retries and a
progress line. fem_cloth_batch's episodes and the accuracy report's cells both go through it.

By default it starts a LocalCluster of its own, bound to 127.0.0.1: one worker process per core
with one thread each (every task is a subprocess with OMP_NUM_THREADS set by the task), and shuts
it down when done. With a scheduler address it uses that cluster instead (workers started by hand
with dask-worker; see docs/batch.md) and leaves it running.
"""

import logging
import os
import sys
import tempfile
import time

from fem_cloth.batch import command


class RunnerError(Exception):
    """The cluster could not be started or reached."""


def _lost(task, error):
    """The result of a task that raised instead of returning (a worker that died, or could not
    load the task): as_completed gives (type, exception, traceback)."""
    if isinstance(error, tuple) and len(error) == 3:
        error = error[1]
    return {"key": task["key"], "status": "error", "exit_code": None, "wall_s": None, "cpu_s": None, "worker": "",
            "summary": None, "error": f"the task failed on its worker: {type(error).__name__}: {error}"}


def load_average():
    """The load average (1, 5, 15 min): throughput figures mean little without it."""
    try:
        return " ".join(f"{x:.2f}" for x in os.getloadavg())
    except OSError:
        return "unknown"


def default_workers():
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:
        return os.cpu_count() or 1


class Progress:
    """One line on stderr: done / total, failures, elapsed, rate and ETA (from the rate so far);
    redrawn in place on a terminal, a line every 10 s otherwise."""

    def __init__(self, label, total, enabled=True, stream=sys.stderr):
        self.label, self.total, self.enabled, self.stream = label, total, enabled, stream
        self.tty = enabled and stream.isatty()
        self.start = self.last = time.monotonic()
        self.done = self.failed = 0
        self.dirty = False
        self.shown = None  # (done, failed) of the last line written

    def update(self, done, failed, force=False):
        self.done, self.failed = done, failed
        now = time.monotonic()
        if not self.enabled or (not force and now - self.last < (0.5 if self.tty else 10.0)):
            return
        self.last = now
        wall = now - self.start
        rate = done / wall if wall > 0 else 0.0
        eta = f"ETA {(self.total - done) / rate:.0f} s" if rate > 0 else "ETA ?"
        width = 24
        filled = int(width * done / self.total) if self.total else width
        failures = f", {failed} failed" if failed else ""
        line = (f"{self.label}: [{'#' * filled}{'.' * (width - filled)}] {done}/{self.total}{failures}, "
                f"{wall:.0f} s, {rate:.2f}/s, {eta}")
        self.stream.write(("\r" + line + "   ") if self.tty else line + "\n")
        self.stream.flush()
        self.dirty = self.tty
        self.shown = (done, failed)

    def finish(self):
        if self.shown != (self.done, self.failed):
            self.update(self.done, self.failed, force=True)
        if self.dirty:
            self.stream.write("\n")
            self.dirty = False


class Runner:
    """A Dask client; a context manager that closes what it started."""

    def __init__(self, scheduler=None, workers=None, quiet=False, connect_timeout=30.0):
        self.scheduler, self.quiet, self.connect_timeout = scheduler, quiet, connect_timeout
        self.requested_workers = workers or default_workers()
        self.client = self.cluster = self.scratch = None

    def __enter__(self):
        try:
            import cloudpickle
            import distributed
        except ImportError as error:
            raise RunnerError(f"Dask distributed is not installed ({error}): scripts/install-deps "
                              f"installs python3-distributed") from None
        # The task code travels by value: a worker needs Python, Dask and the programs, not this
        # package on its path.
        cloudpickle.register_pickle_by_value(command)
        logging.getLogger("distributed").setLevel(logging.ERROR)
        try:
            if self.scheduler:
                self.client = distributed.Client(self.scheduler, timeout=self.connect_timeout)
                self.client.wait_for_workers(1, timeout=self.connect_timeout)
            else:
                # Worker scratch space in a folder of its own, not dask-worker-space/ in the cwd.
                self.scratch = tempfile.TemporaryDirectory(prefix="fem_cloth_batch-dask-")
                # Every socket on 127.0.0.1, the HTTP servers of scheduler and workers too (they
                # bind every interface unless told).
                self.cluster = distributed.LocalCluster(
                    n_workers=self.requested_workers, threads_per_worker=1, processes=True,
                    host="127.0.0.1", dashboard_address="127.0.0.1:0",
                    worker_dashboard_address="127.0.0.1:0", silence_logs=logging.ERROR,
                    local_directory=self.scratch.name)
                self.client = distributed.Client(self.cluster)
        except (OSError, TimeoutError) as error:
            self.__exit__(None, None, None)
            where = self.scheduler or "a local cluster"
            raise RunnerError(f"cannot start or reach {where}: {error}") from None
        return self

    def __exit__(self, *exc):
        if self.client is not None:
            self.client.close()
        if self.cluster is not None:
            self.cluster.close()
        if self.scratch is not None:
            self.scratch.cleanup()
        self.client = self.cluster = self.scratch = None
        return False

    @property
    def workers(self):
        return len(self.client.scheduler_info()["workers"])

    def describe(self):
        kind = f"scheduler {self.scheduler}" if self.scheduler else "local cluster on 127.0.0.1"
        return f"{kind}, {self.workers} workers"

    def run(self, tasks, on_result, retries=1, label="batch"):
        """Runs every task. A task that does not end ok runs again, up to `retries` more times
        (wherever the scheduler puts it). on_result(task, result) is called once per task with
        the final result, to which it adds attempts and earlier_errors. Returns the results."""
        from distributed import as_completed

        progress = Progress(label, len(tasks), enabled=not self.quiet)
        by_future, attempts, errors, results = {}, {}, {}, []
        pending = as_completed(with_results=True, raise_errors=False)
        for task in tasks:
            future = self.client.submit(command.run_command, task, pure=False)
            by_future[future.key], attempts[task["key"]], errors[task["key"]] = task, 1, []
            pending.add(future)
        failed = 0
        try:
            for future, result in pending:
                task = by_future.pop(future.key)
                if future.status != "finished":  # raised, or cancelled with a lost scheduler
                    result = _lost(task, result)
                del future
                key = task["key"]
                if result["status"] != "ok" and attempts[key] <= retries:
                    errors[key].append(result["error"])
                    attempts[key] += 1
                    retry = self.client.submit(command.run_command, task, pure=False)
                    by_future[retry.key] = task
                    pending.add(retry)
                    continue
                result["attempts"] = attempts[key]
                result["earlier_errors"] = errors[key]
                failed += result["status"] != "ok"
                results.append(result)
                on_result(task, result)
                progress.update(len(results), failed)
        except KeyboardInterrupt:
            self.client.cancel(list(pending.futures))
            raise
        finally:
            progress.finish()
        return results
