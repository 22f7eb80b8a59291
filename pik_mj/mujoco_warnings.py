"""MuJoCo's C warnings, routed to Python.

:func:`mujoco_warnings` is the one place where pik_mj takes MuJoCo's warnings (without
a handler MuJoCo prints them and appends them to ``MUJOCO_LOG.TXT`` in the working
directory): collected into a list, or re-raised as Python ``RuntimeWarning``\\ s,
expected ones (e.g. the empty attach prefix pik_mj uses on purpose) dropped.
"""

from __future__ import annotations

import warnings
from collections.abc import Iterator, Sequence
from contextlib import contextmanager

import mujoco

__all__ = ["mujoco_warnings"]


@contextmanager
def mujoco_warnings(
    messages: list[str] | None = None, *, expected: Sequence[str] = ()
) -> Iterator[list[str]]:
    """Route MuJoCo's C warnings to Python inside the block.

    Args:
        messages: List the warnings are appended to; None re-raises each as a
            Python ``RuntimeWarning`` ("MuJoCo: ...").
        expected: Substrings of warnings that are dropped.

    Yields:
        The list the warnings go to (``messages``, or a new one).
    """
    out: list[str] = [] if messages is None else messages

    def handler(message: str) -> None:
        if any(s in message for s in expected):
            return
        if messages is None:
            warnings.warn(f"MuJoCo: {message}", RuntimeWarning, stacklevel=2)
        out.append(message)

    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(handler)
    try:
        yield out
    finally:
        mujoco.set_mju_user_warning(previous)
