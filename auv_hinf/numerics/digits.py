"""Numbers rounded to significant digits in a chosen direction.

A printed bound must stay a bound (0.140299 m is printed 0.141 m, not 0.14 m), and an advised
value must stay on the side that holds (a smallest radius of 20.00015 m is advised as 20.01 m,
not as the 20 m that does not fit). The rounding is exact on the number's shortest decimal form
(:class:`decimal.Decimal`), so no binary round-off can move it to the wrong side.
"""

from __future__ import annotations

import math
from decimal import ROUND_CEILING, ROUND_FLOOR, Decimal

#: Significant digits of a value advised to a user: a configuration value is printed with them when they
#: give it back exactly (:meth:`~auv_hinf.certificate.reason.Setting.toml`), so an advised value rounded to
#: them (towards its certified side, :func:`significant`) is printed as it was certified.
ADVISED_DIGITS = 4


def significant(x: float, digits: int, *, up: bool) -> float:
    """``x`` rounded to ``digits`` significant digits, towards ``+inf`` (``up``) or ``-inf``.

    Parameters
    ----------
    x : float
        The number (any unit); zero and non-finite values are returned as they are.
    digits : int
        Significant digits kept (>= 1).
    up : bool
        Round towards ``+inf`` (else towards ``-inf``).

    Returns
    -------
    float
        The rounded number, in the unit of ``x``.
    """
    if not math.isfinite(x) or x == 0.0:
        return x
    return float(significant_decimal(Decimal(repr(float(x))), digits, up=up))


def significant_decimal(d: Decimal, digits: int, *, up: bool) -> Decimal:
    """:func:`significant` of a decimal number, exactly (for a value computed in decimal, such as an offset).

    Parameters
    ----------
    d : decimal.Decimal
        The number (any unit; finite); zero is returned as it is.
    digits : int
        Significant digits kept (>= 1).
    up : bool
        Round towards ``+inf`` (else towards ``-inf``).
    """
    if d == 0:
        return d
    return d.quantize(Decimal(1).scaleb(d.adjusted() - digits + 1), rounding=ROUND_CEILING if up else ROUND_FLOOR)


__all__ = ["ADVISED_DIGITS", "significant", "significant_decimal"]
