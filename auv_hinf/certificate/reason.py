"""Reasons as data: why a certificate part does not hold, and the settings that would certify.

A :class:`Reason` names its part, its kind (:data:`REASON_KINDS`), the channel, the vehicle,
the value and the limit, and the :class:`Setting`\\ s of the configuration that would change the
verdict, next to the sentence a person reads. No code decides anything from the sentence.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any, Literal, get_args

from auv_hinf.config.schema import key_unit
from auv_hinf.exceptions import DesignError, SolverError
from auv_hinf.numerics.digits import ADVISED_DIGITS, significant

#: What a reason says, in one word (``Reason.kind``):
#:
#: * ``design``: the gain design gives no gains (infeasible method, failed synthesis);
#: * ``marginal``: a strict inequality holds only up to its tolerance;
#: * ``hypothesis``: a hypothesis of the theorem fails (a singular case, a sign);
#: * ``disagrees``: independent computations of one number disagree;
#: * ``envelope``: the desired motion or the certified set leaves the operating envelope;
#: * ``start``: the configured start is outside the certified start set;
#: * ``thrust``: the certified commanded force exceeds the actuators' limits;
#: * ``not_covered``: the certificate does not cover what was declared (the sub-reasons say why);
#: * ``unsupported``: the declared case is outside what the certificate covers (a time-varying current);
#: * ``solver``: a numerical route failed or did not re-verify;
#: * ``advice``: not a failure: the settings that would certify, with their values.
ReasonKind = Literal[
    "design",
    "marginal",
    "hypothesis",
    "disagrees",
    "envelope",
    "start",
    "thrust",
    "not_covered",
    "unsupported",
    "solver",
    "advice",
]

REASON_KINDS: tuple[ReasonKind, ...] = get_args(ReasonKind)


def _number(v: Any) -> str:
    """``v`` (a number, or a nested list of them) with :data:`~auv_hinf.numerics.digits.ADVISED_DIGITS`
    significant digits when they give it back exactly.

    Else its shortest exact form; a list is written as a TOML array (a formation's ``shape``).
    """
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_number(x) for x in v) + "]"
    if not isinstance(v, float):
        return str(v)
    short = f"{v:.{ADVISED_DIGITS}g}"
    return short if float(short) == v else repr(v)


def upper(x: float, digits: int = 3) -> str:
    """A certified upper bound ``x`` printed with ``digits`` significant digits, rounded up.

    Rounding to the nearest could print a bound below the certified one (0.140299 m as 0.14 m);
    rounding towards ``+inf`` keeps the printed number a bound. Non-finite values print as they are.

    Parameters
    ----------
    x : float
        The bound (any unit).
    digits : int
        Significant digits (>= 1).
    """
    if not math.isfinite(x) or x == 0.0:
        return f"{x:g}"
    return f"{significant(x, digits, up=True):.{digits}g}"


def apart(value: float, bound: float, digits: int = 4) -> tuple[str, str]:
    """``value`` and ``bound`` printed with the fewest significant digits (at least ``digits``) that tell them apart.

    A value just above its bound (0.0300001 m/s against 0.03 m/s) printed at four digits reads as
    equal to it; more digits are used until the two differ (up to 17, where equal floats print equal).

    Parameters
    ----------
    value, bound : float
        The two numbers.
    digits : int
        The fewest significant digits.
    """
    for d in range(digits, 18):
        a, b = f"{value:.{d}g}", f"{bound:.{d}g}"
        if a != b:
            return a, b
    return f"{value:.17g}", f"{bound:.17g}"


@dataclass(frozen=True)
class Setting:
    """A value of the configuration that would change a verdict.

    Attributes
    ----------
    table : str
        The TOML table (``"uncertainty"``, ``"disturbance"``, ``"implementation"``, ...).
    key : str
        The key in that table, as the user writes it.
    value : Any
        The value to write there (a number in the key's unit, or a ``[lo, hi]`` pair).
    """

    table: str
    key: str
    value: Any

    @property
    def unit(self) -> str:
        """The key's unit as the configuration's schema declares it (``""``: dimensionless)."""
        return key_unit(self.table, self.key)

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe dictionary: ``table``, ``key``, ``value`` and the value's ``unit``."""
        return {"table": self.table, "key": self.key, "value": self.value, "unit": self.unit}

    def toml(self) -> str:
        """The value as a user writes it: ``[table] key = value`` (``remove [table] key`` for ``None``).

        A float is printed with 4 significant digits when they give it back exactly, else in
        full: a value rounded for reading could break a constraint of the configuration (a
        lawn-mower's spacing against its turn radius) or leave the certified side.
        """
        v = self.value
        if v is None:
            return f"remove [{self.table}] {self.key}"
        text = f'"{v}"' if isinstance(v, str) else "true" if v is True else "false" if v is False else None
        if text is None:
            text = _number(v)
        return f"[{self.table}] {self.key} = {text}"

    def words(self) -> str:
        """:meth:`toml` followed by the key's unit, for a sentence: ``[disturbance] current_speed = 0.05 m/s``."""
        unit = self.unit
        return self.toml() + (f" {unit}" if unit and self.value is not None else "")

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> Setting:
        """Inverse of :meth:`to_dict`.

        Parameters
        ----------
        data : mapping
            ``table``, ``key`` and ``value`` (a ``unit`` is the schema's, and is not read).
        """
        return cls(str(data["table"]), str(data["key"]), data["value"])


def toml_line(settings: Iterable[Setting]) -> str:
    """The settings as a user writes them, comma-separated (:meth:`Setting.toml`), each followed by its unit.

    Parameters
    ----------
    settings : iterable of Setting
        The values.
    """
    return ", ".join(s.words() for s in settings)


@dataclass(frozen=True)
class Reason:
    """Why a part does not hold, as data, with the sentence a person reads.

    Attributes
    ----------
    part : str
        The part's registry name.
    kind : str
        One of :data:`REASON_KINDS`.
    message : str
        The sentence printed under ``CERTIFIED: no`` and in ``certify --json``'s ``reasons``.
    channel : str, optional
        What is measured: a force channel (``force_x``, ``force_y``, ``moment``), an envelope
        channel (``u``, ``v``, ``r``), ``sample_time``, ``delay``, ...
    vehicle : int, optional
        The vehicle it is about (0-based), when one vehicle binds.
    value, limit : float, optional
        The value found and the limit it is held against (in the channel's unit).
    settings : tuple of Setting
        Configuration values that would certify (empty when none is known).
    """

    part: str
    kind: str
    message: str
    channel: str | None = None
    vehicle: int | None = None
    value: float | None = None
    limit: float | None = None
    settings: tuple[Setting, ...] = ()

    def __post_init__(self) -> None:
        if self.kind not in REASON_KINDS:
            raise ValueError(f"reason kind must be one of {REASON_KINDS}, got {self.kind!r}")

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe dictionary."""
        return {
            "part": self.part,
            "kind": self.kind,
            "message": self.message,
            "channel": self.channel,
            "vehicle": self.vehicle,
            "value": self.value,
            "limit": self.limit,
            "settings": [s.to_dict() for s in self.settings],
        }

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> Reason:
        """Inverse of :meth:`to_dict`.

        Parameters
        ----------
        data : mapping
            ``part``, ``kind`` and ``message``, and optionally the other attributes.
        """
        return cls(
            part=str(data["part"]),
            kind=str(data["kind"]),
            message=str(data["message"]),
            channel=data.get("channel"),
            vehicle=data.get("vehicle"),
            value=data.get("value"),
            limit=data.get("limit"),
            settings=tuple(Setting.from_dict(s) for s in data.get("settings") or ()),
        )


def reason_from(part: str, exc: Exception, prefix: str = "") -> Reason:
    """The :class:`Reason` of a refusal raised as an exception (its message after ``prefix``).

    A :class:`~auv_hinf.exceptions.DesignError` carries its kind and data; a
    :class:`~auv_hinf.exceptions.SolverError` is a ``solver`` reason; anything else ``not_covered``.

    Parameters
    ----------
    part : str
        The part's registry name.
    exc : Exception
        The refusal.
    prefix : str
        Text put before the exception's message.
    """
    message = prefix + str(exc)
    if isinstance(exc, DesignError):
        return Reason(
            part,
            exc.kind if exc.kind in REASON_KINDS else "not_covered",
            message,
            channel=exc.channel,
            vehicle=exc.vehicle,
            value=exc.value,
            limit=exc.limit,
            settings=tuple(Setting(t, k, v) for t, k, v in exc.settings),
        )
    return Reason(part, "solver" if isinstance(exc, SolverError) else "not_covered", message)


__all__ = ["REASON_KINDS", "Reason", "ReasonKind", "Setting", "apart", "reason_from", "toml_line", "upper"]
