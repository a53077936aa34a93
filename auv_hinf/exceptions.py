"""Error types of auv-hinf.

Every error subclasses a builtin so that callers can catch ``ValueError`` or
``RuntimeError`` without importing this module. Messages name the quantity,
what was expected and what was found.
"""

from __future__ import annotations

import math
import numbers
from typing import Any


class AuvHinfError(Exception):
    """Base class of every error raised on purpose by auv-hinf."""


class ParameterError(AuvHinfError, ValueError):
    """A physical parameter is non-finite, negative, or otherwise invalid."""


class FormationError(AuvHinfError, ValueError):
    """A formation request is invalid (fewer than two vehicles, bad shapes)."""


class EnvelopeError(AuvHinfError, ValueError):
    """An operating envelope is empty, reversed or non-finite."""


class DesignError(AuvHinfError, ValueError):
    """A gain-design request is outside the domain of the formula asked for, or a design is refused.

    Parameters
    ----------
    message : str
        The sentence a person reads.
    kind : str
        What kind of refusal it is, as a certificate part reports it (one of
        ``auv_hinf.certificate.reason.REASON_KINDS``; ``"not_covered"`` unless the raiser knows better).
    channel, vehicle, value, limit : optional
        What binds, as data (see ``auv_hinf.certificate.reason.Reason``).
    settings : tuple of (table, key, value)
        Configuration values that would lift the refusal, when the raiser knows them.
    """

    def __init__(
        self,
        message: str,
        *,
        kind: str = "not_covered",
        channel: str | None = None,
        vehicle: int | None = None,
        value: float | None = None,
        limit: float | None = None,
        settings: tuple[tuple[str, str, Any], ...] = (),
    ) -> None:
        super().__init__(message)
        self.kind = kind
        self.channel = channel
        self.vehicle = vehicle
        self.value = value
        self.limit = limit
        self.settings = settings


class ConfigError(AuvHinfError, ValueError):
    """A configuration file or preset name is invalid."""


class SolverError(AuvHinfError, RuntimeError):
    """A numerical solver did not return a verified optimal answer."""


class LinkError(AuvHinfError, RuntimeError):
    """A vehicle link could not be opened, or a vehicle stopped sending what the loop needs."""


class LogError(AuvHinfError, ValueError):
    """A run log cannot be read or lacks a column; the message names the file and the column."""


class Interrupted(KeyboardInterrupt):
    """Ctrl-C (SIGINT) during long work, with the work finished before it kept.

    A ``KeyboardInterrupt``, so a caller that does not look for it still stops; one that does
    finds what was finished in :attr:`partial`.

    Parameters
    ----------
    done, total : int
        How many of the units of work (runs, samples) were finished, of how many asked.
    partial : Any
        What was finished (a partial campaign, the last time saved), or ``None`` when nothing was.
    """

    def __init__(self, done: int, total: int, partial: Any = None) -> None:
        super().__init__(f"interrupted after {done} of {total}")
        self.done = done
        self.total = total
        self.partial = partial


def require_finite(name: str, value: Any) -> float:
    """Return ``value`` as a float, or raise if it is not a finite real number.

    Parameters
    ----------
    name : str
        Name of the quantity, used in the error message.
    value : Any
        The value to check.

    Returns
    -------
    float
        The value converted to float.

    Raises
    ------
    ParameterError
        If the value is not a real number or is NaN or infinite.
    """
    # "20" is text, as in the configuration: never read as a number; a truth value (numpy's too) or a
    # complex number is not a real one
    kind = getattr(getattr(value, "dtype", None), "kind", "")  # a numpy scalar's or array's
    if isinstance(value, (bool, str, bytes, complex)) or (kind and kind in "bcSUO"):
        raise ParameterError(f"{name} must be a finite real number, got {value!r}")
    try:
        out = float(value)
    except (TypeError, ValueError, OverflowError):
        raise ParameterError(f"{name} must be a finite real number, got {value!r}") from None
    if not math.isfinite(out):
        raise ParameterError(f"{name} must be finite, got {out!r}")
    return out


def require_count(name: str, value: Any, minimum: int = 1) -> int:
    """Return ``value`` as an int, or raise if it is not an integer (Python's or numpy's) >= ``minimum``.

    Parameters
    ----------
    name : str
        Name of the quantity, used in the error message.
    value : Any
        The value to check.
    minimum : int
        Its least admissible value.

    Raises
    ------
    ParameterError
        If the value is a bool, not an integer, or below ``minimum``.
    """
    if not _is_count(value, minimum):
        raise ParameterError(f"{name} must be an integer >= {minimum}, got {value!r}")
    return int(value)


def _is_count(value: Any, minimum: int) -> bool:
    """``value`` is an integer (Python's or numpy's, not a bool) of at least ``minimum``."""
    return not isinstance(value, bool) and isinstance(value, numbers.Integral) and int(value) >= minimum


def require_positive(name: str, value: Any) -> float:
    """Return ``value`` as a float, or raise if it is not a finite real number > 0.

    Parameters
    ----------
    name : str
        Name of the quantity, used in the error message.
    value : Any
        The value to check.

    Raises
    ------
    ParameterError
        If the value is not finite or not > 0.
    """
    out = require_finite(name, value)
    if out <= 0.0:
        raise ParameterError(f"{name} must be > 0, got {out!r}")
    return out


def require_fleet_size(n: Any, minimum: int = 2) -> int:
    """Return ``n`` as an int, or raise if it is not an integer number of vehicles >= ``minimum``.

    Parameters
    ----------
    n : Any
        The number of vehicles to check.
    minimum : int
        Smallest number accepted.

    Raises
    ------
    FormationError
        If ``n`` is a bool, not an integer, or below ``minimum``.
    """
    if not _is_count(n, minimum):
        raise FormationError(f"number of vehicles n must be an integer >= {minimum}, got {n!r}")
    return int(n)


__all__ = [
    "AuvHinfError",
    "ConfigError",
    "DesignError",
    "EnvelopeError",
    "FormationError",
    "Interrupted",
    "LinkError",
    "LogError",
    "ParameterError",
    "SolverError",
    "require_count",
    "require_finite",
    "require_fleet_size",
    "require_positive",
]
