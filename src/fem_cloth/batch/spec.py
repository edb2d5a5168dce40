"""The batch spec (docs/batch.md): a base scene, overrides for every episode, sweeps, random draws
and the outputs.

A spec is checked completely before anything runs; every error names its key. Drawing is
deterministic and uses nothing but Python's Mersenne Twister `random()`, whose sequence for a given
integer seed Python guarantees across versions: draw r of key k has a stream of its own, seeded
from (seed, r, k), so adding, removing or reordering keys leaves the other keys' values alone, and
every sweep point sees the same draws (common random numbers: sweep points differ only in the
swept values).
"""

import hashlib
import itertools
import json
import math
import os
import random
import re

import yaml

KNOWN_KEYS = ("scene", "episodes", "seed", "set", "sweep", "random", "output", "every", "timeout", "commands")
OUTPUTS = ("bag", "csv", "none")
DISTRIBUTIONS = ("uniform", "loguniform", "normal", "integer", "choice")
SWEEP_FORMS = ("linspace", "logspace", "range")
# A scene key path as fem_cloth_sim --set takes it: words and list indices joined by dots.
_KEY = re.compile(r"^[A-Za-z0-9_]+(\.[A-Za-z0-9_]+)*$")
_WORD = re.compile(r"^[A-Za-z_][A-Za-z0-9_./-]*$")
_YAML_WORDS = {"true", "false", "yes", "no", "on", "off", "null", "y", "n", "~"}


class SpecError(Exception):
    """A spec that cannot run; the message names the key."""


class _StrictLoader(yaml.SafeLoader):
    """YAML as the scenes read it: a key given twice is an error, and 1e7 is a number (YAML 1.2;
    PyYAML's YAML 1.1 wants a dot, and would read it as the text '1e7')."""

    def construct_mapping(self, node, deep=False):
        seen = set()
        for key_node, _ in node.value:
            key = self.construct_object(key_node, deep=True)
            if not isinstance(key, (str, int, float, bool)) or key is None:
                raise SpecError(f"line {key_node.start_mark.line + 1}: a key must be a word")
            if key in seen:
                raise SpecError(f"line {key_node.start_mark.line + 1}: key '{key}' given twice")
            seen.add(key)
        return super().construct_mapping(node, deep=deep)


_StrictLoader.add_constructor(
    "tag:yaml.org,2002:map",
    lambda loader, node: loader.construct_mapping(node, deep=True))
_StrictLoader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?(?:[0-9][0-9_]*(?:\.[0-9_]*)?|\.[0-9_]+)[eE][-+]?[0-9]+$"),
    list("-+0123456789."))


def load_yaml_text(text, what):
    try:
        return yaml.load(text, Loader=_StrictLoader)
    except SpecError as error:
        raise SpecError(f"{what}: {error}") from None
    except yaml.YAMLError as error:
        mark = getattr(error, "problem_mark", None)
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark else ""
        problem = getattr(error, "problem", None) or str(error)
        raise SpecError(f"{what}: malformed YAML{where}: {problem}") from None


def yaml_text(value):
    """A value as the YAML text of a `--set key=value` and of the index: exact (floats by repr,
    which reads back to the same double), flow style, JSON where a plain word would not do."""
    if isinstance(value, str) and _WORD.match(value) and value.lower() not in _YAML_WORDS:
        return value
    if isinstance(value, list):
        return "[" + ", ".join(yaml_text(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k}: {yaml_text(v)}" for k, v in value.items()) + "}"
    return json.dumps(value)


def _is_number(value):
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def _numbers(where, value, count, kind="numbers"):
    if not isinstance(value, list) or len(value) != count or not all(_is_number(v) for v in value):
        raise SpecError(f"{where} needs a list of {count} finite {kind}, got {yaml_text(value)}")
    return value


