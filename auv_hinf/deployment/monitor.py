"""The runtime monitor of a certificate's assumptions: one verdict per step, one record per violation.

At every step :meth:`Monitor.check` receives a :class:`StepInput` (what the loop measured and
commanded) and returns the violated :class:`~auv_hinf.deployment.runtime.Assumptions`, each a
:class:`Violation` ``(time, vehicle, assumption, value, bound)``; vehicle ``-1`` is the fleet.

======================  =========================================================================  ============
assumption              violated when                                                              unit
======================  =========================================================================  ============
``period``              the period since the last step exceeds ``sample_time + delay`` less the    s
                        command latency: no measurement could be fresh enough (vehicle -1)
``lag``                 the last step's measurement age plus the period exceeds that bound: the    s
                        measurement behind the force held until now got older than the
                        certificate allows (the input-delay bound ``eta(t) <= h + d``)
``delay``               a measurement is older than ``delay - command_latency`` when stepped       s
``stale``               no navigation message arrived for a sample time                            s
``missing``             a vehicle never sent a position and a heading                              s (inf)
``heartbeat``           no HEARTBEAT for ``heartbeat_timeout``                                     s
``mode``                the HEARTBEAT's custom_mode is not the mapping's (19, MANUAL)              -
``pilot_gain``          "PilotGain" differs from the mapping's gain by more than 0.01              -
``envelope_u/v/r``      a body velocity or yaw rate is outside the envelope by more than the       m/s, rad/s
                        noise (and, for u and v, the current bound: they are over ground)
``invariant_position``  ``|p - p_d|`` exceeds its certified bound plus the position noise          m
``invariant_velocity``  ``|p' - p_d'|`` exceeds its bound plus the velocity noise and the speed    m/s
                        times the heading noise
``invariant_heading``   ``|psi - psi_d|`` exceeds its bound plus the heading noise                 rad
``invariant_yaw_rate``  ``|r - r_d|`` exceeds its bound plus the yaw-rate noise                    rad/s
``force_x/y/psi``       the law's command exceeds the actuator limit                               N, N m
``deliverable``         ArduSub's mixer, a thruster or a stick clipped the command (value 1)       -
``current``             the estimated current exceeds its bound by more than the estimator's       m/s
                        resolution
======================  =========================================================================  ============

**Current estimator** (per vehicle). The model is water-relative, ``M nu_r' + C nu_r + D(nu_r) nu_r =
tau`` with ``nu_r = nu - R(psi)^T c`` for a constant current ``c``, while the vehicle measures ``nu``
over ground. With the loop period ``dt`` and the force the vehicle made since the previous step
(the mapping's prediction of what was sent, :meth:`Monitor.made`), ``nu' ~ (nu_k - nu_{k-1}) / dt``;
the drag force ``h = tau - M nu' + C(nu) nu`` is inverted axis by axis (``d_lin v + d_quad |v| v =
h``) to ``nu_r``, and ``c = R(psi) (nu - nu_r)`` is low-passed with :data:`CURRENT_TIME_CONSTANT`.
The check starts after three time constants. It assumes the model's drag and a quasi-steady current.

The monitor is a deterministic function of its logged inputs, so replaying a log
(:mod:`auv_hinf.deployment.replay`) reproduces a run's verdicts.
"""

from __future__ import annotations

import enum
import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from auv_hinf._typing import FloatArray
from auv_hinf.deployment.runtime import Assumptions
from auv_hinf.exceptions import ParameterError
from auv_hinf.mission.fleet import wrap_angle
from auv_hinf.models.vehicle import VehicleParams

#: ArduSub reports the pilot gain as a float in steps of at least 0.01 (JS_GAIN_STEPS over its range).
GAIN_TOLERANCE = 0.01
#: Time constant of the current estimator's low-pass filter (s): long against the 0.1 s loop, so
#: that differenced velocities average out, short against a minute-long run.
CURRENT_TIME_CONSTANT = 2.0
#: Current the estimator cannot tell from zero (m/s): its estimate on the loopback fleet without a
#: current stays below 0.005 m/s; 0.02 m/s leaves room for the mapping's force residual (about
#: 0.3 N against a drag slope of about 20 N s/m near 0.05 m/s).
CURRENT_RESOLUTION = 0.02
#: Relative round-off allowed on a force against its limit.
FORCE_RTOL = 1e-9


