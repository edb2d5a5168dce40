"""The accuracy report (docs/accuracy.md) with its stability cells on the runner.

fem_cloth_report computes everything; this only dispatches: it asks the report for the cells of
its selection (--list-cells), runs them as runner tasks of contiguous slices of about equal work
(--cells FIRST:LAST --cell-results FILE, one subprocess with one thread each), and then runs the
report itself, which reads the cells' results back (--from-cell-results) and does the work-precision
study in its own process, alone on the machine, as its timings want (the cluster is shut down by
then).
"""

import argparse
import json
import os
import shutil
import subprocess

from fem_cloth.batch.batch import BatchError
from fem_cloth.batch.command import command_task

# The report's exit statuses that still leave a complete result (4: a cell was non-finite, which
# the report itself says).
REPORT_OK = (0, 4)


def _report_options(args):
    """The report's --out and --study in `args` (the rest passes through as it is)."""
    parser = argparse.ArgumentParser(add_help=False)
    parser.add_argument("--out", default="output/report")
    parser.add_argument("--study", default="all")
    known, rest = parser.parse_known_args(args)
    return known, rest


def slices(weights, count):
    """[first, last) index ranges, in order, of about equal total weight, at most `count` of them."""
    total = sum(weights)
    if not weights:
        return []
    count = max(1, min(count, len(weights)))
    ranges, first, done = [], 0, 0.0
    for i, weight in enumerate(weights):
        done += weight
        # Close a slice once it reaches its share of what is left.
        left = count - len(ranges)
        if left > 1 and done >= total * (len(ranges) + 1) / count and i + 1 < len(weights):
            ranges.append((first, i + 1))
            first = i + 1
    ranges.append((first, len(weights)))
    return ranges


def _cells(report, rest, folder):
    listing = os.path.join(folder, "cells.json")
    done = subprocess.run([report, *rest, "--study", "stability", "--list-cells", listing],
                          capture_output=True, text=True, check=False)
    if done.returncode != 0:
        raise BatchError(done.stderr.strip() or f"fem_cloth_report --list-cells: exit {done.returncode}")
    with open(listing, encoding="utf-8") as f:
        return json.load(f)["cells"]


def run_report(runner, report, args, tasks_per_worker=4, say=print):
    """Runs the stability cells of the report's selection on `runner`; returns the report's
    arguments that make it read their results back (`args` alone without a stability study)."""
    options, rest = _report_options(args)
    if options.study == "work-precision":
        return list(args)
    folder = os.path.join(os.path.abspath(options.out), "stability_cells")
    results = os.path.join(folder, "results")
    shutil.rmtree(folder, ignore_errors=True)
    os.makedirs(os.path.join(folder, "logs"))
    os.makedirs(results)
    cells = _cells(report, rest, folder)
    ranges = slices([c["weight"] for c in cells], tasks_per_worker * runner.workers)
    tasks = []
    for first, last in ranges:
        name = f"{first:05d}-{last:05d}"
        path = os.path.join(results, f"{name}.json")
        tasks.append(command_task(
            f"cells {first}:{last}", [report, *rest, "--study", "stability", "--cells", f"{first}:{last}",
                                      "--cell-results", path, "--quiet"],
            threads=1, log=os.path.join(folder, "logs", f"{name}.log"), summary=path,
            ok_exit_codes=REPORT_OK))
    say(f"report: {len(cells)} stability cells in {len(tasks)} tasks on {runner.describe()}")
    failed = []
    runner.run(tasks, lambda task, result: failed.append((task, result)) if result["status"] != "ok" else None,
               label="stability")
    if failed:
        task, result = failed[0]
        raise BatchError(f"{len(failed)} of {len(tasks)} cell tasks did not run ({task['key']}: "
                         f"{result['error']}; log: {task['log']})")
    return [*args, "--from-cell-results", results]
