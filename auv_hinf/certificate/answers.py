"""Answers as settings: a world a bisection on certificates found, written as a user writes it.

An answer is certified at the values the search found; written with a few significant digits it must
lie inside that world, so every range of a box is rounded inwards and a current down.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from decimal import Decimal
from typing import Any

from auv_hinf.certificate.reason import Setting
from auv_hinf.numerics.digits import ADVISED_DIGITS, significant, significant_decimal

#: Offset from the model (a fraction of its value) below which an advised box's range is written as the
#: model itself: a spread of 1e-9 is no vehicle's uncertainty, and its 16-digit value no one's to type.
OFFSET_FLOOR = Decimal("1e-9")


def advice(best: Mapping[str, Any] | None) -> tuple[Setting, ...]:
    """The settings of ``largest_certifiable`` to re-run with: the scaled ``[uncertainty]`` table and the current.

    Each range of the box is written with :data:`~auv_hinf.numerics.digits.ADVISED_DIGITS` significant
    digits of its distance from the model (1), rounded inwards, and the current with as many, rounded
    down: the world written lies inside the one certified (a bisection's ``[0.985101318359375,
    1.014898681640625]`` is written ``[0.98511, 1.01489]``, its ``0.009228515625`` m/s ``0.009228``).

    Parameters
    ----------
    best : mapping or None
        A :func:`~auv_hinf.robust.margin.largest_certifiable` answer (its ``uncertainty`` table and
        ``current_speed``, m/s); ``None``: no answer.
    """
    if best is None or best.get("current_speed") is None:
        return ()
    out = [Setting("uncertainty", name, inwards(pair)) for name, pair in (best.get("uncertainty") or {}).items()]
    out.append(Setting("disturbance", "current_speed", significant(best["current_speed"], ADVISED_DIGITS, up=False)))
    return tuple(out)


def inwards(pair: Sequence[float]) -> list[float]:
    """A box's range ``[lo, hi]`` (multiples of the model's value) with short offsets from 1, rounded inwards.

    The offsets are taken and rounded in decimal (0.9 is 1 - 0.1, and 1 - 0.3906 is written 0.6094); an
    offset below :data:`OFFSET_FLOOR` is written 0, the model's value, also inside the box.

    Parameters
    ----------
    pair : sequence of float
        The range ``[lo, hi]`` (dimensionless multiples of the model's value).
    """
    out = []
    for x, up in zip(pair, (True, False), strict=True):
        offset = Decimal(repr(float(x))) - 1
        short = Decimal(0) if abs(offset) < OFFSET_FLOOR else significant_decimal(offset, ADVISED_DIGITS, up=up)
        out.append(float(1 + short))
    return out


__all__ = ["OFFSET_FLOOR", "advice", "inwards"]
