"""What a sweep runs: a set of task parameters × robots × stacks, as numbered cases.

A sweep's parameter space is a :class:`Grid` (every combination of the listed
values) or a :class:`Uniform` random set (``n`` points drawn in a box). Each
point is crossed with every robot and every stack; the case index runs over
``(robot, stack, point)`` with the point fastest:

.. math::

    i = (r \\cdot n_{stacks} + s) \\cdot n_{points} + p

Case ``i``'s seed derives from the sweep seed and its point index ``p``
(``numpy.random.SeedSequence([seed, p])``), so the robots and stacks of one
point share its seed, and a :class:`Uniform` point is drawn from that seed
alone: any case can be rebuilt from ``(sweep, i)`` without the others.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from pik_mj import inputs
from pik_mj.exceptions import InvalidInput, UnknownName
from pik_mj.sweep.case import DEFAULT_HAND, PARAMETERS, REQUIRED, STACKS


def _name(name: Any) -> str:
    if name not in PARAMETERS:
        raise InvalidInput(
            f"unknown sweep parameter {name!r}; valid parameters: "
            + ", ".join(f"{k} ({v})" for k, v in PARAMETERS.items())
        )
    return str(name)


def _values(values: Any, name: str) -> list[Any]:
    """The values of grid axis ``name``: a number or a list of them."""
    if isinstance(values, (str, bytes, Mapping)):
        raise InvalidInput(f"grid axis {name!r} must be numbers [m], got {values!r}")
    return list(np.atleast_1d(np.asarray(values, dtype=object)))


@dataclass(frozen=True)
class Grid:
    """Every combination of the listed parameter values.

    Args:
        axes: Parameter name -> its values, e.g. ``{"x": np.linspace(0.1, 0.8, 8),
            "y": [-0.2, 0.0], "z": [1.0]}`` (world frame [m]; see
            :data:`pik_mj.sweep.case.PARAMETERS`). The last axis varies fastest.
    """

    axes: Mapping[str, Sequence[float]]

    def __post_init__(self) -> None:
        if not isinstance(self.axes, Mapping) or not self.axes:
            raise InvalidInput(f"a Grid needs a mapping name -> values, got {self.axes!r}")
        axes = {}
        for name, values in self.axes.items():
            key = _name(name)
            vals = tuple(
                inputs.real(v, f"grid value of {name!r}", unit="m") for v in _values(values, name)
            )
            if not vals:
                raise InvalidInput(f"grid axis {name!r} has no values")
            if len(set(vals)) != len(vals):
                raise InvalidInput(f"grid axis {name!r} repeats a value: {vals}")
            axes[key] = vals
        object.__setattr__(self, "axes", axes)

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(self.axes)

    def __len__(self) -> int:
        return math.prod(len(v) for v in self.axes.values())

    def point(self, p: int, seed: int) -> dict[str, float]:
        """Point ``p`` (row-major over the axes; ``seed`` unused)."""
        out = {}
        for name, values in reversed(self.axes.items()):
            p, k = divmod(p, len(values))
            out[name] = values[k]
        return {name: out[name] for name in self.axes}

    def to_dict(self) -> dict[str, Any]:
        return {"grid": {k: list(v) for k, v in self.axes.items()}}


@dataclass(frozen=True)
class Uniform:
    """``n`` points drawn uniformly in a box, point ``p`` from its own seed.

    Args:
        bounds: Parameter name -> ``(low, high)``; ``low == high`` fixes it.
        n: Number of points.
    """

    bounds: Mapping[str, tuple[float, float]]
    n: int

    def __post_init__(self) -> None:
        if not isinstance(self.bounds, Mapping) or not self.bounds:
            raise InvalidInput(
                f"a Uniform set needs a mapping name -> (low, high), got {self.bounds!r}"
            )
        n = inputs.integer(self.n, "n", low=1)
        bounds = {}
        for name, pair in self.bounds.items():
            pair_like = isinstance(pair, (Sequence, np.ndarray)) and not isinstance(pair, str)
            if not pair_like or len(pair) != 2:
                raise InvalidInput(f"range of {name!r} must be (low, high) [m], got {pair!r}")
            lo, hi = (inputs.real(v, f"range of {name!r}", unit="m") for v in pair)
            if lo > hi:
                raise InvalidInput(f"range of {name!r} is inverted: low {lo} > high {hi}")
            bounds[_name(name)] = (lo, hi)
        object.__setattr__(self, "bounds", bounds)
        object.__setattr__(self, "n", n)

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(self.bounds)

    def __len__(self) -> int:
        return self.n

    def point(self, p: int, seed: int) -> dict[str, float]:
        """Point ``p``: one uniform draw per parameter from ``default_rng(seed)``."""
        rng = np.random.default_rng(seed)
        return {k: float(rng.uniform(lo, hi)) for k, (lo, hi) in self.bounds.items()}

    def to_dict(self) -> dict[str, Any]:
        return {"uniform": {k: list(v) for k, v in self.bounds.items()}, "n": self.n}


Space = Grid | Uniform


@dataclass(frozen=True)
class Case:
    """One case of a sweep: solve, static check and hold of one point.

    Attributes:
        index: Case index (see the module docstring).
        robot: Robot model name or MJCF path.
        stack: Stack name (:data:`pik_mj.sweep.case.STACKS`).
        params: Parameter name -> value (world frame, SI units).
        seed: The case's seed (from the sweep seed and the point index).
        point: Point index in the parameter space.
    """

    index: int
    robot: str
    stack: str
    params: dict[str, float]
    seed: int
    point: int


def point_seed(seed: int, point: int) -> int:
    """Seed of point ``point`` of a sweep seeded ``seed`` (a 63-bit integer)."""
    state = np.random.SeedSequence([int(seed), int(point)]).generate_state(1, np.uint64)[0]
    return int(state >> np.uint64(1))  # fits Parquet's int64


@dataclass(frozen=True)
class Sweep:
    """A sweep: ``space`` × ``robots`` × ``stacks``, each case solved, checked, held.

    Args:
        space: The parameter points (:class:`Grid` or :class:`Uniform`); must set
            the hand target ``x``, ``y``, ``z``.
        robots: Robot model names (or MJCF paths) of :func:`pik_mj.robot.loading.load_spec`.
        stacks: Stack names, see :data:`pik_mj.sweep.case.STACKS`.
        seed: Sweep seed.
        hold: Duration of each physics hold [s].
        hand: Limb whose end frame is sent to the target.
    """

    space: Space
    robots: tuple[str, ...] = ("sample_humanoid",)
    stacks: tuple[str, ...] = ("balanced", "unbalanced")
    seed: int = 0
    hold: float = 3.0
    hand: str = DEFAULT_HAND

    def __post_init__(self) -> None:
        if not isinstance(self.space, (Grid, Uniform)):
            raise InvalidInput(f"space must be a Grid or a Uniform set, got {self.space!r}")
        missing = [k for k in REQUIRED if k not in self.space.names]
        if missing:
            raise InvalidInput(f"the sweep's space must set {missing} (hand target [m])")
        for what in ("robots", "stacks"):
            names = inputs.names(getattr(self, what), what)
            if not names:
                raise InvalidInput(f"{what} must name at least one, got none")
            if len(set(names)) != len(names):
                raise InvalidInput(f"{what} repeat a name: {list(names)}")
            object.__setattr__(self, what, names)
        for s in self.stacks:
            if s not in STACKS:
                raise UnknownName("stack", s, STACKS)
        object.__setattr__(self, "seed", inputs.integer(self.seed, "seed", low=0))
        hold = inputs.real(self.hold, "hold", unit="s", low=0, low_open=True)
        object.__setattr__(self, "hold", hold)
        if not isinstance(self.hand, str) or not self.hand:
            raise InvalidInput(f"hand must be a limb name, got {self.hand!r}")

    def __len__(self) -> int:
        return len(self.robots) * len(self.stacks) * len(self.space)

    @property
    def parameters(self) -> tuple[str, ...]:
        """Parameter names, in the space's order."""
        return self.space.names

    def cases(self) -> list[Case]:
        """Every case, by index."""
        n = len(self.space)
        seeds = [point_seed(self.seed, p) for p in range(n)]
        points = [self.space.point(p, seeds[p]) for p in range(n)]
        combos = [(r, s, p) for r in self.robots for s in self.stacks for p in range(n)]
        return [
            Case(i, robot, stack, dict(points[p]), seeds[p], p)
            for i, (robot, stack, p) in enumerate(combos)
        ]

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready definition; :meth:`from_dict` rebuilds it."""
        return {
            "space": self.space.to_dict(),
            "robots": list(self.robots),
            "stacks": list(self.stacks),
            "seed": self.seed,
            "hold": self.hold,
            "hand": self.hand,
        }

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> Sweep:
        """The sweep of :meth:`to_dict`."""
        try:
            sp = data["space"]
            space: Space
            if "grid" in sp:
                space = Grid(sp["grid"])
            else:
                space = Uniform({k: tuple(v) for k, v in sp["uniform"].items()}, sp["n"])
            return cls(
                space,
                robots=tuple(data["robots"]),
                stacks=tuple(data["stacks"]),
                seed=data["seed"],
                hold=data["hold"],
                hand=data["hand"],
            )
        except (KeyError, TypeError) as exc:
            raise InvalidInput(f"not a sweep definition ({exc!r}): {dict(data)!r}") from None
