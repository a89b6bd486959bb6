"""Scene and rig configuration: TOML parsed once into frozen dataclasses.

A *rig* file holds only ``[rig]``. A *scene* file names a rig (``rig = "path.toml"``,
relative to the scene) or holds an inline ``[rig]`` table, plus ``[damping]``,
``[excitation]``, ``[sweep]``, ``[solver]``, ``[lockin]``, ``[model]`` and ``[random]``
(the random excitation's run, used by a scene of ``excitation.kind = "random"``). Every
key but the rig's has a default (the SPEC's). Unknown keys, wrong types and values out
of range raise :class:`~hertzsweep.errors.ConfigError` naming the file, the key and the
reason.

Overrides ``table.key=value`` (TOML value syntax; a bare word is taken as a string)
are applied to the raw tables before validation, so they are checked like the file.
"""

from __future__ import annotations

import math
import os
import stat
import tomllib
from collections.abc import Callable, Iterable, Mapping
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import ConfigError
from .lockin import common_denominator, order_fraction

GRAVITY = 9.81  # [m s^-2] default static load is mass * GRAVITY, as in the paper (F_s = mg)
STEEL_DENSITY = 7810.0  # [kg m^-3] 100C6 bearing steel; default ball mass from its volume

GEOMETRIES = ("double-sphere-plane", "sphere-plane")
DAMPING_LAWS = ("viscous", "contact")
DIRECTIONS = ("up", "down")
STEADY_STATE_METHODS = ("settle", "shooting")
SOLVER_METHODS = ("central-difference", "rk4")  # hertzsweep.kernels.methods.METHODS
MODEL_KINDS = ("single", "ball")  # hertzsweep.kernels.methods.MODELS
EXCITATION_KINDS = ("sine", "random")  # stepped sine (sweep) or band-limited Gaussian noise
# The largest input file (scene, rig, study) read: the largest shipped file is under 2 kB
# and a study's grid of a thousand values is under 20 kB, so 1 MiB leaves room for any
# real file while a wrong path (a log, an image, a disk image) is refused before it is read.
MAX_INPUT_BYTES = 1 << 20


# --------------------------------------------------------------------------- dataclasses
@dataclass(frozen=True)
class RigConfig:
    """The test rig, SI units.

    Attributes
    ----------
    geometry : ``"double-sphere-plane"`` (the paper's rig) or ``"sphere-plane"``.
    ball_radius : [m] R.
    youngs_modulus : [Pa] E, ball and planes alike.
    poisson_ratio : [1] nu, in (-1, 0.5).
    mass : [kg] the moving mass m.
    static_load : [N] F_s (default m g).
    ball_mass : [kg] for the estimate of the ball's own mode (default from radius and
        ``ball_density``).
    ball_density : [kg m^-3] used only for the default ball mass.
    natural_frequency : [Hz] a measured linearised natural frequency f0, optional. When
        given it replaces the Hertz value of eq. (15): the contact stiffness k becomes the
        one that gives this f0 with ``mass`` and ``static_load`` (eq. 2, 3), and z_s and
        the time scale Omega follow (:func:`hertzsweep.core.rig.derive`).
    """

    ball_radius: float
    youngs_modulus: float
    poisson_ratio: float
    mass: float
    geometry: str = "double-sphere-plane"
    static_load: float | None = None
    ball_mass: float | None = None
    ball_density: float = STEEL_DENSITY
    natural_frequency: float | None = None

    def __post_init__(self) -> None:
        if self.static_load is None:
            object.__setattr__(self, "static_load", self.mass * GRAVITY)
        if self.ball_mass is None:
            volume = 4.0 / 3.0 * math.pi * self.ball_radius**3
            object.__setattr__(self, "ball_mass", self.ball_density * volume)


@dataclass(frozen=True)
class DampingConfig:
    """Damping law, eq. (8) (``viscous``) or eq. (11) (``contact``, exponent n)."""

    ratio: float = 0.0045
    law: str = "viscous"
    exponent: float = 1.5


@dataclass(frozen=True)
class ExcitationConfig:
    """The input: a sine of levels sigma = F/F_s, or band-limited Gaussian noise.

    ``kind = "sine"`` (the default) drives ``1 + sigma sin(w tau)`` (eq. 8); ``sigma`` is a
    dimension of every result. ``kind = "random"`` drives ``1 + rms g(tau)``, g the
    unit-variance Gaussian process of :mod:`hertzsweep.core.excitation`, with a flat
    one-sided PSD ``S_f = rms^2 / (w_high - w_low)`` per unit w on ``band``; ``rms`` is a
    dimension of its results and ``seed`` fixes the process. A sine scene ignores ``rms``,
    ``band`` and ``seed``, a random scene ``sigma``.
    """

    sigma: tuple[float, ...] = (0.006, 0.01)
    kind: str = "sine"
    rms: tuple[float, ...] = ()
    band: tuple[float, float] = (0.2, 3.0)
    seed: int = 0


@dataclass(frozen=True)
class SweepConfig:
    """Stepped-sine frequency grid and dwell.

    ``settle_periods`` is a whole number, or ``None`` for ``"auto"`` (settle until the
    readings of consecutive blocks of ``measure_periods`` agree within ``tolerance``,
    at most ``max_settle_periods``).
    """

    start: float = 0.90
    stop: float = 1.05
    step: float = 0.0025
    directions: tuple[str, ...] = ("up", "down")
    settle_periods: int | None = 300
    measure_periods: int = 20
    tolerance: float = 1e-4
    max_settle_periods: int = 5000
    jump_threshold: float = 0.3
    steady_state: str = "settle"
    period_multiple: int = 1
    initial_state: tuple[float, float] | None = None  # (q, q') of each sweep's first dwell

    @property
    def frequency_ratios(self) -> np.ndarray:
        """The grid start, start + step, ... up to stop (inclusive within 1e-9 step)."""
        count = int(math.floor((self.stop - self.start) / self.step + 1e-9)) + 1
        return np.round(self.start + self.step * np.arange(count), 12)


