"""The one bisection of the toolbox: the boundary of a predicate on an interval.

Every "largest X that certifies" search (start regions, decay rates, sample times, box
scales, bandwidths, turn radii) and every "smallest X that meets a bound" is a bisection on a
predicate that holds at one end of an interval and fails at the other. :func:`bisect` shrinks
that bracket; :func:`largest_holding` adds the two end checks of a search on ``[lo, hi]``.

Both return only points at which the predicate was *evaluated*: a caller that reports the
holding end reports a value that was itself certified, whether or not the predicate is
monotone (monotonicity decides only whether it is also the largest).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Literal, overload

from auv_hinf.exceptions import ParameterError


def bisect(
    holds: Callable[[float], bool],
    lo: float,
    hi: float,
    *,
    rtol: float = 0.0,
    atol: float = 0.0,
    steps: int | None = None,
    geometric: bool = False,
) -> tuple[float, float]:
    """Shrink ``[lo, hi]`` around the boundary of ``holds``, which holds at ``lo`` and fails at ``hi``.

    Neither end is evaluated: the caller knows them. Each step evaluates the midpoint
    (arithmetic, or ``sqrt(lo hi)`` with ``geometric``) and keeps the half whose ends still
    hold and fail.

    Parameters
    ----------
    holds : callable
        The predicate (the end at which it holds may be the upper one: pass ``lambda x: not ...``).
    lo, hi : float
        The bracket, in the predicate's unit; ``0 < lo`` with ``geometric``.
    rtol, atol : float
        Stop when ``hi - lo <= max(atol, rtol |hi|)`` (``hi / lo <= 1 + rtol`` with ``geometric``).
    steps : int, optional
        Stop after exactly this many evaluations instead.
    geometric : bool
        Bisect at the geometric midpoint ``sqrt(lo hi)`` instead of the arithmetic one.

    Returns
    -------
    tuple of float
        ``(lo, hi)``: the last evaluated point that holds (or the given ``lo``) and the last that
        fails (or the given ``hi``).

    Raises
    ------
    ParameterError
        If no stopping rule is given, or ``geometric`` with ``lo <= 0``.
    """
    if steps is None and rtol <= 0.0 and atol <= 0.0:
        raise ParameterError("bisect needs rtol > 0, atol > 0 or a number of steps")
    if geometric and not lo > 0.0:
        raise ParameterError(f"a geometric bisection needs lo > 0, got {lo!r}")

    def wide(a: float, b: float) -> bool:
        if geometric:
            return b / a > 1.0 + rtol
        return b - a > max(atol, rtol * abs(b))

    n = 0
    while (n < steps) if steps is not None else wide(lo, hi):
        mid = math.sqrt(lo * hi) if geometric else 0.5 * (lo + hi)
        lo, hi = (mid, hi) if holds(mid) else (lo, mid)
        n += 1
    return lo, hi


@overload
def largest_holding(
    holds: Callable[[float], bool],
    hi: float,
    *,
    lo: float = ...,
    check_lo: Literal[False],
    rtol: float = ...,
    atol: float = ...,
    steps: int | None = ...,
) -> float: ...


@overload
def largest_holding(
    holds: Callable[[float], bool],
    hi: float,
    *,
    lo: float = ...,
    check_lo: bool = ...,
    rtol: float = ...,
    atol: float = ...,
    steps: int | None = ...,
) -> float | None: ...


def largest_holding(
    holds: Callable[[float], bool],
    hi: float,
    *,
    lo: float = 0.0,
    check_lo: bool = True,
    rtol: float = 0.0,
    atol: float = 0.0,
    steps: int | None = None,
) -> float | None:
    """Largest evaluated ``x`` in ``[lo, hi]`` at which ``holds``: ``hi`` itself when it holds there.

    ``holds(hi)`` is evaluated first, then ``holds(lo)`` (only with ``check_lo``: a caller that
    has checked it passes ``False``), then :func:`bisect` with the given stopping rule.

    Parameters
    ----------
    holds : callable
        The predicate, expected to hold at ``lo`` and fail above some point.
    hi : float
        Upper end of the search, in the predicate's unit.
    lo : float
        Lower end of the search.
    check_lo : bool
        Evaluate ``holds(lo)`` (and return None when it fails); ``False`` when the caller knows
        it holds.
    rtol, atol : float
        Stopping tolerances of the bisection, as in :func:`bisect`.
    steps : int, optional
        Number of bisection evaluations instead, as in :func:`bisect`.

    Returns
    -------
    float or None
        ``None`` when ``holds(lo)`` fails.
    """
    if holds(hi):
        return hi
    if check_lo and not holds(lo):
        return None
    return bisect(holds, lo, hi, rtol=rtol, atol=atol, steps=steps)[0]


__all__ = ["bisect", "largest_holding"]
