"""Argparse types of the scenarios' options: each refuses a bad value with the reason
:mod:`pik_mj.inputs` gives (argparse then reports ``argument --name: <reason>``)."""

from __future__ import annotations

import argparse
from collections.abc import Callable
from typing import Any

from pik_mj import inputs
from pik_mj.exceptions import InvalidInput


def argument_type(check: Callable[[str], Any]) -> Callable[[str], Any]:
    """An argparse type from a check raising :class:`InvalidInput` (the message
    becomes argparse's, after ``argument --name:``)."""

    def convert(text: str) -> Any:
        try:
            return check(text)
        except InvalidInput as exc:
            raise argparse.ArgumentTypeError(str(exc)) from None

    convert.__name__ = check.__name__
    return convert


def as_number(text: str) -> float | str:
    """``text`` as a float, else ``text`` itself (refused by :func:`pik_mj.inputs.real`,
    which names it)."""
    try:
        return float(text)
    except ValueError:
        return text


def as_integer(text: str) -> int | str:
    """``text`` as an int, else ``text`` itself (refused by
    :func:`pik_mj.inputs.integer`, which names it)."""
    try:
        return int(text)
    except ValueError:
        return text


@argument_type
def duration(text: str) -> float:
    """An argparse type: a duration >= 0 [s]."""
    return inputs.real(as_number(text), "a duration", unit="s", low=0)


@argument_type
def positive(text: str) -> float:
    """An argparse type: a finite number > 0."""
    return inputs.real(as_number(text), "a value", low=0, low_open=True)


@argument_type
def finite(text: str) -> float:
    """An argparse type: a finite number."""
    return inputs.real(as_number(text), "a value")


@argument_type
def count(text: str) -> int:
    """An argparse type: an integer >= 1."""
    return inputs.integer(as_integer(text), "a count", low=1)


@argument_type
def fraction(text: str) -> float:
    """An argparse type: a fraction in [0, 1]."""
    return inputs.real(as_number(text), "a fraction", low=0, high=1)
