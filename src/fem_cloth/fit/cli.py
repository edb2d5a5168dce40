"""fem_cloth_fit: the simulation's parameters fitted to a recording (docs/fitting.md).

  fem_cloth_fit RECORDING.bag --param KEY=LOW:HIGH [--param ...] [--start KEY=VALUE ...]
                --out DIR [--scene BASE.yaml] [--markers TOPIC | --depth TOPIC | --cloud TOPIC]
                [--camera-info TOPIC]
                [--method least_squares]
                [--max-evaluations N] [--profile-points K] [--workers N | --scheduler ADDRESS]
                [--sim PATH] [--node /fem_cloth_node] [--quiet]

Exit status: 0 fitted (the results in --out), 2 a recording, scene or option that cannot be
fitted (one line naming the culprit; also start values that do not simulate), 1 the Dask
cluster could not be started or reached, 130 Ctrl-C.
"""

import argparse
import json
import math
import os
import sys
import time

import numpy as np
import yaml

from fem_cloth.batch.batch import BatchError, check_scene, find_program
from fem_cloth.batch.runner import Runner, RunnerError, default_workers, load_average as _load
from fem_cloth.fit import fit
from fem_cloth.fit.data import NODE, FitError, Recording

PROGRAM = "fem_cloth_fit"


def _say(text):
    print(f"{PROGRAM}: {text}", flush=True)


def _parser():
    parser = argparse.ArgumentParser(
        prog=PROGRAM, description="Fits parameters of a fem_cloth scene to a recording: the "
        "recording's commands re-simulated (fem_cloth_sim --commands) for candidate values, their "
        "simulated observations compared with the recorded ones (docs/fitting.md).")
    parser.add_argument("recording", help="a bag: the commands that drove the cloth (scene, mesh, "
                        "applied pins and forces, tf) and the observations")
    parser.add_argument("--param", action="append", default=[], metavar="KEY=LOW:HIGH",
                        help="a parameter to fit and its bounds (repeatable): a scene key "
                        "(bending.stiffness, damping.mass, material.youngs_modulus, ...) or one of "
                        f"{', '.join(sorted(fit.ALIASES))}")
    parser.add_argument("--start", action="append", default=[], metavar="KEY=VALUE",
                        help="a parameter's start (default: the base scene's value if inside the "
                        "bounds, else the middle of the bounds, geometrically for LOW > 0)")
    parser.add_argument("--out", required=True, metavar="DIR", help="folder for the results")
    parser.add_argument("--scene", metavar="FILE", help="the base scene (default: the recording's own)")
    parser.add_argument("--markers", metavar="TOPIC", help="the marker cloud (PointCloud2 with x, y, z, "
                        "vertex); default: the recording's only observation topic")
    parser.add_argument("--depth", metavar="TOPIC", help="a depth image topic (sensor_msgs/Image 32FC1 "
                        "or 16UC1) from a camera fixed by /tf_static")
    parser.add_argument("--cloud", metavar="TOPIC", help="a point cloud made from a depth camera "
                        "(PointCloud2 x, y, z in the camera's frame, fixed by /tf_static)")
    parser.add_argument("--camera-info", metavar="TOPIC", help="the camera's CameraInfo (default: "
                        "camera_info next to the image or cloud topic)")
    parser.add_argument("--method", choices=fit.METHODS, default="least_squares",
                        help="scipy.optimize method (default least_squares, trust-region reflective)")
    parser.add_argument("--max-evaluations", type=int, default=60, metavar="N",
                        help="at most about N simulated candidates for the optimiser (default 60)")
    parser.add_argument("--profile-points", type=int, default=7, metavar="K",
                        help="the loss at K values of each parameter across its bounds, the others "
                        "at the fit (a slice, plotted); 0: none (default 7)")
    group = parser.add_mutually_exclusive_group()
    group.add_argument("--scheduler", metavar="ADDRESS", help="an existing Dask scheduler")
    group.add_argument("--workers", type=int, metavar="N",
                       help=f"local cluster workers (default: the cores, {default_workers()})")
    parser.add_argument("--sim", metavar="PATH", help="the fem_cloth_sim to run (default: this "
                        "source tree's build, else the sourced workspace, else PATH)")
    parser.add_argument("--timeout", type=float, metavar="S", help="a candidate run taking longer fails")
    parser.add_argument("--node", default=NODE, help=f"the node whose topics the bag holds ({NODE})")
    parser.add_argument("--quiet", "-q", action="store_true", help="no progress lines")
    return parser


