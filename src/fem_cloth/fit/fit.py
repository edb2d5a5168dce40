"""The fit (docs/fitting.md): candidate parameter sets simulated by fem_cloth_sim --commands on the
recording's commands, as tasks of the batch runner on Dask (in parallel: a Jacobian's columns, a
population), their simulated observations compared with the observed ones, an optimiser of
scipy.optimize, and how well the data determine each parameter.

Parameters are searched in the logarithm of their value when both bounds are > 0 (stiffnesses,
damping, density: a factor matters, not a difference), else linearly.
"""

import math
import os
import shutil

import numpy as np

from fem_cloth.batch.command import command_task
from fem_cloth.fit.data import FitError

# Names of the issue for the scene keys (docs/scenes.md); any dotted scene key is taken too.
ALIASES = {"stretch_stiffness": "material.youngs_modulus", "youngs_modulus": "material.youngs_modulus",
           "poisson_ratio": "material.poisson_ratio", "bending_stiffness": "bending.stiffness",
           "mass_damping": "damping.mass", "stiffness_damping": "damping.stiffness",
           "density": "material.density", "friction": "obstacles.0.friction"}
METHODS = ("least_squares", "nelder_mead", "differential_evolution")
# The residual of a marker coordinate in a candidate run that failed (m): far worse than any fit.
FAILED_RESIDUAL = 1.0
# Forward-difference step of the Jacobian, in the search coordinate (log value, or the fraction
# of the bounds): 1 % of the value.
JACOBIAN_STEP = 0.01


class Parameter:
    """A parameter to fit: its scene key, bounds and start."""

    def __init__(self, text):
        name, sep, bounds = text.partition("=")
        name = name.strip()
        if not name:
            raise FitError(f"--param '{text}': no parameter name")
        self.name = name
        self.key = ALIASES.get(name, name)
        if not sep or not bounds.strip():
            raise FitError(f"parameter '{name}' has no bounds: give --param {name}=LOW:HIGH "
                           f"(the fit searches only between bounds)")
        parts = bounds.split(":")
        try:
            low, high = (float(p) for p in parts)
        except ValueError:
            raise FitError(f"parameter '{name}': bounds '{bounds}' are not LOW:HIGH (two numbers)") from None
        if not (math.isfinite(low) and math.isfinite(high) and low < high):
            raise FitError(f"parameter '{name}': bounds {low:g}:{high:g} need finite LOW < HIGH")
        self.low, self.high = low, high
        self.log = low > 0
        self.start = None

    def set_start(self, value, where):
        if not (self.low <= value <= self.high):
            raise FitError(f"parameter '{self.name}': start {value:g} ({where}) is outside its bounds "
                           f"{self.low:g}:{self.high:g}")
        self.start = value

    def default_start(self, scene_value):
        """The base scene's value if it is inside the bounds, else the middle of the bounds."""
        if isinstance(scene_value, (int, float)) and self.low <= scene_value <= self.high:
            self.start = float(scene_value)
        else:
            self.start = math.sqrt(self.low * self.high) if self.log else 0.5 * (self.low + self.high)

    # The search coordinate u: log(value), or the fraction of the bounds.
    def to_u(self, value):
        return math.log(value) if self.log else (value - self.low) / (self.high - self.low)

    def from_u(self, u):
        value = math.exp(u) if self.log else self.low + u * (self.high - self.low)
        return min(self.high, max(self.low, value))

    def u_bounds(self):
        return (self.to_u(self.low), self.to_u(self.high))


def scene_value(scene, key):
    """The value of a dotted key in a scene document (None if it has none)."""
    node = scene
    for part in key.split("."):
        if isinstance(node, list) and part.isdigit() and int(part) < len(node):
            node = node[int(part)]
        elif isinstance(node, dict) and part in node:
            node = node[part]
        else:
            return None
    return node


def read_states(bag_path, node, stamps):
    """The simulated positions at the observations' stamps (ns), each interpolated linearly
    between the two states around it: {stamp: (V, 3) array}, and the simulation frame."""
    import rosbag
    times, positions, frame = [], [], ""
    with rosbag.Bag(bag_path) as bag:
        for _, msg, _ in bag.read_messages(topics=[f"{node}/state"]):
            times.append(msg.header.stamp.to_nsec())
            positions.append(np.array([(p.x, p.y, p.z) for p in msg.positions]))
            frame = msg.header.frame_id
    if not times:
        raise FitError(f"the simulated run {bag_path} has no states")
    times = np.array(times, dtype=np.int64)
    out = {}
    for stamp in stamps:
        i = int(np.searchsorted(times, stamp))
        if i < len(times) and times[i] == stamp:
            out[stamp] = positions[i]
        elif 0 < i < len(times):
            w = (stamp - times[i - 1]) / (times[i] - times[i - 1])
            out[stamp] = (1 - w) * positions[i - 1] + w * positions[i]
        else:
            out[stamp] = None  # outside the simulated run
    return out, frame.lstrip("/")