def _stream(seed, draw, key):
    """The random stream of one key in one draw (see the module's docstring)."""
    digest = hashlib.sha256(f"fem_cloth_batch/{seed}/{draw}/{key}".encode()).digest()
    return random.Random(int.from_bytes(digest[:8], "big"))


def draw_seed(seed, draw):
    """The seed the index records for a draw: what its keys' streams derive from."""
    digest = hashlib.sha256(f"fem_cloth_batch/{seed}/{draw}".encode()).digest()
    return int.from_bytes(digest[:8], "big")


# ------------------------------------------------------------------------------------------------
# Distributions: checked once (check_*), drawn per episode (draw_*) from random() alone.
# ------------------------------------------------------------------------------------------------
def _check_uniform(where, args):
    low, high = _numbers(where, args, 2)
    if low > high:
        raise SpecError(f"{where}: low {low} is above high {high}")


def _check_loguniform(where, args):
    low, high = _numbers(where, args, 2)
    if not 0 < low <= high:
        raise SpecError(f"{where} needs 0 < low <= high, got [{low}, {high}]")


def _check_normal(where, args):
    if not isinstance(args, dict) or not {"mean", "std"} <= set(args) or \
            not set(args) <= {"mean", "std", "min", "max"}:
        raise SpecError(f"{where} needs {{mean, std}} and optionally min, max (a truncated normal), "
                        f"got {yaml_text(args)}")
    for name, value in args.items():
        if not _is_number(value):
            raise SpecError(f"{where}: {name} must be a finite number, got {yaml_text(value)}")
    if args["std"] < 0:
        raise SpecError(f"{where}: std must be >= 0, got {args['std']}")
    low, high = args.get("min", -math.inf), args.get("max", math.inf)
    if low >= high:
        raise SpecError(f"{where}: min {low} must be below max {high}")
    # Truncation by rejection: refuse a window so far out that rejection would not end.
    z = [(b - args["mean"]) / args["std"] if args["std"] > 0 else math.copysign(math.inf, b - args["mean"])
         for b in (low, high)]
    mass = 0.5 * (math.erf(z[1] / math.sqrt(2)) - math.erf(z[0] / math.sqrt(2)))
    if not mass >= 1e-3:
        raise SpecError(f"{where}: [min, max] holds only {mass:.2g} of the distribution (at least 1e-3)")


def _check_integer(where, args):
    low, high = _numbers(where, args, 2, "integers")
    if not all(isinstance(v, int) for v in (low, high)) or low > high:
        raise SpecError(f"{where} needs integers low <= high, got {yaml_text(args)}")


def _choice_parts(args):
    if isinstance(args, dict):
        return args.get("values"), args.get("weights")
    return args, None


def _check_choice(where, args):
    if isinstance(args, dict) and not set(args) <= {"values", "weights"}:
        raise SpecError(f"{where} takes a list of values, or {{values, weights}}")
    values, weights = _choice_parts(args)
    if not isinstance(values, list) or not values:
        raise SpecError(f"{where} needs a non-empty list of values")
    if weights is not None:
        if not isinstance(weights, list) or len(weights) != len(values) or \
                not all(_is_number(w) and w >= 0 for w in weights) or sum(weights) <= 0:
            raise SpecError(f"{where}: weights must be {len(values)} numbers >= 0 with a positive sum")


def _draw_uniform(rng, args):
    low, high = args
    return low + (high - low) * rng.random()


def _draw_loguniform(rng, args):
    low, high = args
    return math.exp(math.log(low) + (math.log(high) - math.log(low)) * rng.random())


def _draw_normal(rng, args):
    low, high = args.get("min", -math.inf), args.get("max", math.inf)
    while True:
        # Box-Muller on random() alone (Python's gauss() is not covered by its stability promise).
        u1, u2 = 1.0 - rng.random(), rng.random()
        x = args["mean"] + args["std"] * math.sqrt(-2.0 * math.log(u1)) * math.cos(2.0 * math.pi * u2)
        if low <= x <= high:
            return x