class Action(str, enum.Enum):
    """What the loop does on a violation, mildest first: log, hold station, or neutral and stop."""

    WARN = "warn"
    HOLD = "hold"
    STOP = "stop"

    @classmethod
    def parse(cls, text: str) -> Action:
        """The action called ``text``.

        Parameters
        ----------
        text : str
            ``"warn"``, ``"hold"`` or ``"stop"`` (any case).

        Returns
        -------
        Action
            The action.

        Raises
        ------
        ParameterError
            For any other word.
        """
        try:
            return cls(str(text).strip().lower())
        except ValueError:
            raise ParameterError(f"an action is one of warn, hold, stop; got {text!r}") from None

    @property
    def severity(self) -> int:
        """0 for warn, 1 for hold, 2 for stop."""
        return ("warn", "hold", "stop").index(self.value)


#: Every assumption the monitor checks, in the order its violations are listed.
ASSUMPTIONS = (
    "period",
    "lag",
    "delay",
    "stale",
    "missing",
    "heartbeat",
    "mode",
    "pilot_gain",
    "envelope_u",
    "envelope_v",
    "envelope_r",
    "invariant_position",
    "invariant_velocity",
    "invariant_heading",
    "invariant_yaw_rate",
    "force_x",
    "force_y",
    "force_psi",
    "deliverable",
    "current",
)
#: Actions taken unless configured otherwise: a vehicle that is gone, or in another mode than the
#: mapping's, cannot be controlled; everything else is logged.
DEFAULT_ACTIONS: dict[str, Action] = {"missing": Action.STOP, "heartbeat": Action.STOP, "mode": Action.STOP}


@dataclass(frozen=True)
class Violation:
    """One assumption that failed at one step.

    Attributes
    ----------
    time : float
        The step's time (s from the start of the run).
    vehicle : int
        The vehicle (0-based); -1 for the fleet (the loop period).
    assumption : str
        One of :data:`ASSUMPTIONS`.
    value, bound : float
        What was measured and the bound it broke, in the assumption's unit (module docstring).
    """

    time: float
    vehicle: int
    assumption: str
    value: float
    bound: float

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe dictionary (infinite values as ``None``)."""

        def num(v: float) -> float | None:
            return float(v) if math.isfinite(v) else None

        return {
            "time": num(self.time),
            "vehicle": self.vehicle,
            "assumption": self.assumption,
            "value": num(self.value),
            "bound": num(self.bound),
        }


@dataclass(frozen=True)
class MonitorConfig:
    """Which action each violated assumption triggers.

    Attributes
    ----------
    default : Action
        The action of every assumption not in ``actions``.
    actions : tuple of (str, Action)
        Per-assumption actions (default :data:`DEFAULT_ACTIONS`).
    """

    default: Action = Action.WARN
    actions: tuple[tuple[str, Action], ...] = tuple(DEFAULT_ACTIONS.items())

    def __post_init__(self) -> None:
        for name, action in self.actions:
            if name not in ASSUMPTIONS:
                raise ParameterError(f"unknown assumption {name!r}; the monitor checks {', '.join(ASSUMPTIONS)}")
            if not isinstance(action, Action):
                raise ParameterError(f"the action of {name!r} must be an Action, got {action!r}")

    @classmethod
    def parse(cls, default: str | None, items: Iterable[str]) -> MonitorConfig:
        """A configuration from ``--on-violation ACTION`` and ``--action NAME=ACTION`` words.

        Parameters
        ----------
        default : str or None
            The action of the assumptions not named (``None``: warn, with :data:`DEFAULT_ACTIONS`).
        items : iterable of str
            ``NAME=ACTION`` per assumption.

        Returns
        -------
        MonitorConfig
            The configuration; a given default replaces :data:`DEFAULT_ACTIONS` as well.

        Raises
        ------
        ParameterError
            For a malformed item, an unknown assumption or an unknown action.
        """
        actions = dict(DEFAULT_ACTIONS) if default is None else {}
        for item in items:
            name, sep, word = item.partition("=")
            if not sep:
                raise ParameterError(f"--action takes NAME=ACTION (e.g. delay=hold), got {item!r}")
            actions[name.strip()] = Action.parse(word)
        return cls(Action.WARN if default is None else Action.parse(default), tuple(actions.items()))

    def action_for(self, assumption: str) -> Action:
        """The action of ``assumption``.

        Parameters
        ----------
        assumption : str
            One of :data:`ASSUMPTIONS`.

        Returns
        -------
        Action
            Its configured action, else the default.
        """
        return dict(self.actions).get(assumption, self.default)

    def most_severe(self, violations: Sequence[Violation]) -> Action | None:
        """The most severe action among ``violations`` (``None`` when there are none).

        Parameters
        ----------
        violations : sequence of Violation
            One step's violations.

        Returns
        -------
        Action or None
            What the loop does.
        """
        acts = [self.action_for(v.assumption) for v in violations]
        return max(acts, key=lambda a: a.severity) if acts else None

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe dictionary (stored in a run log)."""
        return {"default": self.default.value, "actions": {k: a.value for k, a in self.actions}}