def _bag_scene(recording, work):
    """The recording's scene (its ~scene topic) as a file, and as a document."""
    import rosbag
    with rosbag.Bag(recording.path) as bag:
        for _, msg, _ in bag.read_messages(topics=[f"{recording.node}/scene"]):
            path = os.path.join(work, "recorded_scene.yaml")
            with open(path, "w", encoding="utf-8") as f:
                f.write(msg.data)
            return path
    raise FitError(f"the recording '{recording.path}' has no {recording.node}/scene: give the base scene with --scene")


def _read_scene(path):
    try:
        with open(path, encoding="utf-8") as f:
            document = yaml.safe_load(f)
    except (OSError, yaml.YAMLError) as error:
        raise FitError(f"cannot read the scene '{path}': {error}") from None
    return document if isinstance(document, dict) else {}


def _parameters(args, scene):
    if not args.param:
        raise FitError("no parameter to fit: give --param KEY=LOW:HIGH (for example "
                       "--param bending.stiffness=1e-3:1)")
    params = [fit.Parameter(text) for text in args.param]
    keys = [p.key for p in params]
    for key in keys:
        if keys.count(key) > 1:
            raise FitError(f"parameter '{key}' given twice")
    by_name = {}
    for p in params:
        by_name[p.name] = by_name[p.key] = p
        p.default_start(fit.scene_value(scene, p.key))
    for text in args.start:
        name, sep, value = text.partition("=")
        if name not in by_name:
            raise FitError(f"--start {text}: '{name}' is not a parameter given with --param")
        try:
            number = float(value)
        except ValueError:
            raise FitError(f"--start {text}: '{value}' is not a number") from None
        by_name[name].set_start(number, "--start")
    return params


def _fmt(value):
    return f"{value:.4g}"


def _profile(problem, u_best, points, say):
    """The loss along each parameter across its bounds, the others at the fit (a slice of the loss,
    not a profile that re-fits the others)."""
    if points < 2:
        return []
    grid, per_param = [], []
    for j, param in enumerate(problem.params):
        low, high = param.u_bounds()
        values = np.linspace(low, high, points)
        per_param.append(values)
        for v in values:
            u = np.array(u_best, dtype=float)
            u[j] = v
            grid.append(u)
    say(f"loss slices: {len(grid)} candidates ({points} per parameter)")
    residuals = problem.evaluate(grid)
    out, k = [], 0
    for j, param in enumerate(problem.params):
        losses = [problem.loss_of(residuals[k + i]) for i in range(points)]
        k += points
        out.append({"values": [param.from_u(v) for v in per_param[j]], "loss_m": losses})
    return out