@dataclass(frozen=True)
class BranchConfig:
    """How ``hertzsweep branch`` continues: whether it also follows the period-doubled
    branches from every period doubling (down to period :data:`MAX_PERIOD_MULTIPLE`)."""

    follow_period_doubling: bool = False


@dataclass(frozen=True)
class SolverConfig:
    """Time integration: the paper's central-difference scheme.

    ``max_steps`` raises the budget of integration steps a run may take (``None``: the
    default budget, :data:`hertzsweep.core.checks.DEFAULT_MAX_STEPS`). It bounds the run,
    never changes a result, so it is not among :meth:`Scene.attributes`.
    """

    method: str = "central-difference"
    steps_per_period: int = 256
    max_steps: int | None = None


@dataclass(frozen=True)
class ModelConfig:
    """Which equations are integrated: ``"single"`` (eq. 1/8/11, one degree of freedom)
    or ``"ball"`` (the moving mass on the ball between two Hertz contacts, two degrees of
    freedom: :mod:`hertzsweep.core.ballmodel`)."""

    kind: str = "single"


@dataclass(frozen=True)
class RandomConfig:
    """The run of a random excitation (``excitation.kind = "random"``).

    Lengths are in periods of the linearised natural frequency (``2 pi`` in tau, of
    ``solver.steps_per_period`` steps). Each realisation integrates ``transient_periods``
    (discarded) then ``duration_periods`` (measured) of its own forcing, read in Welch
    segments of ``segment_periods`` (the PSD's resolution ``1 / segment_periods`` in w).
    """

    realisations: int = 16
    duration_periods: int = 2000
    transient_periods: int = 200
    segment_periods: int = 64
    force_bins: int = 200
    trace_periods: int = 0
    first_realisation: int = 0


@dataclass(frozen=True)
class LockinConfig:
    """Harmonics of N/F_s read by the lock-in amplifier: whole orders (ints) and multiples
    of 1/2, 1/3 and 1/4 of the excitation frequency (floats, each the float of its
    fraction: 1/3 is ``1 / 3.0``), ascending."""

    harmonics: tuple[int | float, ...] = (1, 2)

    @property
    def denominator(self) -> int:
        """L, the least common multiple of the orders' denominators (1, 2, 3, 4, 6 or 12):
        a reading spans whole response periods of L excitation periods."""
        return common_denominator(self.harmonics)


@dataclass(frozen=True)
class Scene:
    """One experiment: a rig and everything the sweep needs."""

    rig: RigConfig
    damping: DampingConfig = DampingConfig()
    excitation: ExcitationConfig = ExcitationConfig()
    sweep: SweepConfig = SweepConfig()
    solver: SolverConfig = SolverConfig()
    lockin: LockinConfig = LockinConfig()
    model: ModelConfig = ModelConfig()
    random: RandomConfig = RandomConfig()
    branch: BranchConfig = BranchConfig()
    source: str = "<scene>"
    # the files the scene was read from (the scene, then its rig file if any): an output
    # path must not be one of them; not part of the scene's value
    inputs: tuple[str, ...] = field(default=(), compare=False)
    # the dotted keys an override set (``--set``, ``overrides=``): a check that fails on
    # one of them names ``--set`` as its source, as the command line does
    overridden: frozenset[str] = field(default=frozenset(), compare=False)

    @classmethod
    def from_dict(
        cls,
        tables: Mapping[str, Any],
        base_dir: str | os.PathLike | None = None,
        source: str = "<scene>",
    ) -> Scene:
        """A scene from the tables of a scene file, with no file.

        Parameters
        ----------
        tables : mapping
            ``{"rig": ..., "damping": {...}, "excitation": {...}, ...}``, as a scene file's
            TOML reads: ``rig`` is a ``[rig]`` table or the name of a rig file.
        base_dir : path, optional
            The folder a rig file's name is relative to (default: the working folder).
        source : str
            The name errors give the scene.

        Returns
        -------
        Scene
            Validated as a scene file's values are (:func:`scene_from_dict`); the checks
            of a run (budgets, stability) are made when it runs.

        Raises
        ------
        ConfigError
            Unknown table or key, wrong type, value out of range, a missing rig file.
        """
        raw = _copy_tables(tables)
        inputs = _inline_rig(raw, Path(base_dir) if base_dir is not None else Path(), source)
        rig_source = inputs[0] if inputs else None
        scene = scene_from_dict(raw, source=source, rig_source=rig_source)
        return replace(scene, inputs=inputs)

    def with_overrides(self, overrides: Mapping[str, Any]) -> Scene:
        """A new scene with dotted keys set, as ``--set`` sets them.

        Parameters
        ----------
        overrides : mapping
            ``{"excitation.sigma": [0.01], "damping.ratio": 0.006}``: Python values, as a
            TOML file would give them.

        Raises
        ------
        ConfigError
            A key of no known table, or a value the key does not accept (named under
            ``--set``, as on the command line).
        """
        raw: dict[str, Any] = self._tables(random=True)  # a sine scene keeps its random keys
        keys = apply_overrides(raw, overrides)
        try:
            scene = scene_from_dict(raw, source=self.source)
        except ConfigError as exc:
            raise from_command_line(exc, keys) from None
        return replace(scene, inputs=self.inputs, overridden=self.overridden | keys)

    @property
    def is_random(self) -> bool:
        """Whether the scene drives a random excitation (``excitation.kind = "random"``)."""
        return self.excitation.kind == "random"

    def attributes(self) -> dict[str, Any]:
        """Every resolved value as flat ``table_key`` attributes (netCDF-friendly).

        A sine scene leaves out the random excitation's keys (:data:`RANDOM_KEYS`:
        ``excitation_kind``, ``excitation_rms``, ``excitation_band``, ``excitation_seed``
        and the ``[random]`` table), so that its attributes are those of a scene written
        before random excitation existed; a random scene has every table.
        """
        out: dict[str, Any] = {}
        for table in CLASSES:
            for key, value in asdict(getattr(self, table)).items():
                if (table, key) in BUDGET_KEYS or not self._shows(table, key):
                    continue
                bare = table == "rig" or (table, key) == ("solver", "steps_per_period")
                name = key if bare else f"{table}_{key}"  # SPEC: damping_ratio, steps_per_period
                if value is None:
                    value = "auto"
                if isinstance(value, tuple):
                    value = list(value)
                    if value and isinstance(value[0], str):
                        value = ",".join(value)
                out[name] = value
        out["rig_geometry"] = out.pop("geometry")
        return out

    def to_dict(self) -> dict[str, dict[str, Any]]:
        """The resolved scene as the tables of a scene file, rig inline: what
        :func:`scene_from_dict` reads back into an equal scene (``source`` aside).

        Every value is resolved (the rig's default static load and ball mass included);
        tuples become lists, ``settle_periods = None`` becomes ``"auto"``, and an optional
        value left unset (None) is left out, as it would be from a TOML file. A sine scene
        leaves out the random excitation's keys and the ``[random]`` table, as
        :meth:`attributes` does.
        """
        return self._tables(random=self.is_random)

    def _shows(self, table: str, key: str, random: bool | None = None) -> bool:
        """Whether ``table.key`` is among the scene's values: every key of a random scene
        (or with ``random``), every key but :data:`RANDOM_KEYS` of a sine scene."""
        if random is None:
            random = self.is_random
        if (table, key) in QUIET_DEFAULTS:
            return getattr(getattr(self, table), key) != QUIET_DEFAULTS[table, key]
        return random or not (table in RANDOM_TABLES or (table, key) in RANDOM_KEYS)

    def _tables(self, random: bool) -> dict[str, dict[str, Any]]:
        """:meth:`to_dict`, the random excitation's keys included when ``random``."""
        tables: dict[str, dict[str, Any]] = {}
        for name in CLASSES:
            if not random and name in RANDOM_TABLES:
                continue
            table: dict[str, Any] = {}
            for key, value in asdict(getattr(self, name)).items():
                if not self._shows(name, key, random):
                    continue
                if (name, key) == ("sweep", "settle_periods") and value is None:
                    value = "auto"
                if value is None or value == ():  # unset (a sine scene's empty rms)
                    continue
                table[key] = list(value) if isinstance(value, tuple) else value
            if table or name not in QUIET_TABLES:
                tables[name] = table
        return tables