@dataclass(frozen=True)
class StepInput:
    """What one step measured and commanded; every array has one row per vehicle.

    Attributes
    ----------
    time : float
        The step's time (s from the start of the run).
    period : float
        Time since the previous step (s; NaN at the first).
    states : ndarray, shape (N, 6)
        Measured ``[x, y, psi, u, v, r]`` (NaN rows for vehicles never heard from).
    ages : ndarray, shape (N,)
        Age of each measurement when stepped (s; NaN when unknown).
    nav_gap, heartbeat_gap : ndarray, shape (N,)
        Time since the newest navigation message and HEARTBEAT (s; inf if never).
    commanded : ndarray, shape (N, 3)
        The certified law's command before saturation (N, N, N m).
    saturated : ndarray of bool, shape (N,)
        The mapping clipped the command of the active law (before the step's action).
    reference : ndarray, shape (N, 6), or None
        The desired motion at each measurement's time: ``[x, y, psi, vx, vy, r]`` (m, m, rad, m/s,
        m/s, rad/s; ``vx, vy`` inertial). ``None``: the invariant set is not checked.
    modes : ndarray of int, shape (N,), or None
        HEARTBEAT custom_mode (-1 when unknown).
    gains : ndarray, shape (N,), or None
        Reported "PilotGain" (NaN when unknown).
    """

    time: float
    period: float
    states: FloatArray
    ages: FloatArray
    nav_gap: FloatArray
    heartbeat_gap: FloatArray
    commanded: FloatArray
    saturated: NDArray[np.bool_]
    reference: FloatArray | None = None
    modes: NDArray[np.int64] | None = None
    gains: FloatArray | None = None


def _inverse_drag(h: FloatArray, d_lin: float, d_quad: float) -> FloatArray:
    """Speed ``v`` with ``d_lin v + d_quad |v| v = h`` (N to m/s), elementwise."""
    a = np.abs(h)
    if d_quad > 0.0:
        v = (-d_lin + np.sqrt(d_lin * d_lin + 4.0 * d_quad * a)) / (2.0 * d_quad)
    elif d_lin > 0.0:
        v = a / d_lin
    else:
        v = np.zeros_like(a)
    out: FloatArray = np.sign(h) * v
    return out


class CurrentEstimator:
    """Low-passed drag-inversion estimate of the current (NED, m/s) per vehicle (module docstring).

    Parameters
    ----------
    model : VehicleParams
        The vehicles' model (its drag is inverted).
    n : int
        Number of vehicles.
    time_constant : float
        Time constant of the low-pass filter (s, > 0).
    """

    def __init__(self, model: VehicleParams, n: int, time_constant: float = CURRENT_TIME_CONSTANT) -> None:
        self.model, self.tc = model, float(time_constant)
        self.estimate = np.zeros((n, 2))
        self.elapsed = 0.0
        self._nu: FloatArray | None = None
        self._tau: FloatArray | None = None

    @property
    def ready(self) -> bool:
        """The filter has run for three time constants."""
        return self.elapsed >= 3.0 * self.tc

    def update(self, states: FloatArray, dt: float) -> FloatArray:
        """Advance by one step, with the force set by :meth:`made` at the previous step.

        Parameters
        ----------
        states : ndarray, shape (N, 6)
            This step's measured states.
        dt : float
            Time since the previous step (s; NaN at the first).

        Returns
        -------
        ndarray, shape (N,)
            The estimated current speed of each vehicle (m/s).
        """
        m = self.model
        nu = states[:, 3:6]
        if self._nu is not None and self._tau is not None and math.isfinite(dt) and dt > 0.0:
            nudot = (nu - self._nu) / dt
            u, v, r = nu[:, 0], nu[:, 1], nu[:, 2]
            hx = self._tau[:, 0] - m.m11 * nudot[:, 0] + m.m22 * v * r
            hy = self._tau[:, 1] - m.m22 * nudot[:, 1] - m.m11 * u * r
            du = u - _inverse_drag(hx, m.d11_lin, m.d11_quad)
            dv = v - _inverse_drag(hy, m.d22_lin, m.d22_quad)
            c, s = np.cos(states[:, 2]), np.sin(states[:, 2])
            raw = np.stack([c * du - s * dv, s * du + c * dv], axis=1)
            good = np.all(np.isfinite(raw), axis=1)
            self.estimate[good] += dt / (self.tc + dt) * (raw[good] - self.estimate[good])
            self.elapsed += dt
        self._nu, self._tau = nu.copy(), None
        out: FloatArray = np.hypot(self.estimate[:, 0], self.estimate[:, 1])
        return out

    def made(self, force: FloatArray) -> None:
        """The force the vehicles make from this step on, ``(N, 3)`` (N, N, N m): used at the next step.

        Parameters
        ----------
        force : ndarray, shape (N, 3)
            What was sent, as the mapping predicts the vehicles make it.
        """
        self._tau = np.asarray(force, dtype=float).copy()


