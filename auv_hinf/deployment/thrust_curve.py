"""Blue Robotics T200 thrust curve: bollard thrust (N) against ESC pulse width (us) and supply voltage (V).

Source: Blue Robotics, *T200 Thruster: Public Performance Data, 10-20 V, September 2019* (the
workbook linked from the T200 product page, one sheet per voltage, column "Force (Kg f)"), 1100 to
1900 us in steps of 4 us (201 rows per sheet): bollard thrust (zero inflow) with the Basic ESC R3
on BLHeli_S 16.6 stock settings; pulses below 1500 us are reverse thrust. The numbers below were
taken from two public transcriptions of that workbook that agree exactly at 12, 16, 18 and 20 V;
the 14 V sheet comes from one of them (docs/deployment.md, section "The T200 curve"). They are
facts of the datasheet, stored as numbers.

:class:`T200Curve` interpolates linearly in pulse width and, between the tabulated sheets, in
voltage (12-20 V). The curve has a dead band around 1500 us (1464-1536 us at 12 V, 1472-1528 us at
16 V) with no thrust, and its reverse thrust is about 78 % of its forward thrust. Bollard data
overstates the thrust at speed. Positive thrust is the T200's forward thrust; pulses above
1500 us give it.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cache

import numpy as np
from numpy.typing import ArrayLike

from auv_hinf._typing import FloatArray
from auv_hinf.actuation.thrusters import STANDARD_GRAVITY
from auv_hinf.exceptions import ParameterError, require_finite

#: First pulse width of the table, its step and its number of rows (us, us, -).
PWM_START, PWM_STEP, PWM_COUNT = 1100, 4, 201
#: Pulse width of zero command, the ESC's neutral (us).
PWM_NEUTRAL = 1500
#: Pulse width range of the table (us).
PWM_MIN, PWM_MAX = 1100, 1900

#: Bollard thrust (kgf) at 1100, 1104, ..., 1900 us, per supply voltage (V): the workbook's
#: "Force (Kg f)" column, 14 values to a line.
_FORCE_KGF_TEXT: dict[int, str] = {
    12: """
    -2.90 -2.92 -2.89 -2.83 -2.79 -2.76 -2.72 -2.67 -2.60 -2.59 -2.56 -2.49 -2.44 -2.43
    -2.39 -2.34 -2.30 -2.25 -2.23 -2.18 -2.14 -2.10 -2.07 -2.01 -1.98 -1.95 -1.88 -1.85
    -1.81 -1.78 -1.73 -1.66 -1.65 -1.61 -1.56 -1.53 -1.49 -1.47 -1.44 -1.40 -1.37 -1.33
    -1.29 -1.28 -1.22 -1.19 -1.15 -1.12 -1.08 -1.04 -1.02 -0.99 -0.96 -0.93 -0.90 -0.87
    -0.83 -0.79 -0.77 -0.74 -0.72 -0.69 -0.66 -0.64 -0.60 -0.57 -0.54 -0.52 -0.49 -0.47
    -0.44 -0.42 -0.39 -0.37 -0.34 -0.32 -0.29 -0.27 -0.24 -0.23 -0.20 -0.18 -0.16 -0.15
    -0.12 -0.11 -0.09 -0.07 -0.06 -0.05 -0.04 0.00 0.00 0.00 0.00 0.00 0.00 0.00
    0.00 0.00 0.00 0.00 0.00 0.00 0.00 0.00 0.00 0.00 0.00 0.00 0.04 0.05
    0.07 0.10 0.11 0.13 0.15 0.18 0.20 0.22 0.25 0.28 0.31 0.33 0.37 0.39
    0.43 0.46 0.49 0.52 0.55 0.59 0.63 0.65 0.68 0.71 0.76 0.79 0.83 0.86
    0.89 0.93 0.97 1.00 1.04 1.08 1.14 1.16 1.20 1.23 1.28 1.31 1.35 1.40
    1.43 1.48 1.53 1.56 1.63 1.67 1.71 1.77 1.82 1.85 1.91 1.92 1.96 2.03
    2.09 2.13 2.18 2.24 2.27 2.33 2.40 2.46 2.51 2.56 2.62 2.65 2.71 2.78
    2.84 2.87 2.93 3.01 3.04 3.08 3.16 3.23 3.26 3.32 3.38 3.40 3.45 3.50
    3.57 3.64 3.71 3.69 3.71
    """,
    14: """
    -3.52 -3.50 -3.49 -3.45 -3.40 -3.36 -3.29 -3.25 -3.19 -3.14 -3.10 -3.06 -3.00 -2.94
    -2.88 -2.85 -2.78 -2.76 -2.69 -2.64 -2.59 -2.53 -2.49 -2.45 -2.41 -2.35 -2.34 -2.26
    -2.20 -2.18 -2.12 -2.05 -2.03 -1.99 -1.91 -1.89 -1.82 -1.76 -1.72 -1.68 -1.63 -1.58
    -1.56 -1.52 -1.48 -1.44 -1.40 -1.37 -1.32 -1.28 -1.24 -1.19 -1.17 -1.12 -1.09 -1.05
    -1.02 -0.98 -0.95 -0.92 -0.88 -0.85 -0.81 -0.77 -0.74 -0.70 -0.68 -0.65 -0.62 -0.59
    -0.55 -0.52 -0.49 -0.46 -0.43 -0.40 -0.37 -0.35 -0.32 -0.29 -0.26 -0.24 -0.21 -0.19
    -0.16 -0.15 -0.12 -0.10 -0.08 -0.07 -0.05 -0.03 0.00 0.00 0.00 0.00 0.00 0.00
    0.00 0.00 0.00 0.00 0.00 0.00 0.00 0.00 0.00 0.00 0.00 0.05 0.06 0.08
    0.10 0.12 0.15 0.18 0.20 0.23 0.26 0.29 0.33 0.36 0.39 0.43 0.46 0.50
    0.53 0.58 0.62 0.64 0.69 0.73 0.77 0.83 0.85 0.89 0.92 0.97 1.00 1.05
    1.09 1.14 1.20 1.23 1.28 1.32 1.37 1.41 1.46 1.51 1.55 1.61 1.65 1.71
    1.76 1.81 1.85 1.91 1.96 2.00 2.09 2.12 2.16 2.25 2.27 2.34 2.43 2.50
    2.56 2.64 2.66 2.76 2.78 2.88 2.93 2.99 3.05 3.13 3.19 3.23 3.32 3.36
    3.42 3.49 3.57 3.62 3.69 3.77 3.84 3.92 3.98 4.03 4.11 4.15 4.21 4.30
    4.38 4.42 4.51 4.53 4.52
    """,
    16: """
    -4.07 -4.05 -4.02 -3.96 -3.90 -3.87 -3.82 -3.80 -3.75 -3.71 -3.66 -3.59 -3.52 -3.45
    -3.40 -3.31 -3.25 -3.20 -3.11 -3.04 -2.99 -2.94 -2.86 -2.82 -2.77 -2.71 -2.66 -2.58
    -2.55 -2.51 -2.45 -2.38 -2.35 -2.28 -2.24 -2.20 -2.12 -2.08 -2.02 -1.98 -1.94 -1.86
    -1.81 -1.76 -1.70 -1.67 -1.61 -1.56 -1.51 -1.49 -1.44 -1.40 -1.35 -1.30 -1.26 -1.20
    -1.16 -1.12 -1.10 -1.05 -1.02 -0.98 -0.94 -0.90 -0.87 -0.82 -0.78 -0.74 -0.72 -0.68
    -0.65 -0.62 -0.58 -0.54 -0.51 -0.48 -0.44 -0.42 -0.39 -0.35 -0.32 -0.29 -0.26 -0.24
    -0.21 -0.18 -0.15 -0.13 -0.10 -0.09 -0.07 -0.05 -0.04 0.00 0.00 0.00 0.00 0.00
    0.00 0.00 0.00 0.00 0.00 0.00 0.00 0.00 0.00 0.00 0.04 0.05 0.08 0.10
    0.13 0.15 0.18 0.22 0.25 0.29 0.32 0.36 0.40 0.44 0.47 0.51 0.56 0.60
    0.64 0.68 0.72 0.78 0.82 0.87 0.91 0.95 0.99 1.03 1.10 1.14 1.18 1.24
    1.28 1.33 1.39 1.44 1.48 1.54 1.59 1.65 1.69 1.76 1.82 1.88 1.93 1.99
    2.05 2.12 2.18 2.22 2.28 2.38 2.43 2.52 2.58 2.65 2.73 2.76 2.84 2.89
    2.98 3.05 3.11 3.17 3.22 3.30 3.37 3.42 3.51 3.61 3.68 3.74 3.82 3.89
    3.96 4.06 4.15 4.25 4.30 4.38 4.51 4.53 4.65 4.71 4.79 4.84 4.93 5.01
    5.08 5.14 5.18 5.22 5.25
    """,
    18: """
    -4.59 -4.54 -4.53 -4.48 -4.42 -4.35 -4.35 -4.17 -4.18 -4.11 -4.04 -3.99 -3.91 -3.86
    -3.81 -3.71 -3.68 -3.56 -3.54 -3.42 -3.36 -3.27 -3.19 -3.09 -3.03 -2.96 -2.88 -2.84
    -2.78 -2.70 -2.66 -2.59 -2.53 -2.48 -2.42 -2.36 -2.32 -2.25 -2.21 -2.16 -2.11 -2.04
    -2.00 -1.94 -1.88 -1.81 -1.76 -1.72 -1.66 -1.61 -1.56 -1.52 -1.47 -1.42 -1.38 -1.33
    -1.27 -1.22 -1.17 -1.13 -1.08 -1.05 -1.01 -0.97 -0.93 -0.89 -0.86 -0.81 -0.77 -0.74
    -0.70 -0.67 -0.64 -0.60 -0.56 -0.53 -0.49 -0.46 -0.43 -0.40 -0.37 -0.34 -0.30 -0.27
    -0.24 -0.21 -0.18 -0.15 -0.13 -0.10 -0.08 -0.06 -0.05 0.00 0.00 0.00 0.00 0.00
    0.00 0.00 0.00 0.00 0.00 0.00 0.00 0.00 0.00 0.00 0.05 0.07 0.09 0.12
    0.15 0.18 0.21 0.25 0.29 0.32 0.36 0.39 0.43 0.47 0.51 0.55 0.59 0.63
    0.67 0.70 0.76 0.80 0.84 0.88 0.92 0.97 1.02 1.08 1.13 1.18 1.22 1.28
    1.32 1.38 1.42 1.49 1.54 1.60 1.68 1.74 1.79 1.84 1.92 1.97 2.04 2.08
    2.17 2.22 2.28 2.36 2.43 2.50 2.59 2.64 2.74 2.79 2.87 2.93 3.01 3.10
    3.15 3.21 3.27 3.39 3.46 3.54 3.63 3.72 3.79 3.92 4.02 4.14 4.21 4.32
    4.41 4.54 4.67 4.69 4.86 4.92 5.02 5.12 5.21 5.29 5.38 5.50 5.60 5.67
    5.77 5.82 5.90 5.98 6.02
    """,
    20: """
    -5.04 -4.96 -4.92 -4.84 -4.79 -4.74 -4.68 -4.58 -4.46 -4.40 -4.35 -4.23 -4.16 -4.12
    -4.02 -3.96 -3.89 -3.81 -3.71 -3.66 -3.56 -3.48 -3.36 -3.29 -3.16 -3.13 -3.00 -2.94
    -2.87 -2.78 -2.74 -2.67 -2.60 -2.54 -2.50 -2.44 -2.40 -2.31 -2.26 -2.20 -2.14 -2.11
    -2.04 -1.97 -1.91 -1.86 -1.80 -1.73 -1.67 -1.64 -1.58 -1.52 -1.47 -1.41 -1.37 -1.32
    -1.27 -1.22 -1.17 -1.11 -1.07 -1.02 -0.99 -0.94 -0.91 -0.88 -0.83 -0.78 -0.75 -0.72
    -0.69 -0.66 -0.63 -0.59 -0.56 -0.53 -0.50 -0.47 -0.44 -0.41 -0.39 -0.36 -0.32 -0.29
    -0.26 -0.24 -0.20 -0.17 -0.15 -0.12 -0.09 -0.07 -0.05 -0.04 0.00 0.00 0.00 0.00
    0.00 0.00 0.00 0.00 0.00 0.00 0.00 0.00 0.00 0.00 0.06 0.09 0.11 0.15
    0.18 0.21 0.25 0.29 0.32 0.36 0.39 0.43 0.47 0.50 0.54 0.57 0.61 0.64
    0.66 0.70 0.74 0.78 0.82 0.86 0.89 0.93 0.98 1.02 1.06 1.12 1.17 1.22
    1.28 1.31 1.38 1.44 1.53 1.58 1.64 1.74 1.80 1.85 1.92 1.98 2.07 2.12
    2.20 2.25 2.33 2.44 2.52 2.61 2.66 2.76 2.83 2.91 2.99 3.06 3.13 3.22
    3.28 3.36 3.44 3.55 3.64 3.72 3.85 3.96 4.10 4.21 4.33 4.42 4.55 4.70
    4.82 4.93 5.02 5.14 5.20 5.39 5.52 5.62 5.71 5.82 5.93 6.06 6.13 6.26
    6.36 6.46 6.55 6.62 6.72
    """,
}

#: Tabulated supply voltages (V).
VOLTAGES: tuple[int, ...] = tuple(sorted(_FORCE_KGF_TEXT))


@cache
def force_table(voltage: int) -> FloatArray:
    """The tabulated bollard thrust (kgf) of one sheet, shape ``(201,)``, at 1100-1900 us in 4 us steps.

    Parameters
    ----------
    voltage : int
        One of :data:`VOLTAGES` (V).

    Returns
    -------
    ndarray
        Thrust in kgf, negative for reverse.

    Raises
    ------
    ParameterError
        If ``voltage`` is not a tabulated sheet.
    """
    try:
        text = _FORCE_KGF_TEXT[voltage]
    except KeyError:
        raise ParameterError(f"the T200 table has sheets at {VOLTAGES} V, got {voltage!r}") from None
    values = np.array([float(word) for word in text.split()])
    if values.shape != (PWM_COUNT,):  # a guard on the table itself
        raise ParameterError(f"the T200 sheet at {voltage} V has {values.size} values, expected {PWM_COUNT}")
    return values


def pwm_grid() -> FloatArray:
    """Pulse widths of the table (us), shape ``(201,)``."""
    return PWM_START + PWM_STEP * np.arange(PWM_COUNT, dtype=float)


def thrust_table(voltage: float) -> FloatArray:
    """Thrust (N) at the table's pulse widths and ``voltage`` (V), linear between the sheets.

    Parameters
    ----------
    voltage : float
        Supply voltage within the tabulated 12-20 V.

    Returns
    -------
    ndarray
        Thrust in N at :func:`pwm_grid`, shape ``(201,)``.

    Raises
    ------
    ParameterError
        If the voltage is outside the table.
    """
    v = require_finite("T200 supply voltage", voltage)
    if not VOLTAGES[0] <= v <= VOLTAGES[-1]:
        raise ParameterError(
            f"T200 supply voltage must be within the tabulated {VOLTAGES[0]}-{VOLTAGES[-1]} V, got {v!r} V"
        )
    hi = int(np.searchsorted(np.asarray(VOLTAGES, dtype=float), v))
    if float(VOLTAGES[hi]) == v:
        kgf = force_table(VOLTAGES[hi])
    else:
        lo = hi - 1
        w = (v - VOLTAGES[lo]) / (VOLTAGES[hi] - VOLTAGES[lo])
        kgf = (1.0 - w) * force_table(VOLTAGES[lo]) + w * force_table(VOLTAGES[hi])
    out: FloatArray = kgf * STANDARD_GRAVITY
    return out


@dataclass(frozen=True)
class T200Curve:
    """T200 thrust at one supply voltage, and its inverse on the monotone branches.

    Parameters
    ----------
    voltage : float
        Supply voltage in V, within the tabulated 12-20 V (a four-cell battery: 16.8 V full,
        14.8 V nominal).

    Raises
    ------
    ParameterError
        If the voltage is outside the table.
    """

    voltage: float = 16.0
    _pwm: FloatArray = field(init=False, repr=False, compare=False)
    _thrust: FloatArray = field(init=False, repr=False, compare=False)
    _fwd: tuple[FloatArray, FloatArray] = field(init=False, repr=False, compare=False)
    _rev: tuple[FloatArray, FloatArray] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        thrust = thrust_table(self.voltage)
        pwm = pwm_grid()
        object.__setattr__(self, "voltage", float(self.voltage))
        object.__setattr__(self, "_pwm", pwm)
        object.__setattr__(self, "_thrust", thrust)
        # Monotone branches for the inverse: the table has a few 0.01-0.02 kgf dips (measurement noise).
        up = pwm >= PWM_NEUTRAL
        band_top = pwm[up][thrust[up] <= 0.0].max()  # upper edge of the dead band
        sel = pwm >= band_top
        object.__setattr__(self, "_fwd", (pwm[sel], np.maximum.accumulate(np.maximum(thrust[sel], 0.0))))
        down = pwm <= PWM_NEUTRAL
        band_bottom = pwm[down][thrust[down] >= 0.0].min()  # lower edge of the dead band
        sel = pwm <= band_bottom
        # from the band's lower edge down to 1100 us: reverse thrust magnitude increasing
        rev = np.maximum.accumulate(np.maximum(-thrust[sel][::-1], 0.0))
        object.__setattr__(self, "_rev", (pwm[sel][::-1], rev))

    @property
    def forward_max(self) -> float:
        """Largest forward thrust (N), at 1900 us."""
        return float(self._fwd[1][-1])

    @property
    def reverse_max(self) -> float:
        """Largest reverse thrust magnitude (N), at 1100 us."""
        return float(self._rev[1][-1])

    @property
    def dead_band(self) -> tuple[float, float]:
        """Pulse widths (us) between which the table gives no thrust (inclusive)."""
        return float(self._rev[0][0]), float(self._fwd[0][0])

    def thrust(self, pwm: ArrayLike) -> FloatArray:
        """Thrust (N) at pulse widths ``pwm`` (us), clipped to the 1100-1900 us table.

        Parameters
        ----------
        pwm : array_like
            ESC pulse widths (us).

        Returns
        -------
        ndarray
            Thrust in N, the shape of ``pwm``.
        """
        p = np.clip(np.asarray(pwm, dtype=float), PWM_MIN, PWM_MAX)
        out: FloatArray = np.interp(p, self._pwm, self._thrust)
        return out

    def pwm(self, thrust: ArrayLike) -> FloatArray:
        """Pulse width (us, not rounded) that gives ``thrust`` (N); 1500 us for zero.

        A nonzero thrust maps past the dead band (a small forward thrust gives a pulse just above
        the band's upper edge). Thrusts beyond the table's extremes give 1900 or 1100 us: compare
        them with :attr:`forward_max` and :attr:`reverse_max` first.

        Parameters
        ----------
        thrust : array_like
            Thrust (N), negative for reverse.

        Returns
        -------
        ndarray
            Pulse widths in us, the shape of ``thrust``.
        """
        f = np.asarray(thrust, dtype=float)
        out = np.full(f.shape, float(PWM_NEUTRAL))
        pos, neg = f > 0, f < 0
        out[pos] = np.maximum(np.interp(f[pos], self._fwd[1], self._fwd[0]), self._fwd[0][0])
        out[neg] = np.minimum(np.interp(-f[neg], self._rev[1], self._rev[0]), self._rev[0][0])
        return out


__all__ = [
    "PWM_COUNT",
    "PWM_MAX",
    "PWM_MIN",
    "PWM_NEUTRAL",
    "PWM_START",
    "PWM_STEP",
    "VOLTAGES",
    "T200Curve",
    "force_table",
    "pwm_grid",
    "thrust_table",
]
