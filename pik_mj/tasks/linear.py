"""A task given directly by its rows (irteus' additional Jacobian / velocity hook).

The rows are constants or functions of the configuration, so a user can put any
linear(ized) objective or constraint into the cascade without writing a class:

.. math::

    \\min (A x - b)^T W_A (A x - b) + \\omega^T W_C \\omega
    \\quad \\text{s.t.} \\quad d_l \\le C x + \\omega \\le d_u
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import mink
import numpy as np

from pik_mj.exceptions import InvalidInput
from pik_mj.tasks.task import Task, TaskRows, TaskState

RowsFn = Callable[[mink.Configuration], TaskRows]


class LinearTask(Task):
    """Rows ``A x ≈ b`` and/or ``d_l <= C x <= d_u`` given by the caller.

    Args:
        A, b: Equality rows (both or neither); arrays or callables of the
            configuration returning arrays.
        C, d_lower, d_upper: Inequality rows; bounds may be ``±inf``.
        w_A: Equality weights (float or per row).
        w_C: Slack weights (float or per row).
        threshold: Stop-test tolerance on ``max |error|`` (row units).
        rows: Alternatively, a callable returning :class:`TaskRows` directly.
        name: Display name.
        check: Whether the stop test looks at this task.
    """

    def __init__(
        self,
        A: Any = None,
        b: Any = None,
        C: Any = None,
        d_lower: Any = None,
        d_upper: Any = None,
        *,
        w_A: float | np.ndarray = 1.0,
        w_C: float | np.ndarray = 1.0,
        threshold: float = 1e-6,
        rows: RowsFn | None = None,
        name: str = "linear",
        check: bool = True,
    ):
        if (A is None) != (b is None):
            raise InvalidInput(f"task {name}: give both A and b, or neither")
        if C is None and (d_lower is not None or d_upper is not None):
            raise InvalidInput(f"task {name}: bounds given without C")
        if rows is None and A is None and C is None:
            raise InvalidInput(f"task {name}: give A and b, C and bounds, or rows")
        self.A, self.b, self.C = A, b, C
        self.d_lower, self.d_upper = d_lower, d_upper
        self.w_A, self.w_C = w_A, w_C
        self.rows_fn = rows
        self.threshold = float(threshold)
        self.name = name
        self.check = check

    @staticmethod
    def _eval(value: Any, configuration: mink.Configuration) -> Any:
        return value(configuration) if callable(value) else value

    def compute_rows(self, configuration: mink.Configuration) -> TaskRows:
        nv = configuration.model.nv
        if self.rows_fn is not None:
            return self.rows_fn(configuration)
        parts = []
        if self.A is not None:
            A = np.asarray(self._eval(self.A, configuration), dtype=float)
            b = np.asarray(self._eval(self.b, configuration), dtype=float)
            if A.ndim != 2 or A.shape[1] != nv or b.shape != (A.shape[0],):
                raise InvalidInput(
                    f"task {self.name}: A must be (m, {nv}) and b (m,), got {A.shape}, {b.shape}"
                )
            parts.append(TaskRows.equality(A, b, self.w_A))
        if self.C is not None:
            C = np.asarray(self._eval(self.C, configuration), dtype=float)
            if C.ndim != 2 or C.shape[1] != nv:
                raise InvalidInput(f"task {self.name}: C must be (m, {nv}), got {C.shape}")
            lo = -np.inf if self.d_lower is None else self._eval(self.d_lower, configuration)
            hi = np.inf if self.d_upper is None else self._eval(self.d_upper, configuration)
            parts.append(TaskRows.inequality(C, lo, hi, self.w_C))
        return TaskRows.stack(parts, nv)

    def is_satisfied(self, configuration: mink.Configuration) -> bool:
        return self.evaluate(configuration).satisfied

    def evaluate(self, configuration: mink.Configuration) -> TaskState:
        """The rows once (their callables run once); the error is their
        violation at ``x = 0``, satisfied when ``max |error| <= threshold``."""
        rows = self.compute_rows(configuration)
        error = rows.violation()
        worst = float(np.max(np.abs(error), initial=0.0))
        return TaskState(rows, float(np.linalg.norm(error)), worst <= self.threshold)