def _plot_markers(ax, problem, u_start, u_best):
    """The heights of the three markers that move most: observed, simulated at start and fit."""
    obs = problem.observations
    before = problem.simulated_positions(u_start)
    after = problem.simulated_positions(u_best)
    seconds = (obs.stamps - obs.stamps[0]) / 1e9
    # The markers seen in every frame; the three that move most.
    common = set(obs.vertices[0].tolist())
    for v in obs.vertices[1:]:
        common &= set(v.tolist())
    chosen = sorted(common)
    motion = {v: np.ptp([p[list(vs).index(v), 2] for vs, p in zip(obs.vertices, obs.points)]) for v in chosen}
    chosen = sorted(chosen, key=lambda v: -motion[v])[:3]
    for c, v in enumerate(chosen):
        z_obs = [p[list(vs).index(v), 2] for vs, p in zip(obs.vertices, obs.points)]
        ax.plot(seconds, z_obs, ".", color=f"C{c}", ms=3, label=f"vertex {v}: observed")
        if before is not None:
            ax.plot(seconds, [s[v, 2] for s in before], ":", color=f"C{c}", label="simulated, start")
        if after is not None:
            ax.plot(seconds, [s[v, 2] for s in after], "-", color=f"C{c}", label="simulated, fitted")
    ax.set_xlabel("time since the first observation (s)")
    ax.set_ylabel("marker height z (m, simulation frame)")
    ax.set_title("observed against simulated")
    ax.legend(fontsize=7, ncol=3)


def _plot_depth(ax, problem, u_start, u_best):
    """Per frame, the RMS robust distance of the observed points to the simulated visible surface."""
    obs = problem.observations
    seconds = (obs.stamps - obs.stamps[0]) / 1e9
    sizes = np.cumsum([len(p) for p in obs.points])[:-1]
    for u, style, label in ((u_start, ":", "simulated, start"), (u_best, "-", "simulated, fitted")):
        frames = np.split(problem.evaluate([u])[0], sizes)
        ax.plot(seconds, [np.sqrt(np.mean(f * f)) if len(f) else np.nan for f in frames], style, label=label)
    ax.set_xlabel("time since the first observation (s)")
    ax.set_ylabel("RMS point-to-surface distance (m)")
    ax.set_title(f"observed depth points against the simulated surface ({obs.topic})", fontsize=9)
    ax.legend()


def _plots(out, problem, report, u_start, u_best, slices):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    evaluations = [h[0] for h in problem.history]
    losses = [h[2] for h in problem.history]
    fig, ax = plt.subplots(figsize=(7, 4))
    ax.semilogy(evaluations, losses, ".", color="0.5", label="every candidate")
    best = np.minimum.accumulate(losses)
    ax.semilogy(evaluations, best, "-", color="C0", label="best so far")
    ax.set_xlabel("candidate (simulation run)")
    ax.set_ylabel(problem.observations.loss_name)
    ax.set_title(f"fem_cloth_fit: loss ({report['method']})")
    ax.legend()
    fig.tight_layout()
    fig.savefig(os.path.join(out, "loss.png"), dpi=100)
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(7, 4.5))
    if problem.observations.kind == "markers":
        _plot_markers(ax, problem, u_start, u_best)
    else:
        _plot_depth(ax, problem, u_start, u_best)
    fig.tight_layout()
    fig.savefig(os.path.join(out, "observed_vs_simulated.png"), dpi=100)
    plt.close(fig)

    if slices:
        fig, axes = plt.subplots(1, len(slices), figsize=(4 * len(slices), 3.5), squeeze=False)
        for ax, param, line, entry in zip(axes[0], problem.params, slices, report["parameters"]):
            ax.plot(line["values"], line["loss_m"], "o-", label="the others at the fit")
            ax.plot([entry["fitted"]], [report["loss_after"]], "*", color="C1", ms=12, label="the fit")
            if param.log:
                ax.set_xscale("log")
            ax.set_yscale("log")
            ax.set_xlabel(param.key)
            ax.set_title(entry["verdict"], fontsize=9)
        axes[0][0].set_ylabel(problem.observations.loss_name)
        axes[0][0].legend(fontsize=8)
        fig.tight_layout()
        fig.savefig(os.path.join(out, "loss_slices.png"), dpi=100)
        plt.close(fig)


