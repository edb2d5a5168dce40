"""fem_cloth_batch: batch runs of randomised scenes on Dask distributed (docs/batch.md).

  fem_cloth_batch [run] SPEC.yaml [--out DIR] [--scheduler tcp://HOST:8786 | --workers N]
                  [--sim PATH] [--retries N] [--dry-run] [--quiet]
  fem_cloth_batch verify DIR/index.csv [--sample N] [--seed S] [--threads 1,2]
                  [--scheduler ADDRESS | --workers N] [--sim PATH] [--quiet]
  fem_cloth_batch report [--scheduler ADDRESS | --workers N] [--report PATH] -- REPORT_ARGS
                  the accuracy report (scripts/report runs this) with its stability cells as tasks

Exit status: 0 every episode ok (verify: every re-run identical), 2 a bad spec, index or command
line, 3 some episodes failed (listed, and in the index), 4 verify found a different state,
1 the cluster could not be started or reached, 128 + N stopped by signal N (130 Ctrl-C).
"""

import argparse
import os
import signal
import subprocess
import sys
import time

from fem_cloth.batch.batch import Batch, BatchError, find_program, locked, verify
from fem_cloth.batch.report import run_report
from fem_cloth.batch.runner import Runner, RunnerError, default_workers, load_average as _load
from fem_cloth.batch.spec import DEFAULT_MAX_EPISODES, Spec, SpecError

PROGRAM = "fem_cloth_batch"


def _say(text):
    print(f"{PROGRAM}: {text}", flush=True)


def _count(n, what):
    return f"{n} {what}{'' if n == 1 else 's'}"


def _cluster_options(parser, sim=True):
    group = parser.add_mutually_exclusive_group()
    group.add_argument("--scheduler", metavar="ADDRESS",
                       help="an existing Dask scheduler (tcp://HOST:8786); default: a local cluster")
    group.add_argument("--workers", type=int, metavar="N",
                       help=f"local cluster workers, one thread each (default: the cores, {default_workers()})")
    if sim:
        parser.add_argument("--sim", metavar="PATH", help="the fem_cloth_sim to run (default: this source "
                            "tree's build, else the sourced workspace, else PATH); workers need it at the same path")
    parser.add_argument("--retries", type=int, default=1, metavar="N",
                        help="runs again a task that did not end ok, up to N more times (default 1)")
    parser.add_argument("--quiet", "-q", action="store_true", help="no progress line")


def _run_parser():
    parser = argparse.ArgumentParser(
        prog=PROGRAM, description="Runs the episodes of a batch spec (docs/batch.md) on Dask "
        "distributed and writes an index of them.",
        epilog=f"Also: {PROGRAM} verify INDEX (re-runs episodes and compares their state hashes) and "
        f"{PROGRAM} report -- REPORT_OPTIONS (the accuracy report's stability cells as tasks); "
        f"see {PROGRAM} verify --help, {PROGRAM} report --help.")
    parser.add_argument("spec", help="the batch spec (YAML)")
    parser.add_argument("--out", metavar="DIR", help="the batch folder (default: "
                        "fem_cloth_output/batch/<spec name>); an earlier run there is resumed")
    parser.add_argument("--dry-run", action="store_true",
                        help="write and check the episodes' scenes, run nothing")
    parser.add_argument("--max-episodes", type=int, default=DEFAULT_MAX_EPISODES, metavar="N",
                        help=f"refuse a spec of more episodes (default {DEFAULT_MAX_EPISODES})")
    _cluster_options(parser)
    return parser


def _verify_parser():
    parser = argparse.ArgumentParser(prog=f"{PROGRAM} verify", description="Re-runs finished "
                                     "episodes of a batch and checks that each ends in the state "
                                     "(hash) its index row records, for every thread count.")
    parser.add_argument("index", help="the batch's index.csv")
    parser.add_argument("--sample", type=int, metavar="N", help="only N episodes, drawn at random")
    parser.add_argument("--seed", type=int, default=0, help="seed of the sample (default 0)")
    parser.add_argument("--threads", default="1,2", metavar="LIST",
                        help="OMP_NUM_THREADS of the re-runs, each episode once per entry (default 1,2)")
    _cluster_options(parser)
    return parser


def _report_parser():
    parser = argparse.ArgumentParser(prog=f"{PROGRAM} report", description="The accuracy report "
                                     "(docs/accuracy.md): fem_cloth_report with its stability cells "
                                     "run as tasks on Dask (scripts/report runs this).")
    parser.add_argument("--report", metavar="PATH", help="the fem_cloth_report to run (default: this source "
                        "tree's build, else the sourced workspace, else PATH)")
    parser.add_argument("--tasks-per-worker", type=int, default=4, metavar="K",
                        help="cut the cells into about K tasks per worker (default 4)")
    _cluster_options(parser, sim=False)
    parser.add_argument("report_args", nargs=argparse.REMAINDER, help="-- then fem_cloth_report's options")
    return parser


def _positive(parser, name, value, minimum=1):
    if value is not None and value < minimum:
        parser.error(f"{name} must be >= {minimum}")