class Problem:
    """The recording, the base scene and the parameters; simulates candidates and scores them."""

    def __init__(self, recording, scene_path, params, sim, runner, work, timeout=None, quiet=False):
        self.recording, self.scene_path, self.params = recording, scene_path, params
        self.sim, self.runner, self.work, self.timeout, self.quiet = sim, runner, work, timeout, quiet
        self.evaluations = 0
        self.history = []  # (evaluation, values, loss)
        self.cache = {}
        self.sim_frame = None
        self.observations = recording.observations

    def values(self, u):
        return [p.from_u(x) for p, x in zip(self.params, u)]

    def _task(self, number, values):
        folder = os.path.join(self.work, f"{number:06d}")
        os.makedirs(folder, exist_ok=True)
        argv = [self.sim, "--commands", self.recording.path, "--node", self.recording.node, "--quiet",
                "--summary-json", os.path.join(folder, "summary.json"), "--out", os.path.join(folder, "run.bag")]
        argv += ["--scene", self.scene_path] if self.scene_path else []
        for param, value in zip(self.params, values):
            argv += ["--set", f"{param.key}={value!r}"]
        return command_task(f"candidate {number}", argv, threads=1, timeout=self.timeout,
                            log=os.path.join(folder, "log.txt"), summary=os.path.join(folder, "summary.json"))

    def evaluate(self, points):
        """Residual vectors of the candidates `points` (search coordinates), run in parallel."""
        keys = [tuple(float(x) for x in u) for u in points]
        todo = []
        for key in keys:
            if key not in self.cache and key not in todo:
                todo.append(key)
        tasks, numbers = [], {}
        for key in todo:
            self.evaluations += 1
            task = self._task(self.evaluations, self.values(key))
            numbers[task["key"]] = (self.evaluations, key)
            tasks.append(task)
        results = {}
        if tasks:
            self.runner.run(tasks, lambda task, result: results.__setitem__(task["key"], result),
                            retries=0, label="fit")
        for task in tasks:
            number, key = numbers[task["key"]]
            result = results[task["key"]]
            residuals = self._score(number, result)
            self.cache[key] = residuals
            self.history.append((number, self.values(key), self.loss_of(residuals), result["status"]))
        return [self.cache[key] for key in keys]

    def _score(self, number, result):
        folder = os.path.join(self.work, f"{number:06d}")
        bag = os.path.join(folder, "run.bag")
        if result["status"] == "bad_input" and number == 1:
            raise FitError(f"fem_cloth_sim refused the first candidate: {result['error']} "
                           f"(log: {os.path.join(folder, 'log.txt')})")
        if result["status"] != "ok" or not os.path.isfile(bag):
            if not self.quiet:
                print(f"fem_cloth_fit: candidate {number} did not run to the end ({result['status']}: "
                      f"{result['error']}): scored as failed", flush=True)
            return np.full(self.observations.count() * self.observations.components, FAILED_RESIDUAL)
        residuals = self.residuals_from(bag)
        os.remove(bag)  # the states are read; candidates would fill the disk
        return residuals

    def simulated(self, bag):
        states, frame = read_states(bag, self.recording.node, self.observations.stamps)
        if self.sim_frame is None:
            self.sim_frame = frame
            obs = self.observations
            vertex_count = len(next(s for s in states.values() if s is not None)) if any(
                s is not None for s in states.values()) else 0
            obs.check_vertices(vertex_count, "the simulated scene")
            for i, stamp in enumerate(obs.stamps):
                if states[stamp] is None:
                    raise FitError(f"{obs.topic} message {i + 1} (stamp {stamp / 1e9:.9f} s) is outside the "
                                   f"simulated run of the recording's commands: the frames do not match the run")
            self.observations = obs.transformed(self.recording.frames, frame)
        return states

    def residuals_from(self, bag):
        states = self.simulated(bag)  # first: the first run places the observations
        return self.observations.residuals(states)

    def loss_of(self, residuals):
        """The loss: the root mean square distance per observed point (m), its components summed."""
        r = residuals.reshape(-1, self.observations.components)
        return float(np.sqrt(np.mean(np.sum(r * r, axis=1))))

    def jacobian(self, u, f=None):
        """Forward differences, every column at once (in parallel); a step that would leave the
        bounds goes the other way."""
        u = np.asarray(u, dtype=float)
        points, steps = [], []
        for j, param in enumerate(self.params):
            low, high = param.u_bounds()
            step = JACOBIAN_STEP if u[j] + JACOBIAN_STEP <= high else -JACOBIAN_STEP
            point = u.copy()
            point[j] = u[j] + step
            points.append(point)
            steps.append(step)
        f0, *columns = self.evaluate([u] + points)
        return np.column_stack([(fj - f0) / h for fj, h in zip(columns, steps)])