def run(args):
    out = os.path.abspath(args.out)
    os.makedirs(out, exist_ok=True)
    work = os.path.join(out, "candidates")
    fit.clean(work)
    os.makedirs(work)
    try:
        sim = find_program("fem_cloth_sim", args.sim)
    except BatchError as error:
        raise FitError(str(error)) from None
    given = [o for o in ("markers", "depth", "cloud") if getattr(args, o)]
    if len(given) > 1:
        raise FitError(f"one kind of observation at a time: --{' and --'.join(given)} given")
    recording = Recording(args.recording, args.node, markers=args.markers, depth=args.depth,
                          camera_info=args.camera_info, cloud=args.cloud)
    scene_path = os.path.abspath(args.scene) if args.scene else _bag_scene(recording, work)
    params = _parameters(args, _read_scene(scene_path))
    error = check_scene(sim, scene_path, [f"{p.key}={p.start!r}" for p in params])
    if error:
        starts = ", ".join(f"{p.key} = {p.start:g}" + (f" (parameter '{p.name}')" if p.name != p.key else "")
                           for p in params)
        raise FitError(f"the base scene with the start values ({starts}): {error}")
    for p in params:
        for bound in (p.low, p.high):
            error = check_scene(sim, scene_path, [f"{p.key}={bound!r}"])
            if error:
                raise FitError(f"parameter '{p.name}': bound {bound:g}: {error}")
    obs = recording.observations
    say = (lambda text: None) if args.quiet else _say
    say(f"{recording.path}: {len(obs)} frames, {obs.count()} observed points on {obs.topic}; fitting "
        f"{', '.join(p.key for p in params)} by {args.method}")
    started = time.monotonic()
    with Runner(scheduler=args.scheduler, workers=args.workers, quiet=True) as runner:
        say(f"{runner.describe()} (load average {_load()})")
        problem = fit.Problem(recording, args.scene and scene_path, params, sim, runner, work,
                              timeout=args.timeout, quiet=args.quiet)
        problem.simulated_positions = lambda u: _positions(problem, u)
        u_start = np.array([p.to_u(p.start) for p in params])
        start_residuals = problem.evaluate([u_start])[0]
        if problem.history[-1][3] != "ok":
            raise FitError(f"the start values do not simulate: {problem.history[-1][3]} "
                           f"(see {os.path.join(work, '000001', 'log.txt')})")
        loss_before = problem.loss_of(start_residuals)
        say(f"start: {', '.join(f'{p.key} {_fmt(p.start)}' for p in params)}: loss {loss_before:.4g} m")
        u_opt, converged, message = fit.optimise(problem, args.method, args.max_evaluations, say)
        if not converged:
            print(f"{PROGRAM}: warning: {args.method} did not converge ({message}; --max-evaluations "
                  f"{args.max_evaluations}): the values below are the best candidate's, not a minimum's, "
                  f"and their intervals and verdicts assume one", file=sys.stderr, flush=True)
        # The best candidate run, whichever method (an optimiser's last point need not be it).
        best = min(problem.history, key=lambda h: h[2])
        u_best = np.array([p.to_u(v) for p, v in zip(params, best[1])])
        if problem.loss_of(problem.evaluate([u_opt])[0]) <= best[2]:
            u_best = np.asarray(u_opt, dtype=float)
        optimiser_evaluations = problem.evaluations
        jacobian = problem.jacobian(u_best)
        residuals = problem.evaluate([u_best])[0]
        loss_after = problem.loss_of(residuals)
        verdicts, noise = fit.identifiability(problem, u_best, jacobian, residuals)
        report = {"recording": os.path.abspath(recording.path), "observations": obs.topic,
                  "frames": len(obs), "observed_points": obs.count(), "method": args.method,
                  "loss": obs.loss_name, "loss_before": loss_before, "loss_after": loss_after,
                  "candidates": optimiser_evaluations, "workers": runner.workers,
                  "converged": converged, "optimiser_message": str(message),
                  "parameters": []}
        for p, u, v in zip(params, u_best, verdicts):
            fitted = p.from_u(u)
            report["parameters"].append({
                "name": p.name, "key": p.key, "bounds": [p.low, p.high], "start": p.start,
                "fitted": fitted, "interval95": list(v["interval"]),
                "effect_of_change_m": v["effect_m"],
                "change": "value doubled" if p.log else "a tenth of the bounds",
                "verdict": v["verdict"],
                "in_scene": p.start if v["verdict"].startswith("not identifiable") else fitted})
        slices = _profile(problem, u_best, args.profile_points, say)
        report["candidates_total"] = problem.evaluations
        report["wall_s"] = time.monotonic() - started
        report["load_average"] = _load()
        _plots(out, problem, report, u_start, u_best, slices)
    _write(out, report, scene_path, sim, params, slices)
    _summary(report, say if not args.quiet else print, noise)
    fit.clean(work)
    return 0