def run_main(argv):
    parser = _run_parser()
    args = parser.parse_args(argv)
    _positive(parser, "--workers", args.workers)
    _positive(parser, "--retries", args.retries, 0)
    _positive(parser, "--max-episodes", args.max_episodes)
    spec = Spec(args.spec, args.max_episodes)
    sim = find_program("fem_cloth_sim", args.sim)
    out = args.out or os.path.join("fem_cloth_output", "batch", os.path.splitext(os.path.basename(spec.path))[0])
    batch = Batch(spec, out, sim, say=_say)
    sweep = f" = {len(spec.points)} sweep points x {spec.episodes} draws" if spec.sweep else ""
    _say(f"{args.spec}: {_count(len(spec), 'episode')}{sweep}, {len(spec.random)} random and {len(spec.sweep)} "
         f"swept keys, output {spec.output}, in {batch.out}")
    with locked(batch.out):
        episodes, kept, todo = batch.prepare(args.workers or default_workers())
        if args.dry_run or not todo:
            _say(f"index: {batch.index_path}" if not todo and kept else "dry run: nothing ran")
            return 0
        start = time.monotonic()
        with Runner(args.scheduler, args.workers, quiet=args.quiet) as runner:
            _say(f"{runner.describe()} (ready in {time.monotonic() - start:.1f} s; load average "
                 f"{_load()})")
            run_start = time.monotonic()
            bad = batch.run(runner, episodes, kept, todo, args.retries)
            wall = time.monotonic() - run_start
            workers = runner.workers
    ran = len(todo)
    _say(f"{len(episodes)} episodes: {len(episodes) - len(bad)} ok, {len(bad)} not ok; {ran} ran in "
         f"{wall:.1f} s on {workers} workers ({ran / wall:.2f} episodes/s), {len(kept)} skipped "
         f"(done before)")
    for row in bad[:20]:
        _say(f"  episode {row['episode']}: {row['status']} (exit {row['exit_code'] or '-'}, "
             f"{row['attempts']} attempts): {row['error']}")
    if len(bad) > 20:
        _say(f"  ... and {len(bad) - 20} more (status column of the index)")
    _say(f"index: {batch.index_path} (load average {_load()})")
    return 3 if bad else 0


def verify_main(argv):
    parser = _verify_parser()
    args = parser.parse_args(argv)
    _positive(parser, "--workers", args.workers)
    _positive(parser, "--sample", args.sample)
    _positive(parser, "--retries", args.retries, 0)
    try:
        threads = [int(t) for t in args.threads.split(",") if t.strip()]
    except ValueError:
        threads = []
    if not threads or min(threads) < 1:
        parser.error(f"--threads must be a comma-separated list of thread counts >= 1, got '{args.threads}'")
    with locked(os.path.dirname(os.path.abspath(args.index))), \
            Runner(args.scheduler, args.workers, quiet=args.quiet) as runner:
        _say(runner.describe())
        checked, mismatches = verify(args.index, runner, args.sample, args.seed, threads, args.sim,
                                     args.retries, say=_say)
    episodes = len({r["episode"] for r in checked})
    workers = len({r["worker"] for r in checked})
    _say(f"verify: {episodes} episodes x threads {','.join(map(str, threads))}: {len(checked)} runs "
         f"on {workers} workers, {len(checked) - len(mismatches)} ended in the state their index "
         f"row records")
    for r in mismatches[:20]:
        why = r["error"] or f"state {r['state_hash']}, index {r['index_state_hash']}"
        _say(f"  episode {r['episode']} threads {r['threads']} ({r['worker']}): {why}")
    _say(f"details: {os.path.join(os.path.dirname(os.path.abspath(args.index)), 'verify.csv')}")
    if not checked:
        _say("verify: the index has no finished episode to re-run")
        return 4
    return 4 if mismatches else 0


class _Stopped(KeyboardInterrupt):
    def __init__(self, signum):
        super().__init__(signum)
        self.signum = signum


def _stop(signum, frame):
    raise _Stopped(signum)


def report_main(argv):
    parser = _report_parser()
    args = parser.parse_args(argv)
    _positive(parser, "--workers", args.workers)
    _positive(parser, "--tasks-per-worker", args.tasks_per_worker)
    report_args = args.report_args[1:] if args.report_args[:1] == ["--"] else args.report_args
    report = find_program("fem_cloth_report", args.report)
    with Runner(args.scheduler, args.workers, quiet=args.quiet) as runner:
        final = run_report(runner, report, report_args, args.tasks_per_worker, say=_say)
    # The report itself, with the cluster gone: its work-precision timings run alone.
    return subprocess.run([report, *final], check=False).returncode


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    # SIGTERM (a job scheduler's, kill's) stops the batch as Ctrl-C does: the cluster is shut
    # down, the simulations stop with their workers, the index keeps what finished.
    signal.signal(signal.SIGTERM, _stop)
    try:
        if argv and argv[0] == "verify":
            return verify_main(argv[1:])
        if argv and argv[0] == "report":
            return report_main(argv[1:])
        return run_main(argv[1:] if argv and argv[0] == "run" else argv)
    except (SpecError, BatchError) as error:
        print(f"{PROGRAM}: {error}", file=sys.stderr)
        return 2
    except RunnerError as error:
        print(f"{PROGRAM}: {error}", file=sys.stderr)
        return 1
    except KeyboardInterrupt as stop:
        signum = stop.signum if isinstance(stop, _Stopped) else signal.SIGINT
        print(f"\n{PROGRAM}: stopped by {signal.Signals(signum).name}; the same command resumes",
              file=sys.stderr)
        return 128 + signum