def _draw_integer(rng, args):
    low, high = args
    return min(high, low + int(rng.random() * (high - low + 1)))


def _draw_choice(rng, args):
    values, weights = _choice_parts(args)
    if weights is None:
        return values[min(len(values) - 1, int(rng.random() * len(values)))]
    u, total = rng.random() * sum(weights), 0.0
    for value, weight in zip(values, weights):
        total += weight
        if u < total:
            return value
    return values[-1]


_CHECK = {"uniform": _check_uniform, "loguniform": _check_loguniform, "normal": _check_normal,
          "integer": _check_integer, "choice": _check_choice}
_DRAW = {"uniform": _draw_uniform, "loguniform": _draw_loguniform, "normal": _draw_normal,
         "integer": _draw_integer, "choice": _draw_choice}


def check_template(section, key, template):
    """A random value: a distribution {name: arguments}, a list whose entries are templates (a
    vector with drawn components), or a literal. Returns how many distributions it holds."""
    if isinstance(template, list):
        return sum(check_template(section, f"{key}[{i}]", t) for i, t in enumerate(template))
    where = f"{section} '{key}'"
    if isinstance(template, dict):
        if len(template) != 1 or next(iter(template)) not in DISTRIBUTIONS:
            names = ", ".join(str(k) for k in template)
            raise SpecError(f"{where}: unknown distribution '{names}' (known: {', '.join(DISTRIBUTIONS)})")
        name, args = next(iter(template.items()))
        _CHECK[name](f"{where}: {name}", args)
        return 1
    return 0


def draw_template(template, rng):
    if isinstance(template, list):
        return [draw_template(t, rng) for t in template]
    if isinstance(template, dict):
        name, args = next(iter(template.items()))
        return _DRAW[name](rng, args)
    return template


# The most episodes a batch may have unless --max-episodes says more: each is a scene file, an
# index row and a run; a spec with more is almost always a typo (range: [3, 1000000000, 1]),
# and building it would fill the memory before any check.
DEFAULT_MAX_EPISODES = 100000


def _too_many(where, count, limit):
    return SpecError(f"{where} gives {count} values, more than the {limit} episodes a batch may have "
                     f"(--max-episodes N raises the limit)")


def sweep_values(where, value, limit=DEFAULT_MAX_EPISODES):
    """The values a sweep key takes: a list, or {linspace|logspace: [first, last, count]} or
    {range: [start, stop, step]} (integers, stop excluded); counted before they are made, at
    most `limit`."""
    if isinstance(value, list):
        if not value:
            raise SpecError(f"{where} has no values")
        return value
    if not isinstance(value, dict) or len(value) != 1 or next(iter(value)) not in SWEEP_FORMS:
        raise SpecError(f"{where} must be a list of values or one of {{{', '.join(SWEEP_FORMS)}: ...}}")
    form, args = next(iter(value.items()))
    where = f"{where}: {form}"
    if form == "range":
        start, stop, step = _numbers(where, args, 3, "integers")
        if not all(isinstance(v, int) for v in args) or step == 0 or not range(start, stop, step):
            raise SpecError(f"{where} needs integers [start, stop, step] giving at least one value")
        if len(range(start, stop, step)) > limit:
            raise _too_many(where, len(range(start, stop, step)), limit)
        return list(range(start, stop, step))
    first, last, count = _numbers(where, args, 3)
    if not isinstance(count, int) or count < 1:
        raise SpecError(f"{where}: the count must be an integer >= 1, got {count}")
    if count > limit:
        raise _too_many(where, count, limit)
    if form == "logspace" and not (first > 0 and last > 0):
        raise SpecError(f"{where}: first and last must be > 0")
    if count == 1:
        return [first]
    if form == "linspace":
        return [first + (last - first) * i / (count - 1) for i in range(count)]
    return [first * (last / first) ** (i / (count - 1)) for i in range(count)]