def _positions(problem, u):
    """The simulated positions at the observed frames for u (one more run; for the plot)."""
    task = problem._task(0, problem.values(u))
    results = {}
    problem.runner.run([task], lambda t, r: results.__setitem__("r", r), retries=0, label="fit")
    bag = os.path.join(problem.work, "000000", "run.bag")
    if results["r"]["status"] != "ok" or not os.path.isfile(bag):
        return None
    states = problem.simulated(bag)
    return [states[s] for s in problem.observations.stamps]


def _write(out, report, scene_path, sim, params, slices):
    report["loss_slices"] = [dict(key=p.key, **s) for p, s in zip(params, slices)]
    with open(os.path.join(out, "fit.json"), "w", encoding="utf-8") as f:
        json.dump(report, f, indent=2)
    with open(os.path.join(out, "fit.yaml"), "w", encoding="utf-8") as f:
        yaml.safe_dump({k: v for k, v in report.items() if k != "loss_slices"}, f, sort_keys=False)
    overrides = [f"{e['key']}={e['in_scene']!r}" for e in report["parameters"]]
    error = check_scene(sim, scene_path, overrides, write=os.path.join(out, "scene.yaml"))
    if error:
        raise FitError(f"cannot write the fitted scene: {error}")


def _summary(report, say, noise):
    say(f"loss ({report['loss'].replace(' (m)', '')}): {report['loss_before']:.4g} m before, {report['loss_after']:.4g} m "
        f"after; {report['candidates_total']} candidate runs in {report['wall_s']:.0f} s on "
        f"{report['workers']} workers (load average {report['load_average']})")
    for e in report["parameters"]:
        low, high = e["interval95"]
        kept = " (the scene keeps the start value)" if e["in_scene"] != e["fitted"] else ""
        say(f"{e['key']}: {_fmt(e['fitted'])} (start {_fmt(e['start'])}; 95 % interval {_fmt(low)} to "
            f"{_fmt(high)}; {e['change']} moves the observed points by {e['effect_of_change_m']:.2g} m RMS, "
            f"residual {noise:.2g} m): {e['verdict']}{kept}")


def main(argv=None):
    args = _parser().parse_args(argv)
    for option, value, ok, wanted in (("--max-evaluations", args.max_evaluations, lambda v: v >= 1, ">= 1"),
                                      ("--workers", args.workers, lambda v: v >= 1, ">= 1"),
                                      ("--profile-points", args.profile_points, lambda v: v >= 0, ">= 0"),
                                      ("--timeout", args.timeout, lambda v: v > 0, "above 0 s")):
        if value is not None and not ok(value):
            print(f"{PROGRAM}: {option} must be {wanted}, got {value}", file=sys.stderr)
            return 2
    try:
        return run(args)
    except FitError as error:
        print(f"{PROGRAM}: {error}", file=sys.stderr)
        return 2
    except OSError as error:  # the results folder: not a folder, not writable
        print(f"{PROGRAM}: cannot write the results to '{args.out}': {error.strerror}", file=sys.stderr)
        return 2
    except RunnerError as error:
        print(f"{PROGRAM}: {error}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print(f"{PROGRAM}: interrupted", file=sys.stderr)
        return 130