# --------------------------------------------------------------------------- validation
def _number(source: str, key: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ConfigError(source, key, f"expected a number, got {value!r}")
    if not math.isfinite(value):
        raise ConfigError(source, key, f"expected a finite number, got {value!r}")
    return float(value)


def _integer(source: str, key: str, value: Any) -> int:
    if isinstance(value, float) and value.is_integer():
        value = int(value)
    if isinstance(value, bool) or not isinstance(value, int):
        raise ConfigError(source, key, f"expected a whole number, got {value!r}")
    return value


def _boolean(source: str, key: str, value: Any) -> bool:
    if not isinstance(value, bool):
        raise ConfigError(source, key, f"expected true or false, got {value!r}")
    return value


MAX_PERIOD_MULTIPLE = 8  # the longest period (in excitation periods) shot or followed


def _period_multiple(source: str, key: str, value: Any) -> int:
    x = _integer(source, key, value)
    if not 1 <= x <= MAX_PERIOD_MULTIPLE:
        raise ConfigError(
            source, key, f"must be a whole number from 1 to {MAX_PERIOD_MULTIPLE}, got {value!r}"
        )
    return x


def _string(source: str, key: str, value: Any, allowed: Iterable[str]) -> str:
    allowed = tuple(allowed)
    if not isinstance(value, str) or value not in allowed:
        choices = ", ".join(repr(a) for a in allowed)
        raise ConfigError(source, key, f"expected one of {choices}, got {value!r}")
    return value


def _positive(source: str, key: str, value: Any) -> float:
    x = _number(source, key, value)
    if x <= 0:
        raise ConfigError(source, key, f"must be positive, got {value!r}")
    return x


def _non_negative(source: str, key: str, value: Any) -> float:
    x = _number(source, key, value)
    if x < 0:
        raise ConfigError(source, key, f"must be >= 0, got {value!r}")
    return x


def _positive_int(source: str, key: str, value: Any) -> int:
    x = _integer(source, key, value)
    if x < 1:
        raise ConfigError(source, key, f"must be at least 1, got {value!r}")
    return x


def _poisson(source: str, key: str, value: Any) -> float:
    x = _number(source, key, value)
    if not -1.0 < x < 0.5:
        raise ConfigError(source, key, f"must lie in (-1, 0.5), got {value!r}")
    return x


def _sigma_list(source: str, key: str, value: Any) -> tuple[float, ...]:
    items = value if isinstance(value, list) else [value]
    if not items:
        raise ConfigError(source, key, "expected a number or a non-empty list of numbers")
    out = tuple(_positive(source, key, v) for v in items)
    if len(set(out)) != len(out):
        raise ConfigError(source, key, f"values must be distinct, got {list(out)}")
    return out


def _directions(source: str, key: str, value: Any) -> tuple[str, ...]:
    items = value if isinstance(value, list) else [value]
    out = tuple(_string(source, key, v, DIRECTIONS) for v in items)
    if not out or len(set(out)) != len(out):
        raise ConfigError(source, key, f"expected 'up', 'down' or both once, got {value!r}")
    return out


def _settle(source: str, key: str, value: Any) -> int | None:
    if value == "auto":
        return None
    if isinstance(value, str):
        raise ConfigError(source, key, f"expected a whole number or 'auto', got {value!r}")
    x = _integer(source, key, value)
    if x < 0:
        raise ConfigError(source, key, f"must be >= 0 or 'auto', got {value!r}")
    return x


def _harmonics(source: str, key: str, value: Any) -> tuple[int | float, ...]:
    """Distinct orders k > 0, each whole or a multiple of 1/2, 1/3 or 1/4 (within
    :data:`~hertzsweep.core.lockin.ORDER_TOLERANCE`): a whole order as an int, another as
    the float of its fraction (0.333 is not 1/3: refused), ascending."""
    items = value if isinstance(value, list) else [value]
    expected = "distinct orders > 0, whole or multiples of 1/2, 1/3, 1/4 (e.g. [0.5, 1, 1.5, 2])"
    out = []
    for item in items:
        if isinstance(item, bool) or not isinstance(item, int | float):
            raise ConfigError(source, key, f"expected {expected}, got {value!r}")
        fraction = order_fraction(item) if item > 0 else None  # None for NaN, inf, <= 0
        if fraction is None:
            raise ConfigError(source, key, f"expected {expected}, got {item!r} in {value!r}")
        if fraction.denominator == 1:
            out.append(int(fraction.numerator))
        else:
            out.append(fraction.numerator / float(fraction.denominator))
    if not out or len(set(out)) != len(out):
        raise ConfigError(source, key, f"expected {expected}, got {value!r}")
    return tuple(sorted(out))


def _non_negative_int(source: str, key: str, value: Any) -> int:
    x = _integer(source, key, value)
    if x < 0:
        raise ConfigError(source, key, f"must be >= 0, got {value!r}")
    return x


MAX_SEED = 2**63 - 1  # a seed is kept as a netCDF int64 attribute


def _seed(source: str, key: str, value: Any) -> int:
    x = _non_negative_int(source, key, value)
    if x > MAX_SEED:
        raise ConfigError(source, key, f"must be at most 2**63 - 1, got {value!r}")
    return x


def _bin_count(source: str, key: str, value: Any) -> int:
    x = _integer(source, key, value)
    if x < 2:
        raise ConfigError(source, key, f"must be at least 2, got {value!r}")
    return x


def _band(source: str, key: str, value: Any) -> tuple[float, float]:
    if not isinstance(value, list) or len(value) != 2:
        raise ConfigError(source, key, f"expected two numbers [w_low, w_high], got {value!r}")
    low, high = (_number(source, key, v) for v in value)
    if not 0.0 < low < high:
        raise ConfigError(source, key, f"must satisfy 0 < w_low < w_high, got {value!r}")
    return low, high


def _fraction(source: str, key: str, value: Any) -> float:
    x = _number(source, key, value)
    if not 0.0 < x < 1.0:
        raise ConfigError(source, key, f"must lie in (0, 1), got {value!r}")
    return x


def _initial_state(source: str, key: str, value: Any) -> tuple[float, float]:
    """``[q, dq]``: two finite numbers, the state a sweep's first dwell starts from."""
    if not isinstance(value, list) or len(value) != 2:
        raise ConfigError(
            source, key, f"expected two numbers [q, dq] (displacement, velocity), got {value!r}"
        )
    q, dq = (_number(source, key, v) for v in value)
    return q, dq


Check = Callable[[str, str, Any], Any]

SCHEMA: dict[str, dict[str, Check]] = {
    "rig": {
        "geometry": lambda s, k, v: _string(s, k, v, GEOMETRIES),
        "ball_radius": _positive,
        "youngs_modulus": _positive,
        "poisson_ratio": _poisson,
        "mass": _positive,
        "static_load": _positive,
        "ball_mass": _positive,
        "ball_density": _positive,
        "natural_frequency": _positive,
    },
    "damping": {
        "ratio": _non_negative,
        "law": lambda s, k, v: _string(s, k, v, DAMPING_LAWS),
        "exponent": _non_negative,
    },
    "excitation": {
        "sigma": _sigma_list,
        "kind": lambda s, k, v: _string(s, k, v, EXCITATION_KINDS),
        "rms": _sigma_list,  # the same rule as sigma: positive, finite, distinct (a dimension)
        "band": _band,
        "seed": _seed,
    },
    "sweep": {
        "start": _positive,
        "stop": _positive,
        "step": _positive,
        "directions": _directions,
        "settle_periods": _settle,
        "measure_periods": _positive_int,
        "tolerance": _positive,
        "max_settle_periods": _positive_int,
        "jump_threshold": _fraction,
        "steady_state": lambda s, k, v: _string(s, k, v, STEADY_STATE_METHODS),
        "period_multiple": _period_multiple,
        "initial_state": _initial_state,
    },
    "solver": {
        "method": lambda s, k, v: _string(s, k, v, SOLVER_METHODS),
        "steps_per_period": _positive_int,
        "max_steps": _positive_int,
    },
    "lockin": {"harmonics": _harmonics},
    "model": {"kind": lambda s, k, v: _string(s, k, v, MODEL_KINDS)},
    "random": {
        "realisations": _positive_int,
        "duration_periods": _positive_int,
        "transient_periods": _non_negative_int,
        "segment_periods": _positive_int,
        "force_bins": _bin_count,
        "trace_periods": _non_negative_int,
        "first_realisation": _non_negative_int,
    },
    "branch": {"follow_period_doubling": _boolean},
}
REQUIRED_RIG_KEYS = ("ball_radius", "youngs_modulus", "poisson_ratio", "mass")
BUDGET_KEYS = {("solver", "max_steps")}  # limits of a run, not settings of its result
CLASSES = {
    "rig": RigConfig,
    "damping": DampingConfig,
    "excitation": ExcitationConfig,
    "sweep": SweepConfig,
    "solver": SolverConfig,
    "lockin": LockinConfig,
    "model": ModelConfig,
    "random": RandomConfig,
    "branch": BranchConfig,
}
# What only a random scene uses: left out of a sine scene's attributes() and to_dict(), so
# that a sine scene's datasets are those it gave before random excitation existed
RANDOM_KEYS = {("excitation", key) for key in ("kind", "rms", "band", "seed")}
RANDOM_TABLES = ("random",)
# Keys left out of a scene's attributes() and to_dict() while at these defaults, so that a
# scene that does not use them gives the datasets it gave before they existed; a table
# left with no key (``[branch]``) is left out too
QUIET_DEFAULTS: dict[tuple[str, str], Any] = {
    ("sweep", "period_multiple"): 1,
    ("branch", "follow_period_doubling"): False,
    ("sweep", "initial_state"): None,  # unset: at rest
    ("random", "first_realisation"): 0,
}
QUIET_TABLES = ("branch",)
# What each key of SCHEMA sets, one line each ([unit] first where it has one): the manual's
# configuration reference is generated from SCHEMA, the dataclasses' defaults and this table
DESCRIPTIONS: dict[str, str] = {
    "rig.geometry": "the contacts: the paper's ball between two planes, or one sphere on a plane",
    "rig.ball_radius": "[m] radius R of the ball",
    "rig.youngs_modulus": "[Pa] Young's modulus E, of the ball and the planes alike",
    "rig.poisson_ratio": "[1] Poisson's ratio nu",
    "rig.mass": "[kg] the moving mass m",
    "rig.static_load": "[N] static load F_s (default: mass * 9.81)",
    "rig.ball_mass": "[kg] mass of the ball, for the ball-mode estimate and the ball model "
    "(default: from ball_radius and ball_density)",
    "rig.ball_density": "[kg m^-3] density of the ball, for its default mass (100C6 steel)",
    "rig.natural_frequency": "[Hz] a measured natural frequency f0 that replaces the Hertz "
    "value of eq. (15) (k, z_s and Omega follow; default: unset)",
    "damping.ratio": "[1] damping ratio zeta",
    "damping.law": "viscous (eq. 8, at all times) or contact (eq. 11, only in contact)",
    "damping.exponent": "[1] exponent n of the contact law, used by law = 'contact'",
    "excitation.sigma": "[1] input levels F/F_s, a number or a list (a dimension of the results)",
    "sweep.start": "[1] first frequency ratio w = f/f0 of the grid",
    "sweep.stop": "[1] last frequency ratio of the grid (included)",
    "sweep.step": "[1] step of the frequency ratio",
    "sweep.directions": "the sweeps to run; each starts from rest at its first frequency",
    "sweep.settle_periods": "periods settled at each frequency before reading, or 'auto' "
    "(until consecutive readings agree within tolerance)",
    "sweep.measure_periods": "periods read by the lock-in (the block size of 'auto')",
    "sweep.tolerance": "[1] relative agreement of 'auto' settling and of the settled flag",
    "sweep.max_settle_periods": "the most periods 'auto' settles at one frequency",
    "sweep.jump_threshold": "[1] relative change of H1 between neighbouring frequencies that "
    "counts as a jump",
    "sweep.steady_state": "settle (integrate until steady) or shooting (Newton on the "
    "one-period map)",
    "sweep.period_multiple": "[periods] shooting (steady_state = 'shooting') solves for orbits "
    "of this many excitation periods, Newton on the n-period map: 2 lands on a period-doubled "
    "response where the sweep's settled state is one (1 to 8)",
    "branch.follow_period_doubling": "hertzsweep branch also continues the period-doubled "
    "branch from every period-doubling point, recursively down to period 8 (as --follow-pd)",
    "sweep.initial_state": "[1] [q, q'] in the model's units (q = 3/2 (z - z_s)/z_s, "
    "q' = dq/dtau): the state each sweep's first dwell (and a trace's approach) starts from "
    "at excitation phase 0, as a tap on the rig would give (default: unset, at rest; the "
    "single model only)",
    "solver.method": "the integration method: the paper's central difference (order 2) or rk4 "
    "with located contact crossings",
    "solver.steps_per_period": "integration steps per excitation period (above the stability "
    "limit)",
    "solver.max_steps": "budget of integration steps of one run: a longer run is refused before "
    "it starts (default: hertzsweep.core.checks.DEFAULT_MAX_STEPS)",
    "lockin.harmonics": "harmonic orders k of N/F_s read by the lock-in: whole, or multiples of "
    "1/2, 1/3, 1/4 (e.g. [0.5, 1, 1.5, 2]: sweep.measure_periods is then a multiple of their "
    "common denominator)",
    "model.kind": "single (one degree of freedom, eq. 1/8/11) or ball (the moving mass on the "
    "ball between two Hertz contacts)",
    "excitation.kind": "sine (the stepped sine of sweep) or random (band-limited Gaussian noise "
    "of hertzsweep random)",
    "excitation.rms": "[1] RMS levels of f = F/F_s of a random scene, a number or a list (a "
    "dimension of its results)",
    "excitation.band": "[1] the band [w_low, w_high] of frequency ratios of a random scene: a flat "
    "one-sided PSD rms^2 / (w_high - w_low) on it, none outside",
    "excitation.seed": "the seed of the random excitation: it alone fixes every realisation",
    "random.realisations": "independent realisations of the random excitation, run in lockstep",
    "random.duration_periods": "periods measured by each realisation (2 pi in tau each, at the "
    "linearised natural frequency)",
    "random.transient_periods": "periods integrated and discarded before the measured ones",
    "random.segment_periods": "periods of a Welch segment: the PSD's resolution is "
    "1 / segment_periods in w",
    "random.force_bins": "bins of the histogram of N/F_s (force_pdf)",
    "random.trace_periods": "periods of time history kept from the first realisation's start "
    "(0: none)",
    "random.first_realisation": "the run's realisation r uses the forcing stream of realisation "
    "first_realisation + r: a run of realisations first .. first + realisations - 1 of a larger "
    "one (a study's split_realisations runs its groups so)",
}


def _table(source: str, raw: Mapping[str, Any], name: str) -> dict[str, Any]:
    table = raw.get(name, {})
    if not isinstance(table, Mapping):
        raise ConfigError(source, name, f"expected a table, got {table!r}")
    values: dict[str, Any] = {}
    for key, value in table.items():
        dotted = f"{name}.{key}"
        if key not in SCHEMA[name]:
            known = ", ".join(SCHEMA[name])
            raise ConfigError(source, dotted, f"unknown key (known: {known})")
        values[key] = SCHEMA[name][key](source, dotted, value)
    return values


def rig_from_table(source: str, raw: Mapping[str, Any]) -> RigConfig:
    """Validate a ``[rig]`` table (already merged with overrides)."""
    values = _table(source, {"rig": raw}, "rig")
    for key in REQUIRED_RIG_KEYS:
        if key not in values:
            raise ConfigError(source, f"rig.{key}", "missing (the rig's keys have no default)")
    try:
        return RigConfig(**values)
    except OverflowError:  # the default ball mass of a huge radius
        key = rig_key_furthest(values)
        raise ConfigError(source, key, "the ball's mass from its radius overflows") from None


# The paper's rig (section 2): the yardstick of rig_key_furthest
PAPER_RIG_VALUES = {
    "ball_radius": 12.7e-3,  # [m]
    "youngs_modulus": 210e9,  # [Pa]
    "mass": 11.4,  # [kg]
    "static_load": 110.0,  # [N]
    "ball_mass": 0.067,  # [kg] a 12.7 mm steel ball
    "ball_density": STEEL_DENSITY,  # [kg m^-3]
    "natural_frequency": 230.8,  # [Hz]
}
EXTREME_DECADES = 3.0  # a rig value this many decades from the paper's is named alone


def rig_key_furthest(values: Mapping[str, Any]) -> str:
    """The ``rig.KEY`` most responsible for a rig whose constants cannot be used (not
    finite, or out of range): the value furthest from the paper's rig in decades
    (``1 - nu^2`` for ``poisson_ratio``, whose limit -1 makes E* unbounded), when it is at
    least :data:`EXTREME_DECADES` away; else ``rig`` (the values together)."""
    distance: dict[str, float] = {}
    for key, reference in PAPER_RIG_VALUES.items():
        value = values.get(key)
        if isinstance(value, int | float) and value > 0 and math.isfinite(value):
            distance[key] = abs(math.log10(value) - math.log10(reference))
    nu = values.get("poisson_ratio")
    if isinstance(nu, int | float) and -1.0 < nu < 1.0:
        distance["poisson_ratio"] = -math.log10(1.0 - nu * nu)
    key, decades = max(distance.items(), key=lambda item: item[1], default=("", 0.0))
    return f"rig.{key}" if decades >= EXTREME_DECADES else "rig"


def scene_from_dict(
    raw: Mapping[str, Any], source: str = "<scene>", rig_source: str | None = None
) -> Scene:
    """Validate a raw scene mapping whose ``rig`` is already an inline table.

    ``rig_source`` names the file the ``[rig]`` values came from (a rig file the scene
    refers to) in their errors; default ``source``.

    Raises
    ------
    ConfigError
        Unknown key, wrong type, value out of range, or an empty/reversed grid.
    """
    for key in raw:
        if key not in CLASSES:
            known = ", ".join(CLASSES)
            raise ConfigError(source, key, f"unknown table (known: {known})")
    if "rig" not in raw:
        raise ConfigError(source, "rig", "missing: give rig = 'file.toml' or a [rig] table")
    rig = rig_from_table(rig_source or source, raw["rig"])
    tables = {name: CLASSES[name](**_table(source, raw, name)) for name in CLASSES if name != "rig"}
    sweep: SweepConfig = tables["sweep"]
    if sweep.stop < sweep.start:
        raise ConfigError(
            source, "sweep.stop", f"grid is reversed: stop {sweep.stop} < start {sweep.start}"
        )
    if sweep.step > (sweep.stop - sweep.start) and sweep.stop > sweep.start:
        raise ConfigError(
            source,
            "sweep.step",
            f"step {sweep.step} is larger than the range {sweep.stop - sweep.start:g}",
        )
    check_random_table(source, tables["random"])
    scene = Scene(rig=rig, source=source, **tables)
    check_model(scene)
    check_random(scene)
    return scene


def check_random_table(source: str, random: RandomConfig) -> None:
    """The lengths of a ``[random]`` table agree: the transient, a Welch segment and the
    trace are no longer than the measured record (``duration_periods``)."""
    duration = random.duration_periods
    for key, value, what in (
        ("transient_periods", random.transient_periods, "a transient"),
        ("segment_periods", random.segment_periods, "a Welch segment"),
        ("trace_periods", random.trace_periods, "a trace"),
    ):
        if value > duration:
            raise ConfigError(
                source,
                f"random.{key}",
                f"{what} of {value} periods is longer than the measured record "
                f"random.duration_periods = {duration}",
            )


RANDOM_NEEDS: tuple[tuple[str, str, object, str], ...] = ()  # (table, key, value, why) a
# random scene must keep: none, every model and method runs random excitation (the ball
# model with the central difference, which check_model asks of it)


def check_random(scene: Scene) -> None:
    """Refuse a random scene (``excitation.kind = "random"``) without levels, or one the
    random run cannot run yet (:data:`RANDOM_NEEDS`)."""
    if not scene.is_random:
        return
    if not scene.excitation.rms:
        raise ConfigError(
            scene.source, "excitation.rms", "a random scene needs its levels: rms = [...] (> 0)"
        )
    for table, key, value, why in RANDOM_NEEDS:
        given = getattr(getattr(scene, table), key)
        if given != value:
            raise ConfigError(scene.source, f"{table}.{key}", f"{why}, got {given!r}")


BALL_MODEL_NEEDS = (  # (table, key, value) a "ball" scene must keep, and why
    ("rig", "geometry", "double-sphere-plane", "the ball sits between two planes"),
    ("solver", "method", "central-difference", "its scheme is the central difference"),
)


def check_model(scene: Scene) -> None:
    """Refuse a ``model.kind`` the rest of the scene cannot run (:data:`BALL_MODEL_NEEDS`:
    the two-degree-of-freedom model sits in the double sphere-plane rig and integrates
    with the central difference; the rk4 method serves the single model)."""
    if scene.model.kind != "ball":
        return
    if scene.sweep.initial_state is not None:
        raise ConfigError(
            scene.source,
            "sweep.initial_state",
            "not available with model.kind = 'ball' (its state is two bodies'; it starts "
            "from rest)",
        )
    for table, key, value, why in BALL_MODEL_NEEDS:
        given = getattr(getattr(scene, table), key)
        if given != value:
            raise ConfigError(
                scene.source,
                "model.kind",
                f"'ball' needs {table}.{key} = {value!r} ({why}), got {given!r}",
            )


# --------------------------------------------------------------------------- files
FILE_KINDS = (  # stat test -> what a path that is not a regular file is, in errors
    (stat.S_ISDIR, "a directory"),
    (stat.S_ISFIFO, "a named pipe (FIFO)"),
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
    (stat.S_ISSOCK, "a socket"),
)


def _not_regular(mode: int) -> str | None:
    """What a file of this mode is when it is not a regular file (None when it is)."""
    if stat.S_ISREG(mode):
        return None
    return next((name for test, name in FILE_KINDS if test(mode)), "not a regular file")


def _too_large(size: int, limit: int) -> str:
    return f"too large ({size} bytes; an input file holds at most {limit} bytes)"


def read_bytes(path: str | Path, limit: int = MAX_INPUT_BYTES) -> bytes:
    """The bytes of an input file: a regular file of at most ``limit`` bytes; anything else
    is a ConfigError naming the file.

    The path is looked at (``os.stat``) before it is opened, so a FIFO, a device or a
    socket is never opened (a FIFO would block, ``/dev/zero`` never ends); it is opened
    non-blocking and looked at again through the open descriptor (the path may have been
    replaced in between), and at most ``limit + 1`` bytes are read.
    """
    name = str(path)
    try:
        info = os.stat(path)
    except FileNotFoundError:
        raise ConfigError(name, "", "no such file") from None
    except (OSError, ValueError) as exc:  # ValueError: a NUL byte in the path
        raise ConfigError(
            name, "", f"cannot read ({getattr(exc, 'strerror', None) or exc})"
        ) from None
    kind = _not_regular(info.st_mode)
    if kind:
        raise ConfigError(name, "", f"not a regular file but {kind}")
    if info.st_size > limit:
        raise ConfigError(name, "", _too_large(info.st_size, limit))
    flags = os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_CLOEXEC", 0)
    flags |= getattr(os, "O_NOCTTY", 0)
    try:
        fd = os.open(path, flags)
    except OSError as exc:
        raise ConfigError(name, "", f"cannot read ({exc.strerror or exc})") from None
    try:
        kind = _not_regular(os.fstat(fd).st_mode)
        if kind:
            raise ConfigError(name, "", f"not a regular file but {kind}")
        chunks = []
        size = 0
        while size <= limit:
            chunk = os.read(fd, limit + 1 - size)
            if not chunk:
                break
            chunks.append(chunk)
            size += len(chunk)
    except OSError as exc:
        raise ConfigError(name, "", f"cannot read ({exc.strerror or exc})") from None
    finally:
        os.close(fd)
    data = b"".join(chunks)
    if len(data) > limit:
        raise ConfigError(name, "", _too_large(len(data), limit))
    return data


def read_text(path: str | Path, limit: int = MAX_INPUT_BYTES) -> str:
    """The text of an input file (scene, rig, study, measurements): a regular file of at
    most ``limit`` bytes (:data:`MAX_INPUT_BYTES`, :func:`read_bytes`), UTF-8 without NUL
    bytes; anything else is a ConfigError naming the file."""
    name = str(path)
    data = read_bytes(path, limit)
    nul = data.find(b"\0")
    if nul >= 0:
        raise ConfigError(name, "", f"not a text file (a NUL byte at offset {nul})")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = data.count(b"\n", 0, exc.start) + 1
        byte = data[exc.start]
        raise ConfigError(
            name, "", f"not UTF-8 text (byte 0x{byte:02x} at offset {exc.start}, line {line})"
        ) from None


def read_toml(path: str | Path) -> dict[str, Any]:
    """Read a TOML file (:func:`read_text`); a missing, special, oversized, binary or
    malformed file is a ConfigError naming it."""
    text = read_text(path)
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(str(path), "", f"not valid TOML ({exc})") from None
    except ValueError as exc:  # an integer of more than 4300 digits
        raise ConfigError(str(path), "", f"not valid TOML ({exc})") from None
    except RecursionError:
        raise ConfigError(
            str(path), "", "not valid TOML (arrays or tables nested too deep)"
        ) from None


def parse_override(text: str) -> tuple[str, Any]:
    """``"damping.ratio=0.01"`` -> ``("damping.ratio", 0.01)``; TOML value syntax.

    A value that is not valid TOML is taken as a bare string (``law=contact``).
    """
    key, sep, value = text.partition("=")
    key = key.strip()
    if not sep or "." not in key or not value.strip():
        raise ConfigError("--set", key or text, "expected table.key=value")
    try:
        parsed = tomllib.loads(f"v = {value.strip()}")["v"]
    except tomllib.TOMLDecodeError:
        parsed = value.strip()
    except ValueError as exc:  # an integer of more than 4300 digits
        raise ConfigError("--set", key, f"cannot read the value ({exc})") from None
    except RecursionError:
        raise ConfigError("--set", key, "cannot read the value (nested too deep)") from None
    return key, parsed


def apply_override(raw: dict[str, Any], key: str, value: Any, source: str = "--set") -> None:
    """Set dotted ``table.key`` in a raw scene mapping (in place)."""
    table, _, name = key.partition(".")
    if table not in CLASSES or not name or "." in name:
        raise ConfigError(source, key, "expected table.key with a known table")
    sub = raw.setdefault(table, {})
    if not isinstance(sub, dict):
        raise ConfigError(source, key, f"{table} is not a table here")
    sub[name] = value


def same_file(a: Path, b: Path) -> bool:
    """Whether two existing paths are the same file (False when either cannot be looked at)."""
    try:
        return os.path.samefile(a, b)
    except (OSError, ValueError):
        return False


def load_raw_scene(path: str | Path) -> dict[str, Any]:
    """Read a scene file and inline its rig (``rig = "file"`` is relative to the scene)."""
    return read_scene_files(path)[0]


def read_scene_files(path: str | Path) -> tuple[dict[str, Any], tuple[str, ...]]:
    """:func:`load_raw_scene`, and the files read: the scene, then its rig file if any.

    ``rig`` is a file name or a ``[rig]`` table. A rig file holds only a ``[rig]`` table:
    it cannot name another file (so references neither chain nor cycle), and a scene
    cannot name itself as its rig.
    """
    path = Path(path)
    raw = read_toml(path)
    return raw, (str(path), *_inline_rig(raw, path.parent, str(path), scene_path=path))


def _inline_rig(
    raw: dict[str, Any], base: Path, source: str, scene_path: Path | None = None
) -> tuple[str, ...]:
    """Replace ``rig = "file"`` (relative to ``base``) by the rig file's ``[rig]`` table,
    in place; returns the rig file read, if any (see :func:`read_scene_files`)."""
    rig = raw.get("rig")
    if rig is not None and not isinstance(rig, str | Mapping):
        raise ConfigError(source, "rig", f"expected a rig file name or a [rig] table, got {rig!r}")
    if not isinstance(rig, str):
        return ()
    if not rig.strip():
        raise ConfigError(source, "rig", "expected a rig file name, got an empty string")
    rig_path = (base / rig) if not Path(rig).is_absolute() else Path(rig)
    if not rig_path.exists():
        raise ConfigError(source, "rig", f"rig file {str(rig_path)!r} does not exist")
    if scene_path is not None and same_file(rig_path, scene_path):
        raise ConfigError(source, "rig", f"names the scene file itself ({rig!r})")
    rig_raw = read_toml(rig_path)
    extra = set(rig_raw) - {"rig"}
    if extra or "rig" not in rig_raw:
        raise ConfigError(
            str(rig_path), ", ".join(sorted(extra)) or "rig", "a rig file holds only [rig]"
        )
    if not isinstance(rig_raw["rig"], Mapping):
        raise ConfigError(
            str(rig_path),
            "rig",
            f"a rig file holds a [rig] table, got rig = {rig_raw['rig']!r} "
            f"(named by {source!r}; a rig file cannot name another)",
        )
    raw["rig"] = dict(rig_raw["rig"])
    return (str(rig_path),)


def _copy_tables(tables: Mapping[str, Any]) -> dict[str, Any]:
    """A scene's tables copied two levels deep (a table's lists copied too), so that
    applying overrides never changes the caller's mapping."""
    if not isinstance(tables, Mapping):
        raise ConfigError("<scene>", "", f"expected a mapping of tables, got {tables!r}")
    return {
        name: {k: list(v) if isinstance(v, list) else v for k, v in table.items()}
        if isinstance(table, Mapping)
        else table
        for name, table in tables.items()
    }


Overrides = Iterable[str] | Mapping[str, Any]  # "table.key=value" texts, or {key: value}


def apply_overrides(raw: dict[str, Any], overrides: Overrides) -> frozenset[str]:
    """Apply ``--set`` texts (``"damping.ratio=0.01"``) or a ``{dotted key: value}``
    mapping to raw scene tables, in place; returns the keys set."""
    if isinstance(overrides, Mapping):
        pairs = [(str(key), value) for key, value in overrides.items()]
    else:
        pairs = [parse_override(text) for text in overrides]
    for key, value in pairs:
        apply_override(raw, key, value)
    return frozenset(key for key, _ in pairs)


def load_scene(path: str | Path, overrides: Overrides = ()) -> Scene:
    """Read, override and validate a scene file (or a rig file, which gets defaults).

    An error in the values of a rig file the scene names is reported under the rig
    file's name; one in a value given by an override, under ``--set``.
    """
    raw, inputs = read_scene_files(path)
    overridden = apply_overrides(raw, overrides)
    rig_source = inputs[1] if len(inputs) > 1 else None
    try:
        scene = scene_from_dict(raw, source=str(path), rig_source=rig_source)
    except ConfigError as exc:
        raise from_command_line(exc, overridden) from None
    return replace(scene, inputs=inputs, overridden=overridden)


def from_command_line(exc: ConfigError, overridden: Iterable[str]) -> ConfigError:
    """The error to report: under ``--set`` when its key was given by an override (the
    bad value came from the command line), else ``exc`` itself."""
    if exc.key in set(overridden):
        return ConfigError("--set", exc.key, exc.reason)
    return exc


def read_rig(path: str | Path) -> tuple[RigConfig, str]:
    """The rig of a rig file or of a scene file, and the file its values came from (the
    rig file a scene names, else ``path``)."""
    raw, inputs = read_scene_files(path)
    rig = raw.get("rig")
    if rig is None:
        raise ConfigError(str(path), "rig", "missing: give rig = 'file.toml' or a [rig] table")
    return rig_from_table(inputs[-1], rig), inputs[-1]


def load_rig(path: str | Path) -> RigConfig:
    """The rig of a rig file or of a scene file."""
    return read_rig(path)[0]