def optimise(problem, method, max_evaluations, say):
    """Runs the optimiser; returns the point it ended at (search coordinates), whether it
    converged, and scipy's message."""
    from scipy import optimize
    params = problem.params
    u0 = np.array([p.to_u(p.start) for p in params])
    bounds = [p.u_bounds() for p in params]
    if method == "least_squares":
        lower, upper = np.array(bounds).T
        result = optimize.least_squares(
            lambda u: problem.evaluate([u])[0], u0, jac=problem.jacobian, bounds=(lower, upper),
            method="trf", x_scale=1.0, xtol=1e-3, ftol=1e-6, gtol=1e-8,
            max_nfev=max(1, max_evaluations // (len(params) + 1)))
        return result.x, result.status > 0, result.message

    def loss(u):
        return problem.loss_of(problem.evaluate([u])[0]) ** 2

    if method == "nelder_mead":
        result = optimize.minimize(loss, u0, method="Nelder-Mead", bounds=bounds,
                                   options={"maxfev": max_evaluations, "xatol": 1e-3, "fatol": 1e-12})
        return result.x, bool(result.success), result.message

    def population_map(function, points):
        points = list(points)
        problem.evaluate(points)  # the whole generation at once, in parallel
        return [function(u) for u in points]

    popsize = 5
    result = optimize.differential_evolution(
        loss, bounds, x0=u0, popsize=popsize, seed=0, tol=1e-3, polish=False, updating="deferred",
        workers=population_map, maxiter=max(1, max_evaluations // (popsize * len(params)) - 1))
    return result.x, bool(result.success), result.message


def identifiability(problem, u, jacobian, residuals):
    """For each parameter: the 95 % interval from the Jacobian at the fit (Gauss-Newton
    covariance scaled by the residuals' variance), the effect of a change on what was observed,
    and a verdict. The effect is the RMS change of the simulated observations when the value
    doubles (log parameters) or moves by a tenth of its bounds: below the residual RMS (the
    observation noise and whatever the model misses) the data cannot pin the value down,
    however many frames there are."""
    m, n = jacobian.shape
    components = problem.observations.components
    dof = max(1, m - n)
    s2 = float(residuals @ residuals) / dof
    noise = math.sqrt(s2)
    covariance = s2 * np.linalg.pinv(jacobian.T @ jacobian)
    out = []
    for j, param in enumerate(problem.params):
        value = param.from_u(u[j])
        sigma = math.sqrt(max(0.0, covariance[j, j]))
        change = math.log(2.0) if param.log else 0.1
        # RMS over observed points of the displacement the change causes.
        effect = float(np.linalg.norm(jacobian[:, j]) * change / math.sqrt(m / components))
        if param.log:
            interval = (value * math.exp(-1.96 * sigma), value * math.exp(1.96 * sigma))
        else:
            width = 1.96 * sigma * (param.high - param.low)
            interval = (value - width, value + width)
        spans_bounds = interval[0] <= param.low and interval[1] >= param.high
        relative = (interval[1] - interval[0]) / (2 * value) if value else math.inf
        noise_xyz = noise * math.sqrt(components)  # the RMS distance per point the residuals amount to
        if effect < 0.05 * noise_xyz or spans_bounds:
            verdict = "not identifiable from this recording"
        elif effect < noise_xyz or relative > 0.25:
            verdict = "weakly determined"
        else:
            verdict = "determined"
        low_u, high_u = param.u_bounds()
        for bound_u, side in ((low_u, "lower"), (high_u, "upper")):
            if abs(u[j] - bound_u) <= JACOBIAN_STEP * (1 if param.log else 0.1):
                verdict += f" (at its {side} bound: the data may want a value beyond it)"
        out.append({"effect_m": effect, "interval": interval, "relative_halfwidth": relative,
                    "verdict": verdict})
    return out, noise * math.sqrt(components)


def clean(work):
    shutil.rmtree(work, ignore_errors=True)
