"""Argument parsing of the ``auv-hinf`` command: one-line usage errors and numbers that look like options.

argparse reads a token that starts with ``-`` as an option unless it matches its own
negative-number pattern, which misses scientific notation (``-1e-3``), ``-inf`` and
comma-separated vectors (``-0.1,0``); :func:`join_numbers` rewrites those values as
``--opt=value`` for the options registered with :func:`numeric` or :data:`NUMERIC_OPTIONS`.
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

#: Exit codes: success, a negative verdict, bad input; and Ctrl-C outside a run's loop (128 + SIGINT).
EXIT_OK, EXIT_NEGATIVE, EXIT_BAD_INPUT = 0, 1, 2
#: Exit code of a failure of the toolbox itself (a defect, not a verdict): a script tells it from "not
#: certified" (1).
EXIT_INTERNAL = 3
#: Exit code after Ctrl-C (SIGINT): 128 + 2, the shell's code for a process stopped by SIGINT.
EXIT_INTERRUPTED = 130
#: The runtime monitor's actions (``run --on-violation``).
ACTIONS = ("warn", "hold", "stop")
#: The command's name in messages.
PROG = "auv-hinf"
#: Largest ``design --n``: the full-size LMI cross-check grows as (2N)^2 (25 s at N = 20).
DESIGN_MAX_N = 20


class UsageError(Exception):
    """Bad command-line arguments (exit 2)."""


class BadInput(Exception):
    """Bad input detected by the CLI itself, e.g. an unwritable ``--out`` (exit 2)."""


class Negative(Exception):
    """A negative verdict that is not a certificate, e.g. no gain to simulate with (exit 1)."""


class Stopped(Exception):
    """Ctrl-C, after the work that finished was kept: the one line to print (exit 130)."""


class Parser(argparse.ArgumentParser):
    """An argparse parser that reports usage errors as one exception (one line, exit code 2)."""

    def error(self, message: str) -> Any:
        """Raise :class:`UsageError` with ``message`` instead of printing the usage and exiting.

        Parameters
        ----------
        message : str
            The one-line message argparse gives.
        """
        raise UsageError(message)


def number(
    kind: type[int] | type[float], lo: float = -math.inf, hi: float = math.inf, *, strict: bool | str = False
) -> Callable[[str], float]:
    """An argparse type: a finite int or float in ``[lo, hi]``, with the bounds ``strict`` names excluded.

    Negative and scientific forms are included (``-1e-3``).

    Parameters
    ----------
    kind : int or float
        The type of the value.
    lo, hi : float
        The bounds, in the option's unit; infinite for none.
    strict : bool or {"lo", "hi"}
        Exclude both bounds (``True``), or only the lower (``"lo"``: ``--k1`` in ``(0, 1e6]``) or the
        upper (``"hi"``: ``--lam`` in ``[-1e6, 0)``), as the configuration's keys do.
    """
    open_lo, open_hi = strict in (True, "lo"), strict in (True, "hi")

    def parse(text: str) -> float:
        try:
            value = kind(text)
        except ValueError:
            what = "an integer" if kind is int else "a number"
            raise argparse.ArgumentTypeError(f"expected {what}, got {text!r}") from None
        if not math.isfinite(value):
            raise argparse.ArgumentTypeError(f"must be finite, got {text!r}")
        above = lo < value if open_lo else lo <= value
        below = value < hi if open_hi else value <= hi
        if not (above and below):
            raise argparse.ArgumentTypeError(f"must be {_range_text(lo, hi, open_lo, open_hi)}, got {text!r}")
        return value

    return parse


def _range_text(lo: float, hi: float, open_lo: bool, open_hi: bool) -> str:
    """``"in [1, 10]"``, ``"in [-1e+06, 0)"``, ``"< 0"`` or ``">= 0"``: the range of :func:`number` in words."""
    if math.isinf(lo) and math.isinf(hi):
        return "finite"
    if math.isinf(lo):
        return f"<{'' if open_hi else '='} {hi:g}"
    if math.isinf(hi):
        return f">{'' if open_lo else '='} {lo:g}"
    return f"in {'(' if open_lo else '['}{lo:g}, {hi:g}{')' if open_hi else ']'}"


#: Options taking a number; their values may look like options (``-1e-3``), see :func:`join_numbers`.
NUMERIC_OPTIONS: set[str] = set()


def numeric(
    p: argparse.ArgumentParser,
    flag: str,
    kind: type[int] | type[float],
    *bounds: float,
    strict: bool | str = False,
    **kw: Any,
) -> None:
    """Add the option ``flag`` taking a :func:`number` (its value may look like an option: ``-1e-3``).

    Parameters
    ----------
    p : argparse.ArgumentParser
        The parser or group.
    flag : str
        The option, ``--lam``.
    kind : int or float
        Its type.
    *bounds : float
        ``lo, hi`` of :func:`number`.
    strict : bool or {"lo", "hi"}
        Exclude both bounds, or the one named (:func:`number`).
    **kw : Any
        Other arguments of ``add_argument`` (``help``, ``default``, ...).
    """
    NUMERIC_OPTIONS.add(flag)
    p.add_argument(flag, type=number(kind, *bounds, strict=strict), **kw)


def vector(size: int, unit: str, *, positive: bool = False) -> Callable[[str], tuple[float, ...]]:
    """An argparse type: ``size`` finite comma-separated numbers (``-0.1,0``), each > 0 when ``positive``.

    Parameters
    ----------
    size : int
        How many numbers.
    unit : str
        Their units, for the message (``"N, N, N m"``).
    positive : bool
        Every number must be > 0 (actuator limits).
    """

    def parse(text: str) -> tuple[float, ...]:
        parts = text.split(",")
        try:
            values = tuple(float(p) for p in parts)
        except ValueError:
            raise argparse.ArgumentTypeError(
                f"expected {size} comma-separated numbers ({unit}), got {text!r}"
            ) from None
        if len(values) != size or not all(math.isfinite(v) for v in values):
            raise argparse.ArgumentTypeError(f"expected {size} finite comma-separated numbers ({unit}), got {text!r}")
        if positive and not all(v > 0.0 for v in values):
            raise argparse.ArgumentTypeError(f"every number must be > 0 ({unit}), got {text!r}")
        return values

    return parse


def per_vehicle(text: str) -> tuple[float, ...]:
    """An argparse type: one finite number >= 0, or a comma-separated list of them (one per vehicle).

    Parameters
    ----------
    text : str
        The option's value as typed.
    """
    try:
        values = tuple(float(p) for p in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number or comma-separated numbers, got {text!r}") from None
    if not all(math.isfinite(v) and v >= 0.0 for v in values):
        raise argparse.ArgumentTypeError(f"expected finite numbers >= 0, got {text!r}")
    return values


def path(text: str) -> Path:
    """An argparse type: a file or directory name, not empty (an empty one would mean the working directory).

    Parameters
    ----------
    text : str
        The option's value as typed.
    """
    if not text.strip():
        raise argparse.ArgumentTypeError("an empty name: give a file or directory")
    return Path(text)


def join_numbers(argv: Sequence[str]) -> list[str]:
    """Write ``--lam -1e-3`` as ``--lam=-1e-3``.

    argparse reads a token that starts with ``-`` as an option unless it matches its
    negative-number pattern, which misses scientific notation (``-1e-3``) and ``-inf``.
    The ``--opt=value`` form is always read as a value, so numeric options get it.

    Parameters
    ----------
    argv : sequence of str
        The command-line arguments (without the program name).
    """
    out: list[str] = []
    i = 0
    while i < len(argv):
        tok = argv[i]
        if tok in NUMERIC_OPTIONS and i + 1 < len(argv) and argv[i + 1].startswith("-"):
            try:
                [float(part) for part in argv[i + 1].split(",")]
            except ValueError:
                pass
            else:
                out.append(f"{tok}={argv[i + 1]}")
                i += 2
                continue
        out.append(tok)
        i += 1
    return out


__all__ = [
    "ACTIONS",
    "DESIGN_MAX_N",
    "EXIT_BAD_INPUT",
    "EXIT_INTERNAL",
    "EXIT_INTERRUPTED",
    "EXIT_NEGATIVE",
    "EXIT_OK",
    "NUMERIC_OPTIONS",
    "PROG",
    "BadInput",
    "Negative",
    "Parser",
    "Stopped",
    "UsageError",
    "join_numbers",
    "number",
    "numeric",
    "per_vehicle",
    "vector",
]