class Episode:
    """One scene of the batch: the sweep point and the draw it comes from, and its values."""

    def __init__(self, index, draw, seed, values):
        self.index, self.draw, self.seed, self.values = index, draw, seed, values

    def value_texts(self):
        return {key: yaml_text(value) for key, value in self.values.items()}


class Spec:
    """A checked spec. Paths in it are relative to the spec file."""

    def __init__(self, path, max_episodes=DEFAULT_MAX_EPISODES):
        self.path = os.path.abspath(path)
        self.max_episodes = max_episodes
        try:
            with open(path, encoding="utf-8") as f:
                self.text = f.read()
        except OSError as error:
            raise SpecError(f"cannot read spec '{path}': {error.strerror}") from None
        data = load_yaml_text(self.text, path)
        if not isinstance(data, dict):
            raise SpecError(f"{path}: a spec is a map of keys ({', '.join(KNOWN_KEYS)})")
        for key in data:
            if key not in KNOWN_KEYS:
                raise SpecError(f"{path}: unknown key '{key}' (known: {', '.join(KNOWN_KEYS)})")
        self._read(data)

    def _where(self, key):
        return f"{self.path}: {key}"

    def _read(self, data):
        if not isinstance(data.get("scene"), str) or not data["scene"]:
            raise SpecError(f"{self._where('scene')} is required: the base scene file")
        self.scene = os.path.join(os.path.dirname(self.path), data["scene"])
        if not os.path.isfile(self.scene):
            raise SpecError(f"{self._where('scene')}: no such file '{data['scene']}'")
        # A recorded run whose commands (pins, grasps, forces, tf) drive every episode
        # (fem_cloth_sim --commands BAG --scene EPISODE_SCENE).
        self.commands = data.get("commands")
        if self.commands is not None:
            if not isinstance(self.commands, str) or not self.commands:
                raise SpecError(f"{self._where('commands')} must be the path of a bag")
            self.commands = os.path.join(os.path.dirname(self.path), self.commands)
            if not os.path.isfile(self.commands):
                raise SpecError(f"{self._where('commands')}: no such file '{data['commands']}'")
        self.episodes = self._integer(data, "episodes", 1, minimum=1)
        self.seed = self._integer(data, "seed", 0, minimum=0)
        self.every = self._integer(data, "every", None, minimum=1)
        self.output = data.get("output", "bag")
        if self.output not in OUTPUTS:
            raise SpecError(f"{self._where('output')} must be one of {', '.join(OUTPUTS)}, got "
                            f"{yaml_text(self.output)}")
        self.timeout = data.get("timeout")
        if self.timeout is not None and not (_is_number(self.timeout) and self.timeout > 0):
            raise SpecError(f"{self._where('timeout')} must be a number of seconds > 0")
        self.fixed = self._section(data, "set")
        self.sweep = {k: sweep_values(f"{self._where('sweep')} '{k}'", v, self.max_episodes)
                      for k, v in self._section(data, "sweep").items()}
        # Counted, not built: the points are the product of the sweeps' values.
        count = self.episodes
        for values in self.sweep.values():
            count *= len(values)
        if count > self.max_episodes:
            product = (f" ({' x '.join(str(len(v)) for v in self.sweep.values())} sweep values x "
                       f"{self.episodes} episodes)" if self.sweep else "")
            raise SpecError(f"{self.path}: {count} episodes{product}, more than the {self.max_episodes} "
                            f"a batch may have (--max-episodes N raises the limit)")
        self.random = self._section(data, "random")
        for key, template in self.random.items():
            if check_template(self._where("random"), key, template) == 0:
                raise SpecError(f"{self._where('random')} '{key}' draws nothing (fixed values go under set)")
        self._check_keys()
        self._fixed_overrides = [f"{key}={yaml_text(value)}" for key, value in self.fixed.items()]
        if "mesh.file" not in self.varied_keys and "mesh.file" not in self.fixed:
            base_file = _base_mesh_file(self.scene)
            if base_file and not os.path.isabs(base_file):
                absolute = os.path.join(os.path.dirname(os.path.abspath(self.scene)), base_file)
                self._fixed_overrides.append(f"mesh.file={yaml_text(absolute)}")

    def _integer(self, data, key, default, minimum):
        value = data.get(key, default)
        if value is default:
            return value
        if not isinstance(value, int) or isinstance(value, bool) or value < minimum:
            raise SpecError(f"{self._where(key)} must be an integer >= {minimum}, got {yaml_text(value)}")
        return value

    def _section(self, data, name):
        section = data.get(name, {})
        if section is None:
            section = {}
        if not isinstance(section, dict):
            raise SpecError(f"{self._where(name)} must be a map of scene keys (dotted, as --set takes them)")
        for key in section:
            if not isinstance(key, str) or not _KEY.match(key):
                raise SpecError(f"{self._where(name)}: '{key}' is not a scene key (words joined by dots, "
                                f"e.g. material.youngs_modulus or pins.0.offset)")
        return section

    def _check_keys(self):
        owner = {}
        for section, keys in (("set", self.fixed), ("sweep", self.sweep), ("random", self.random)):
            for key in keys:
                for other, where in owner.items():
                    if other == key:
                        raise SpecError(f"{self.path}: key '{key}' is in both {where} and {section}")
                    if key.startswith(other + ".") or other.startswith(key + "."):
                        inner, outer = (key, other) if len(key) > len(other) else (other, key)
                        raise SpecError(f"{self.path}: key '{inner}' is inside '{outer}' (give one of them)")
                owner[key] = section

    @property
    def varied_keys(self):
        return list(self.sweep) + list(self.random)

    @property
    def points(self):
        return list(itertools.product(*self.sweep.values()))

    def __len__(self):
        return len(self.points) * self.episodes

    def episode(self, index, points=None):
        """Episode `index`: sweep point index // episodes (the first sweep key varies slowest),
        draw index % episodes."""
        points = points if points is not None else self.points
        point, draw = divmod(index, self.episodes)
        values = dict(zip(self.sweep, points[point]))
        for key, template in self.random.items():
            values[key] = draw_template(template, _stream(self.seed, draw, key))
        return Episode(index, draw, draw_seed(self.seed, draw), values)

    def all_episodes(self):
        points = self.points
        return [self.episode(i, points) for i in range(len(points) * self.episodes)]

    def fixed_overrides(self):
        """The `set` section as --set assignments, with a relative mesh file made absolute (the
        episodes' scenes live in another folder than the base scene)."""
        return list(self._fixed_overrides)

    def overrides(self, episode):
        values = dict(episode.values)
        if isinstance(values.get("mesh.file"), str):
            values["mesh.file"] = os.path.join(os.path.dirname(self.path), values["mesh.file"])
        for key, value in values.items():
            _check_finite(f"{self.path}: episode {episode.index}: '{key}'", value)
        return self.fixed_overrides() + [f"{key}={yaml_text(value)}" for key, value in values.items()]


def _check_finite(where, value):
    if isinstance(value, float) and not math.isfinite(value):
        raise SpecError(f"{where} drew {value}")
    for item in value if isinstance(value, list) else ():
        _check_finite(where, item)


def _base_mesh_file(scene):
    """The base scene's mesh.file (only to make it absolute; fem_cloth_sim reads the scene)."""
    try:
        with open(scene, encoding="utf-8") as f:
            document = yaml.safe_load(f)
    except (OSError, yaml.YAMLError):
        return None  # fem_cloth_sim reports what is wrong with the scene
    mesh = document.get("mesh") if isinstance(document, dict) else None
    return mesh.get("file") if isinstance(mesh, dict) and isinstance(mesh.get("file"), str) else None