@dataclass
class Monitor:
    """Checks the :class:`~auv_hinf.deployment.runtime.Assumptions` at every step (module docstring).

    Parameters
    ----------
    assumptions : Assumptions
        What the certificate assumed.
    n : int
        Number of vehicles.
    model : VehicleParams
        The vehicles' model, for the current estimator.

    Attributes
    ----------
    current : CurrentEstimator
        The running estimate of the current (derived).
    current_speed : ndarray, shape (N,)
        The latest estimated current speed per vehicle (m/s).
    """

    assumptions: Assumptions
    n: int
    model: VehicleParams
    current: CurrentEstimator = field(init=False)
    current_speed: FloatArray = field(init=False)
    _last_ages: FloatArray = field(init=False)

    def __post_init__(self) -> None:
        if self.n < 1:
            raise ParameterError(f"a fleet has at least one vehicle, got {self.n!r}")
        self.current = CurrentEstimator(self.model, self.n)
        self.current_speed = np.zeros(self.n)
        self._last_ages = np.full(self.n, np.nan)

    def made(self, force: FloatArray) -> None:
        """What the vehicles make from this step on, after the step's action (for the current estimator).

        Parameters
        ----------
        force : ndarray, shape (N, 3)
            The force of the commands sent, as the mapping predicts it (N, N, N m).
        """
        self.current.made(force)

    def check(self, step: StepInput) -> list[Violation]:
        """The violations at one step: the fleet's first, then by vehicle in the order of :data:`ASSUMPTIONS`.

        Parameters
        ----------
        step : StepInput
            What the step measured and commanded.

        Returns
        -------
        list of Violation
            Empty when every assumption holds.
        """
        a, t = self.assumptions, float(step.time)
        out: list[Violation] = []

        def add(vehicle: int, name: str, value: float, bound: float) -> None:
            out.append(Violation(t, int(vehicle), name, float(value), float(bound)))

        lag_bound = a.max_lag - a.command_latency
        if a.timed and math.isfinite(step.period) and step.period > lag_bound:
            add(-1, "period", step.period, lag_bound)
        lags = self._last_ages + step.period
        self._last_ages = np.asarray(step.ages, dtype=float).copy()
        states = np.asarray(step.states, dtype=float)
        have = np.all(np.isfinite(states), axis=1)
        self.current_speed = self.current.update(states, step.period)
        excess = self._invariant(states, step.reference)
        for i in range(self.n):
            self._vehicle(i, step, states[i], bool(have[i]), excess, lags, add)
        return out

    def _invariant(
        self, states: FloatArray, reference: FloatArray | None
    ) -> list[tuple[str, FloatArray, FloatArray]] | None:
        """Per channel: the measured errors ``(N,)`` and what they are allowed, noise included ``(N,)``."""
        b = self.assumptions.error_bounds
        if reference is None or b is None:
            return None
        n, ref = self.assumptions.noise, np.asarray(reference, dtype=float)
        c, s = np.cos(states[:, 2]), np.sin(states[:, 2])
        vx, vy = c * states[:, 3] - s * states[:, 4], s * states[:, 3] + c * states[:, 4]
        speed = np.hypot(states[:, 3], states[:, 4])  # the heading noise rotates the measured velocity
        one = np.ones(self.n)
        return [
            (
                "invariant_position",
                np.hypot(states[:, 0] - ref[:, 0], states[:, 1] - ref[:, 1]),
                one * (b.position + n.position),
            ),
            (
                "invariant_velocity",
                np.hypot(vx - ref[:, 3], vy - ref[:, 4]),
                b.velocity + n.velocity + speed * n.heading,
            ),
            ("invariant_heading", np.abs(wrap_angle(states[:, 2] - ref[:, 2])), one * (b.heading + n.heading)),
            ("invariant_yaw_rate", np.abs(states[:, 5] - ref[:, 5]), one * (b.yaw_rate + n.yaw_rate)),
        ]

    def _vehicle(
        self,
        i: int,
        step: StepInput,
        state: FloatArray,
        have: bool,
        excess: list[tuple[str, FloatArray, FloatArray]] | None,
        lags: FloatArray,
        add: Any,
    ) -> None:
        a = self.assumptions
        if a.timed and math.isfinite(lags[i]) and lags[i] > a.max_lag - a.command_latency:
            add(i, "lag", lags[i], a.max_lag - a.command_latency)
        if not have:
            add(i, "missing", math.inf, 0.0)
        elif a.timed:  # the continuous law's certificate certifies no timing (Assumptions.timed)
            age = float(step.ages[i])
            if math.isfinite(age) and age > a.measurement_age_bound:
                add(i, "delay", age, a.measurement_age_bound)
            if float(step.nav_gap[i]) > a.stale_after:
                add(i, "stale", step.nav_gap[i], a.stale_after)
        if float(step.heartbeat_gap[i]) > a.heartbeat_timeout:
            add(i, "heartbeat", step.heartbeat_gap[i], a.heartbeat_timeout)
        if a.mode is not None and step.modes is not None and 0 <= int(step.modes[i]) != a.mode:
            add(i, "mode", step.modes[i], a.mode)
        gain = math.nan if step.gains is None else float(step.gains[i])
        if a.pilot_gain is not None and math.isfinite(gain) and abs(gain - a.pilot_gain) > GAIN_TOLERANCE:
            add(i, "pilot_gain", gain, a.pilot_gain)
        if have:
            env, n = a.envelope, a.noise
            for k, name, rng, margin in (
                (3, "envelope_u", env.u, n.velocity + a.current_bound),
                (4, "envelope_v", env.v, n.velocity + a.current_bound),
                (5, "envelope_r", env.r, n.yaw_rate),
            ):
                if state[k] > rng[1] + margin:
                    add(i, name, state[k], rng[1] + margin)
                elif state[k] < rng[0] - margin:
                    add(i, name, state[k], rng[0] - margin)
            for name, values, allowed in excess or ():
                if values[i] > allowed[i]:
                    add(i, name, values[i], allowed[i])
        if a.force_limits is not None:
            for k, name in enumerate(("force_x", "force_y", "force_psi")):
                f = float(step.commanded[i, k])
                if abs(f) > a.force_limits[k] * (1.0 + FORCE_RTOL):
                    add(i, name, f, math.copysign(a.force_limits[k], f))
        if bool(step.saturated[i]):
            add(i, "deliverable", 1.0, 0.0)
        if self.current.ready and self.current_speed[i] > a.current_bound + CURRENT_RESOLUTION:
            add(i, "current", self.current_speed[i], a.current_bound + CURRENT_RESOLUTION)


def violations_json(violations: Sequence[Violation]) -> list[dict[str, Any]]:
    """``[{assumption, value, bound}]`` of one vehicle's violations at one step (the log's column).

    Parameters
    ----------
    violations : sequence of Violation
        One vehicle's (or the fleet's) violations at one step.

    Returns
    -------
    list of dict
        JSON-safe records without the time and vehicle, which the log row carries.
    """
    return [{k: v for k, v in x.to_dict().items() if k not in ("time", "vehicle")} for x in violations]


__all__ = [
    "ASSUMPTIONS",
    "CURRENT_RESOLUTION",
    "CURRENT_TIME_CONSTANT",
    "DEFAULT_ACTIONS",
    "FORCE_RTOL",
    "GAIN_TOLERANCE",
    "Action",
    "CurrentEstimator",
    "Monitor",
    "MonitorConfig",
    "StepInput",
    "Violation",
    "violations_json",
]
