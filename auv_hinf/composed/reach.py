"""How far the deployed loop's timing can go: the exact nominal limits, and how much of them is certified.

The composed certificate (:mod:`auv_hinf.composed.certificate`) is computed at the declared
sample time and delay. Beside it, ``certify`` reports the *exact* limits of the nominal loop at
the same gains: the controller's own model (no box, no current, no noise), each vehicle on its
slot, its sampled surge, sway and heading loops (:func:`~auv_hinf.composed.loops.axis_loop`,
:func:`~auv_hinf.composed.loops.heading_loop`, one per trim cell on a mission that turns) held
for ``h`` and measured ``d`` late. A loop is stable exactly when its period map's spectral
radius is below 1 (:func:`~auv_hinf.implementation.peak.period_radius`), so:

- ``exact_max_sample_time`` is the first sample time above the declared one at which some
  nominal loop is unstable, at the declared delay;
- ``exact_max_delay`` is the first delay above the declared one at which some nominal loop is
  unstable, at the declared sample time.

Both are found by a geometric scan (factor :data:`SCAN_FACTOR`) and a bisection to
:data:`LIMIT_RTOL`; no sampled plant of the box can be certified beyond them, since the nominal
plant is in the box. ``tightness`` is the declared sample time over the exact limit: the share
of the nominal stability range the certificate is known to reach (a lower bound of it: the
certificate is not searched above the declared timing, which would cost a certificate per step).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any

from auv_hinf.composed.certificate import DeployedProblem
from auv_hinf.composed.loops import Errors, OperatingBox, nominal_loops
from auv_hinf.implementation.peak import SampledLoop, period_radius
from auv_hinf.numerics.bisection import bisect
from auv_hinf.robust.box import ParameterBox

#: Ratio between consecutive points of the scan for the first unstable timing: fine enough that a
#: stable band narrower than 5 % above the declared value is not stepped over in practice.
SCAN_FACTOR = 1.05
#: The scan stops (the limit is reported as infinite) at this multiple of the declared value.
SCAN_SPAN = 100.0
#: Relative width of the final bracket of the bisection (s): far below any timing a deployment sets.
LIMIT_RTOL = 1e-3
#: Delay scanned from, when none is declared (s): the geometric scan needs a positive start.
DELAY_FLOOR = 1e-3


@dataclass(frozen=True)
class Reach:
    """The exact nominal limits of the deployed loop's timing, and the certified share of them.

    Attributes
    ----------
    sample_time, delay : float
        The declared (certified) sample time and delay (s).
    exact_max_sample_time : float
        First sample time above the declared one at which a nominal loop is unstable (s; ``inf``
        when none up to :data:`SCAN_SPAN` times the declared is).
    exact_max_delay : float
        First delay above the declared one at which a nominal loop is unstable (s; ``inf`` likewise).
    """

    sample_time: float
    delay: float
    exact_max_sample_time: float
    exact_max_delay: float

    @property
    def tightness(self) -> float | None:
        """``sample_time / exact_max_sample_time`` (<= 1 by soundness; ``None`` when the limit is infinite)."""
        ex = self.exact_max_sample_time
        return self.sample_time / ex if 0.0 < ex < math.inf else None

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe figures (s; ``null`` for an infinite limit)."""
        return {
            "max_sample_time": self.sample_time,
            "max_delay": self.delay,
            "exact_max_sample_time": _finite(self.exact_max_sample_time),
            "exact_max_delay": _finite(self.exact_max_delay),
            "tightness": self.tightness,
        }


def _finite(x: float) -> float | None:
    return x if math.isfinite(x) else None


def model_loops(problem: DeployedProblem, sample_time: float, delay: float) -> list[SampledLoop]:
    """The controller's own model's sampled loops on the slots, one per trim cell (see the module docstring).

    Parameters
    ----------
    problem : DeployedProblem
        The problem (its model, mission and gains).
    sample_time, delay : float
        ``h > 0`` and ``d >= 0`` (s).
    """
    plant = replace(problem.plant, box=ParameterBox.from_ranges(problem.plant.model, ()), current=0.0, current_rate=0.0)
    op = OperatingBox.of(problem.mission, 0.0, Errors(0.0, 0.0, 0.0, 0.0))
    axes = nominal_loops(plant, op, problem.mission, 0.0, problem.gains, sample_time, delay)
    return [loop for _, _, cells in axes for loop in cells]


def _first_unstable(stable: Callable[[float], bool], start: float) -> float:
    """First value above ``start`` (where ``stable`` holds) at which it fails: scan, then bisect."""
    lo = start
    while True:
        hi = lo * SCAN_FACTOR
        if hi > SCAN_SPAN * start:
            return math.inf
        if not stable(hi):
            break
        lo = hi
    return bisect(stable, lo, hi, rtol=LIMIT_RTOL, geometric=True)[1]


def reach(problem: DeployedProblem) -> Reach:
    """The exact nominal limits of ``problem``'s sample time and delay (see the module docstring).

    Parameters
    ----------
    problem : DeployedProblem
        A problem whose composed certificate covers (its nominal loops are stable as declared).
    """
    h, d = problem.timing

    def stable(sample_time: float, delay: float) -> bool:
        return all(period_radius(loop) < 1.0 for loop in model_loops(problem, sample_time, delay))

    if not stable(h, d):  # the certificate covers only stable nominal loops; kept as a guard
        return Reach(h, d, h, d)
    exact_h = _first_unstable(lambda x: stable(x, d), h)
    exact_d = _first_unstable(lambda x: stable(h, x), max(d, DELAY_FLOOR))
    return Reach(h, d, exact_h, exact_d)


__all__ = ["DELAY_FLOOR", "LIMIT_RTOL", "SCAN_FACTOR", "SCAN_SPAN", "Reach", "model_loops", "reach"]
