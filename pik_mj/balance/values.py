"""Checks of the balance functions' inputs: finite arrays of a shape, real numbers."""

from __future__ import annotations

import math

import numpy as np

from pik_mj.exceptions import InvalidInput


def finite_array(value: object, shape: tuple[int | None, ...], name: str) -> np.ndarray:
    """Returns ``value`` as a finite float array of ``shape`` (None = any length)."""
    try:
        arr = np.array(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise InvalidInput(f"{name} must be a numeric array of shape {shape}") from exc
    if arr.ndim != len(shape) or any(
        s is not None and s != n for s, n in zip(shape, arr.shape, strict=True)
    ):
        want = "(" + ", ".join("n" if s is None else str(s) for s in shape) + ")"
        raise InvalidInput(f"{name} must have shape {want}, got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise InvalidInput(f"{name} must be finite (no NaN/inf), got {arr}")
    return arr


def real(value: object, name: str, *, allow_inf: bool = False) -> float:
    """``value`` as a float, finite unless ``allow_inf``."""
    try:
        x = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError) as exc:
        raise InvalidInput(f"{name} must be a real number, got {value!r}") from exc
    if math.isnan(x) or (not allow_inf and math.isinf(x)):
        raise InvalidInput(f"{name} must be finite, got {x}")
    return x
