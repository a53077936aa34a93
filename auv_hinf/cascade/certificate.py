"""A certificate of the ILOS guidance cascade: bounds of every vehicle's along-track, cross-track and heading errors.

Each vehicle of a ``[guidance]`` fleet runs the cascade of :mod:`auv_hinf.guidance.law` on its
own slot, sampled every ``h`` seconds (its thrust and rudder held), on a plant anywhere in the
``[uncertainty]`` box, in a constant current ``|c| <= C`` (the residuals carry a bound of ``|c'|``,
which the guidance part keeps at 0: the 3-DOF model's water-relative velocities assume it). This
module proves, for every such plant and current and every mission time, bounds of the errors,
of the commanded thrust and rudder, and of the sway speed. The derivation is in
``docs/derivations/guidance.md``; in short:

* **Coordinates.** In the slot's path-tangential frame (course ``gamma``, rate ``omega``,
  speed ``U``) the state of one vehicle is ``x = (x_e, v_x, y_e, p, e, e_r, v)``: the along-track
  error (m), the along-track ground speed less ``U`` (m/s), the cross-track error (m),
  ``p = (U - c_t) sin(theta) - c_n`` (m/s; ``theta = atan((y_e + sigma y_i)/Delta)`` the line-of-sight
  angle, ``c_t`` and ``c_n`` the current along and across the track), the heading error
  ``e = psi - psi_d`` (rad), ``e_r = r - omega + theta_c'`` (rad/s; ``theta_c'`` the line of
  sight's rate with the ILOS rate evaluated continuously) and the sway speed ``v`` (m/s). The
  ILOS state between samples is the linear interpolation of the controller's own (Euler)
  integrator, so the errors at every sample are the controller's.
* **The nominal loop.** At ``u = U0``, ``theta = 0``, ``omega = 0`` and the model's coefficients
  the cascade is linear (:func:`_rows`): ``x_e' = v_x``, ``v_x' = a_x``, ``y_e' = -p + U0 e + v``,
  ``p' = (U0/Delta) y_e' + u_i``, ``e' = e_r``, ``e_r' = tau - (m_u U0/m33) v + theta''``,
  ``v' = -(m11 U0/m22)(e_r - theta') - (d22/m22) v + (m33/(l m22)) tau``, with the held commands
  ``a_x = -k_u (v_x + k_x x_e)``, ``tau = -k_p e - k_d e_r + (m_u U0/m33) v`` (the Munk moment the
  law cancels included) and ``u_i = U0 sigma y_e / Delta^2`` at the samples. It is a sampled-data
  LTI loop (:func:`cascade_loop`) whose peak-to-peak gains
  :func:`~auv_hinf.implementation.peak.peak_gains` bounds rigorously, to the states and to the
  linear expressions :data:`DERIVED` (bounded directly, they keep their terms' cancellations).
* **What drives it.** Each state's exact derivative less the nominal one is a residual ``w_j``
  (:func:`residual_bounds`): the box's mass and drag mismatch, the current's turn with the
  track, the trigonometry of the line of sight and of the heading error, the speed the vehicle
  really has, the hold of the feed-forward between samples, the saturation of the along-track
  correction. Each is bounded, term by term, over the *error box* (the states and the derived
  expressions within assumed bounds); the bounds of the vehicle's accelerations use the law's
  commands against the plant's terms, or the actuator limits. The sway speed is bounded twice,
  by the loop and by its own damped equation (drag and the rudder's Munk compensation, a scalar
  comparison), and the smaller bound is kept.
* **First exit.** With the start's free response and the residuals' bounds through the peak
  gains (plus the outputs' motion between the gains' fine steps), a box ``B`` whose image is
  strictly inside it cannot be left: at the first exit every residual would have been within its
  bound up to then, so the states would have been strictly inside ``B``. :func:`certify_cascade`
  finds ``B`` by a monotone fixed-point iteration from the free response, inflates it by
  :data:`FIXED_POINT_MARGIN` and checks the strict inclusion there. The commanded thrust and rudder
  are then bounded over ``B`` and checked against the limits: the law is never saturated, as the
  residuals assume.
* **Cells.** What is constant in a run can be cut into cells, each with its own nominal loop
  (:func:`certify_cascade`): the masses (the nominal plant is the cell's centre) and, on a mission
  that keeps its course in a constant current, the current's component along the track (the
  nominal surge speed through the water is ``U0`` less the cell's middle).

* **Turns.** The slot's turn pushes the sway and the heading rate by a known signal
  (:func:`turn_forcing`). The loop has an equilibrium for it (:func:`turn_equilibrium`: the
  sideslip that the ILOS crab holds), and on a mission that turns the fixed point is also run on
  the states about it, ``z = x - E omega(t)``, driven by the turn's acceleration instead
  (:func:`turn_terms`); every trajectory stays in both invariant boxes, so in their intersection.
  The turn's scalar signals (``omega``, ``omega'``, the equilibrium's lag in the held commands) enter
  the loop along fixed directions, each through its own peak gain (:func:`turn_directions`), and the
  nominal loop carries the quadratic sway drag linearised at the steady turn's sideslip
  (:func:`turn_sway_slope`).

* **Late and noisy measurements.** With a delay ``d`` the held commands are computed from the states
  at ``t_k - d`` (the nominal loop carries the measurements in flight), each measured state with a
  discrete error bounded by :func:`measurement_errors`; every residual term that pairs a value the
  law computed at the sample with the present one uses the measurement's largest age ``h + d`` and
  its error, and the commands are bounded on the measured states.

The certificate covers the cascade at the declared sample time, fixed delay and measurement-error
bounds (what ``simulate`` runs), and ILOS guidance only: plain LOS has no integral state, and its
cross-track error is a function of ``p``, which this loop does not express.
"""

from __future__ import annotations

import functools
import itertools
import math
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from tqdm.auto import tqdm

from auv_hinf._typing import FloatArray
from auv_hinf.actuation.limits import RudderActuation
from auv_hinf.composed.loops import Plant
from auv_hinf.guidance.law import MAX_START_CRAB, MIN_RUDDER_SPEED, GuidanceConfig, SlotMotion, integral_start
from auv_hinf.implementation.model import MeasurementNoise
from auv_hinf.implementation.peak import MAX_PERIODS, PeakGains, SampledLoop, free_peaks, peak_gains
from auv_hinf.mission.fleet import wrap_angle
from auv_hinf.models.vehicle import VehicleParams
from auv_hinf.numerics.progress import PROGRESS_DELAY
from auv_hinf.robust.box import PARAMETERS, ParameterBox

#: The state's names, in the loop's order (m, m/s, m, m/s, rad, rad/s, m/s).
STATES = ("along_track", "along_speed", "cross_track", "sight", "heading", "heading_rate", "sway")
X_E, V_X, Y_E, P, E, E_R, V = range(7)
#: The linear expressions of the nominal loop whose peaks are bounded with the states (:func:`_rows`):
#: ``y_e'``, ``theta'``, ``r - omega``, ``v'``, ``p'``, ``y_e''`` of the nominal loop (m/s, rad/s,
#: rad/s, m/s^2, m/s^2, m/s^2), the heading feedback ``a_psi`` and the held commands ``tau``,
#: ``a_x`` (rad/s^2, rad/s^2, m/s^2). Bounding them directly keeps the cancellations between
#: their terms, which a sum of the states' bounds loses.
DERIVED = ("ydot_lin", "sight_lin", "yaw_lin", "vdot_lin", "pdot_lin", "yddot_lin", "a_psi", "tau", "a_x")
NB = len(STATES) + len(DERIVED)
#: Relative inflation of the fixed point before the strict inclusion is checked: the image must
#: fit inside the inflated box, which leaves room for the first-exit argument's strictness.
FIXED_POINT_MARGIN = 1e-3
#: Absolute floor added to every component of the inflated box (SI units of each state): a state
#: nothing drives (zero bound) still gets a box with an interior.
FIXED_POINT_FLOOR = 1e-9
#: Relative step below which the fixed-point iteration counts as converged.
FIXED_POINT_RTOL = 1e-6
#: Most fixed-point iterations: the iteration contracts geometrically when the small gain holds.
MAX_ITERATIONS = 400
#: Most re-inflations of the fixed point before its strict inclusion is given up.
INFLATIONS = 20
#: Largest ``(P + C)/U0`` (the line of sight's sine) an error box may assume: beyond it the
#: line-of-sight angle is not bounded away from a right angle and the vehicle may turn back.
MAX_SIGHT_SINE = 0.95
#: Largest heading angle off the track (line of sight plus heading error, rad) an error box may
#: assume: below a right angle the surge speed keeps its sign.
MAX_TRACK_ANGLE = 0.45 * math.pi


@dataclass(frozen=True)
class CascadeProblem:
    """What the cascade's certificate depends on.

    Attributes
    ----------
    guidance : GuidanceConfig
        The ILOS guidance and the autopilots' gains.
    plant : Plant
        The controller's model, the ``[uncertainty]`` box and the current's bounds.
    act : RudderActuation
        The propeller and the rudder (the limits; the rudder derivatives are exact).
    speed : tuple of float
        ``[min, max]`` of every slot's ground speed ``U`` (m/s).
    speed_rate : float
        Bound of every slot's ``|U'|`` (m/s^2): ``|p_d''|`` in general, 0 for a slot of constant speed.
    turn_rate : float
        Bound of every slot's course rate ``|omega|`` (rad/s).
    turn_accel : float
        Bound of ``|omega'|`` (rad/s^2).
    speed_jerk : float
        Bound of ``|U''|`` (m/s^3): ``|p_d'''| + |omega| |p_d''|`` in general (``U'' = t . p_d''' +
        omega n . p_d''``), 0 for a slot of constant speed.
    sample_time : float
        The cascade's period ``h`` (s).
    start : tuple of float
        Bounds of the seven states at ``t = 0`` (:data:`STATES`, SI units).
    nominal : VehicleParams or None
        The plant of the nominal loop: the centre of a cell of the box that ``plant.box`` has been
        narrowed to (:func:`certify_cascade`); ``None``: the controller's model.
    current_along : tuple of float or None
        ``[lo, hi]`` of the current's component along the track in a cell of it (m/s; on a mission
        that keeps its course, :func:`current_cells_apply`); ``None``: every component ``[-C, C]``.
    delay : float
        The ``[implementation]`` delay ``d`` (s): the commands held from ``t_k`` are computed from the
        measurement taken at ``t_k - d`` (before ``t = 0``: the start).
    noise : MeasurementNoise
        Bounds of the measurement errors (m, m/s, rad, rad/s; default exact).
    start_turn : float or None
        Bound of every slot's course rate ``|omega(0)|`` at ``t = 0`` (rad/s); ``None``: :attr:`turn_rate`.
    sway_slope : float
        The slope ``s`` (kg/s) at which the nominal loop carries the quadratic sway drag
        ``d22q |v| v``: its sway damping is ``d22 + s`` and the residual ``w7`` holds the rest,
        ``|d22q' |v|/m22' - s/m22| |v|`` (any ``s >= 0`` is sound; :func:`turn_sway_slope` chooses it).
    """

    guidance: GuidanceConfig
    plant: Plant
    act: RudderActuation
    speed: tuple[float, float]
    speed_rate: float
    turn_rate: float
    turn_accel: float
    speed_jerk: float
    sample_time: float
    start: tuple[float, ...] = field(default=(0.0,) * 7)
    nominal: VehicleParams | None = None
    current_along: tuple[float, float] | None = None
    delay: float = 0.0
    noise: MeasurementNoise = field(default_factory=MeasurementNoise)
    start_turn: float | None = None
    sway_slope: float = 0.0

    @property
    def turn_start(self) -> float:
        """Bound of every slot's ``|omega(0)|`` (rad/s): :attr:`start_turn`, or :attr:`turn_rate`."""
        return self.turn_rate if self.start_turn is None else self.start_turn

    @property
    def turns(self) -> bool:
        """The slots turn: their course rate or its rate of change is bounded away from zero."""
        return self.turn_rate > 0.0 or self.turn_accel > 0.0

    @property
    def lag(self) -> float:
        """Largest age ``h + d`` (s) of the measurement behind the commands held at any time."""
        return self.sample_time + self.delay

    @property
    def nominal_plant(self) -> VehicleParams:
        """The nominal loop's plant: :attr:`nominal`, or the controller's model."""
        return self.nominal if self.nominal is not None else self.plant.model

    @property
    def reference_speed(self) -> float:
        """``U0`` (m/s): the middle of the slots' speed range."""
        return 0.5 * (self.speed[0] + self.speed[1])

    @property
    def along(self) -> tuple[float, float]:
        """``[lo, hi]`` of the current's component ``c_t`` along the track (m/s): :attr:`current_along`,
        or ``[-C, C]``."""
        c = self.plant.current
        return self.current_along if self.current_along is not None else (-c, c)

    @property
    def across(self) -> float:
        """Bound of the current's component ``|c_n|`` across the track (m/s): ``sqrt(C^2 - c_t^2)`` at the
        smallest ``|c_t|`` of :attr:`along`."""
        lo, hi = self.along
        least = 0.0 if lo <= 0.0 <= hi else min(abs(lo), abs(hi))
        return math.sqrt(max(self.plant.current**2 - least**2, 0.0))

    @property
    def nominal_speed(self) -> float:
        """``u0`` (m/s): the nominal loop's surge speed through the water, ``U0`` less the middle of
        :attr:`along` (``U0`` when the current is not cut into cells)."""
        lo, hi = self.along
        return self.reference_speed - 0.5 * (lo + hi)


@dataclass(frozen=True)
class Actuation:
    """Bounds of what the cascade commands, over an error box.

    Attributes
    ----------
    thrust : float
        ``|T|`` (N).
    rudder : float
        ``|delta|`` (rad).
    surge : tuple of float
        ``[min, max]`` of the surge speed through the water (m/s).
    yaw_rate : float
        ``|r|`` (rad/s).
    """

    thrust: float
    rudder: float
    surge: tuple[float, float]
    yaw_rate: float


def _gains(g: GuidanceConfig) -> tuple[float, float]:
    """The heading loop's ``(k_p, k_d)`` (1/s^2, 1/s): critically damped at ``heading_bandwidth``."""
    return g.heading_bandwidth**2, 2.0 * g.heading_bandwidth


def _rows(problem: CascadeProblem) -> dict[str, FloatArray]:
    """The nominal loop's linear expressions, as rows on ``(x, a_x, tau, u_i)`` (7 states, 3 commands).

    ``ydot`` is ``y_e'``, ``pdot`` is ``p'``, ``sight_rate`` is ``theta'`` (with ``u_i`` held at
    ``y_e``), ``yaw_rate`` is ``r - omega``, ``vdot`` is ``v'``, ``sight_accel`` is ``theta''``
    and ``erdot`` is ``e_r'``: the linear parts of the exact expressions, at ``u = U0``,
    ``theta = 0``, ``omega = 0`` and the model's coefficients.
    """
    g, m, n, act = problem.guidance, problem.plant.model, problem.nominal_plant, problem.act
    u0, delta = problem.nominal_speed, g.lookahead
    a_g, b_g = u0 / delta, g.sigma / delta

    def row(**terms: float) -> FloatArray:
        out = np.zeros(10)
        names = {
            **{n: k for k, n in enumerate(("x_e", "v_x", "y_e", "p", "e", "e_r", "v"))},
            "a_x": 7,
            "tau": 8,
            "u_i": 9,
        }
        for name, value in terms.items():
            out[names[name]] = value
        return out

    ydot = row(p=-1.0, e=u0, v=1.0)
    pdot = a_g * ydot + row(u_i=1.0)
    sight_rate = (ydot + b_g * row(y_e=1.0)) / delta
    yaw_rate = row(e_r=1.0) - sight_rate
    # the plant's coefficients are the nominal plant's; the rudder is commanded through the model's m33
    vdot = (
        -n.m11 * u0 / n.m22 * yaw_rate
        - (n.d22_lin + problem.sway_slope) / n.m22 * row(v=1.0)
        + m.m33 / (act.lever_arm * n.m22) * row(tau=1.0)
    )
    sight_accel = (-pdot + u0 * row(e_r=1.0) + vdot + b_g * ydot) / delta
    munk = (n.m22 - n.m11) * u0 / n.m33
    erdot = m.m33 / n.m33 * row(tau=1.0) - munk * row(v=1.0) + sight_accel
    return {
        "ydot": ydot,
        "pdot": pdot,
        "sight_rate": sight_rate,
        "yaw_rate": yaw_rate,
        "vdot": vdot,
        "sight_accel": sight_accel,
        "erdot": erdot,
        "xdot": row(v_x=1.0),
        "vxdot": row(a_x=1.0),
        "edot": row(e_r=1.0),
    }


#: The rows of :func:`_rows` that are the seven states' derivatives, in the order of :data:`STATES`.
STATE_ROWS = ("xdot", "vxdot", "ydot", "pdot", "edot", "erdot", "vdot")


def _state_rows(rows: dict[str, FloatArray]) -> FloatArray:
    """The nominal loop's state derivatives on ``(x, a_x, tau, u_i)``, shape (7, 10): ``[A | B]``."""
    return np.vstack([rows[k] for k in STATE_ROWS])


def _law(problem: CascadeProblem) -> FloatArray:
    """The held commands' linear law on the measured state, shape (3, 7)."""
    g, m = problem.guidance, problem.plant.model
    u0 = problem.nominal_speed
    kp, kd = _gains(g)
    d_c = np.zeros((3, 7))
    d_c[0, [X_E, V_X]] = (-g.speed_gain * g.along_track_gain, -g.speed_gain)
    d_c[1, [E, E_R, V]] = (-kp, -kd, (m.m22 - m.m11) * u0 / m.m33)
    d_c[2, Y_E] = u0 * g.sigma / g.lookahead**2
    return d_c


def cascade_loop(problem: CascadeProblem, turns: bool = True) -> SampledLoop:
    """The nominal sampled loop of one vehicle (see the module docstring), outputs the seven states.

    The held commands are ``a_x`` (m/s^2), ``tau`` (the yaw acceleration the rudder is asked
    for, rad/s^2: the heading feedback plus the Munk moment the law cancels, per the model's
    inertia) and ``u_i`` (the ILOS integral's push on ``p``, m/s^2). They are computed from the
    measurement taken ``problem.delay`` seconds before the sample, each state measured with its own
    discrete error (:func:`measurement_errors` bounds them).

    Parameters
    ----------
    problem : CascadeProblem
        The cascade (its gains, model, rudder, reference speed, sample time and delay).
    turns : bool
        Give the loop the turn's scalar signals as four more inputs (:data:`TURN_CHANNELS`): a
        mission that keeps its course has none, and its gains cost about a quarter less without them.
    """
    rows = _rows(problem)
    full = _state_rows(rows)
    outputs = np.vstack([np.hstack([np.eye(7), np.zeros((7, 3 + 7))]), _derived_outputs(problem, rows)])
    b_w = np.eye(7)
    b_w[P, Y_E] = problem.nominal_speed / problem.guidance.lookahead  # the cross-track rate's residual moves p too
    if turns:  # then the turn's scalar signals along their directions (:data:`TURN_CHANNELS`)
        b_w = np.hstack([b_w, turn_directions(problem)])
    # one error input per measured state when the measurements are noisy (the gains from them cost a
    # quarter more), else one unused column
    d_n = np.zeros((7, 1)) if problem.noise.exact else np.eye(7)
    return SampledLoop(
        full[:, :7],
        full[:, 7:],
        b_w,
        np.eye(7),
        d_n,
        np.zeros((0, d_n.shape[1])),
        np.zeros((0, 0)),
        np.zeros((0, 7)),
        np.zeros((3, 0)),
        _law(problem),
        problem.sample_time,
        problem.delay,
        outputs,
        STATES + DERIVED,
    )


def turn_equilibrium(problem: CascadeProblem) -> FloatArray:
    """The nominal loop's equilibrium per unit turn rate: every output (:data:`STATES`, :data:`DERIVED`) per rad/s.

    The slot's turn pushes the sway (the Coriolis force and the side force of the rudder that holds
    the yaw drag) and, through the line of sight's acceleration, the heading rate
    (:func:`turn_forcing`). On a steady turn the loop settles where the law holds that
    push: a sideslip ``v`` that the ILOS state's crab ``p = v`` keeps off the track, with the heading
    and cross-track errors at zero. With the held commands equal to the law at a constant state,
    the sampled loop's equilibrium is the continuous one, ``x = -(A + B K)^-1 f``.

    Parameters
    ----------
    problem : CascadeProblem
        The cascade (its nominal loop).

    Returns
    -------
    ndarray, shape (NB,)
        Signed outputs per unit ``omega`` (SI units per rad/s).
    """
    rows = _rows(problem)
    full = _state_rows(rows)
    law = _law(problem)
    state = -np.linalg.solve(full[:, :7] + full[:, 7:] @ law, turn_forcing(problem)[0])
    derived = _derived_outputs(problem, rows) @ np.concatenate([state, law @ state, state])
    out: FloatArray = np.concatenate([state, derived])
    return out


def turn_forcing(problem: CascadeProblem) -> tuple[FloatArray, FloatArray]:
    """The residuals' parts that are linear in the slot's turn: per unit ``omega`` and per unit ``omega'``.

    In ``v'``, with ``r = omega + (r - omega)`` and at the nominal plant and speed: the Coriolis force
    ``-(m11' u / m22') r`` carries ``-(m11 U0/m22) omega``, and the side force of the rudder that holds
    the yaw drag, ``(rho/l) d33(r_m) r_m / m22'``, carries ``d33_lin omega / (l m22)`` (the model's
    ``d33_lin``, as the law compensates it; ``l`` the rudder's signed lever arm). The line of sight's
    acceleration carries ``v'/Delta`` into ``e_r'``, and ``e_r = r - omega + theta_c'`` carries
    ``-omega'``. Every other term of the turn is a product with an error, with the yaw rate's
    quadratic drag or with the current's or the plant's spread, and stays in the residuals' bounds
    (:func:`residual_bounds`).

    Parameters
    ----------
    problem : CascadeProblem
        The cascade (its nominal plant, speed and lookahead).

    Returns
    -------
    tuple of ndarray, shape (7,)
        The state derivatives' coefficients of ``omega`` (1/s per rad/s, in the units of each
        state's rate) and of ``omega'``.
    """
    n = problem.nominal_plant
    m, act = problem.plant.model, problem.act
    push = -n.m11 * problem.nominal_speed / n.m22 + m.d33_lin / (act.lever_arm * n.m22)
    per_rate = np.zeros(7)
    per_rate[V], per_rate[E_R] = push, push / problem.guidance.lookahead
    per_accel = np.zeros(7)
    per_accel[E_R] = -1.0
    return per_rate, per_accel


def turn_sway_slope(problem: CascadeProblem) -> float:
    """The quadratic sway drag's slope for the nominal loop (kg/s): ``d22q`` at the sideslip the turn holds.

    On a steady turn the vehicle slips sideways at ``|E_v| omega_max`` (:func:`turn_equilibrium`,
    at zero slope), and the sway's bound is about twice that: ``d22q |E_v| omega_max`` is near the
    middle of the drag's incremental range ``[0, d22q |v|_max]``, which halves the residual the
    quadratic drag leaves and damps the nominal loop's sway as the drag does. Zero on a mission that
    keeps its course.

    Parameters
    ----------
    problem : CascadeProblem
        The cascade (its nominal plant and turn rate).
    """
    if problem.turn_rate <= 0.0:
        return 0.0
    sideslip = abs(float(turn_equilibrium(replace(problem, sway_slope=0.0))[V])) * problem.turn_rate
    return problem.nominal_plant.d22_quad * sideslip


def sway_drag_gap(slope: float, quad: tuple[float, float], sway: float) -> float:
    """The quadratic sway drag's acceleration less the nominal loop's linear part of it: its supremum (m/s^2).

    The supremum of ``|q |v| v - s v|`` over ``|v| <= V`` and every plant's ``q = d22q'/m22'`` in
    ``[q_lo, q_hi]``: ``q_hi V^2 - s V`` where the drag exceeds the slope, and where it falls short
    ``max_v (s v - q_lo v^2)``, which is ``s^2/(4 q_lo)`` at ``v = s/(2 q_lo)`` inside the range and
    ``s V - q_lo V^2`` beyond it.

    Parameters
    ----------
    slope : float
        The nominal loop's slope per unit mass, ``s/m22_n`` (1/s).
    quad : tuple of float
        ``[q_lo, q_hi]``: the box's range of ``d22q'/m22'`` (1/m).
    sway : float
        The sway speed's bound ``V`` (m/s).
    """
    q_lo, q_hi = quad
    above = q_hi * sway * sway - slope * sway
    below = slope * slope / (4.0 * q_lo) if slope < 2.0 * q_lo * sway else slope * sway - q_lo * sway * sway
    return max(above, below, 0.0)


def _derived_outputs(problem: CascadeProblem, rows: dict[str, FloatArray]) -> FloatArray:
    """The loop's rows of :data:`DERIVED`, on ``(x, a_x, tau, u_i, y_used)`` (17 columns)."""
    kp, kd = _gains(problem.guidance)
    u0 = problem.nominal_speed
    out = np.zeros((len(DERIVED), 17))
    on_x_u = {
        "ydot_lin": rows["ydot"],
        "sight_lin": rows["sight_rate"],
        "yaw_lin": rows["yaw_rate"],
        "vdot_lin": rows["vdot"],
        "pdot_lin": rows["pdot"],
        "yddot_lin": -rows["pdot"] + u0 * rows["edot"] + rows["vdot"],
        "tau": np.eye(10)[8],
        "a_x": np.eye(10)[7],
    }
    for k, name in enumerate(DERIVED):
        if name == "a_psi":  # the heading feedback the held command was computed with
            out[k, 10 + E], out[k, 10 + E_R] = -kp, -kd
        else:
            out[k, :10] = on_x_u[name]
    return out


def _off(rng: tuple[float, float], value: float) -> float:
    """``max |x - value|`` over ``x`` in ``rng``."""
    return max(abs(rng[0] - value), abs(rng[1] - value))


def _product_off(ranges: list[tuple[float, float]], divisor: tuple[float, float], value: float) -> float:
    """``max |x_1 ... x_k / y - value|`` over the ranges (positive divisor): at a corner (monotone in each)."""
    best = 0.0
    for combo in np.array(np.meshgrid(*ranges, divisor)).reshape(len(ranges) + 1, -1).T:
        best = max(best, abs(float(np.prod(combo[:-1])) / float(combo[-1]) - value))
    return best


def commands(problem: CascadeProblem, box: FloatArray, noise: FloatArray | None = None) -> FloatArray:
    """Bounds of the nominal loop's held commands ``|a_x|, |tau|, |u_i|`` over ``box`` (m/s^2, rad/s^2, m/s^2).

    Parameters
    ----------
    problem : CascadeProblem
        The cascade.
    box : ndarray, shape (7,) or (NB,)
        Bounds of the states (and of :data:`DERIVED`, whose command bounds include the noise).
    noise : ndarray, shape (7,), optional
        Bounds of the measured states' errors (:func:`measurement_errors`; default none).
    """
    box = np.asarray(box, dtype=float)
    measured = box[:7] if noise is None else box[:7] + noise
    out: FloatArray = np.abs(_law(problem)) @ measured
    if box.size == NB:
        out[:2] = np.minimum(out[:2], [box[7 + DERIVED.index("a_x")], box[7 + DERIVED.index("tau")]])
    return out


#: The noise bounds every noisy problem's nominal loop is analysed with (the loop has one error input per
#: measured state whatever the bounds; they scale its gains' columns in :func:`_image`).
UNIT_NOISE = MeasurementNoise(1.0, 1.0, 1.0, 1.0)

#: ``max_s |d/ds (Delta^2 / (s^2 + Delta^2))| * Delta = 3 sqrt(3) / 8`` (at ``s = Delta / sqrt(3)``): the
#: Lipschitz constant, per ``1/Delta``, of the line of sight's ``cos^2(theta)`` in ``s = y_e + sigma y_i``.
SIGHT_SLOPE = 3.0 * math.sqrt(3.0) / 8.0


def _integrand_gap(problem: CascadeProblem, yb: float) -> float:
    """Bound (m) of ``|s_m - s|``: the law's ``s = y_e + sigma y_i`` less the state's at the measurement's time.

    The measured cross-track error is off by at most the position noise ``n_p``; the law's own
    ``y_i`` has moved on from the interpolated ``y_i`` at ``t_k - d`` by at most ``d`` times its
    held rate, ``|y_m| cos^2(theta_m) / Delta <= (Y + n_p) / Delta``.

    Parameters
    ----------
    problem : CascadeProblem
        The cascade (its delay, noise and ILOS gains).
    yb : float
        Bound of ``|y_e|`` (m).
    """
    g, n_p = problem.guidance, problem.noise.position
    return n_p + g.sigma * problem.delay * (yb + n_p) / g.lookahead


def _ilos_rate_noise(problem: CascadeProblem, yb: float) -> float:
    """Bound (m) of ``|f(y_m, s_m) - f(y_e, s)|`` at one instant, ``f = y Delta^2 / (s^2 + Delta^2)``.

    ``Delta`` times the ILOS rate is ``f``; ``|df/dy| <= 1`` and ``|df/ds| <= SIGHT_SLOPE |y| / Delta``,
    with ``|y_m - y_e| <= n_p`` and ``|s_m - s|`` from :func:`_integrand_gap`.

    Parameters
    ----------
    problem : CascadeProblem
        The cascade.
    yb : float
        Bound of ``|y_e|`` (m).
    """
    n_p = problem.noise.position
    return n_p + SIGHT_SLOPE * (yb + n_p) * _integrand_gap(problem, yb) / problem.guidance.lookahead


def measurement_errors(problem: CascadeProblem, yb: float, ydot: float, ground: float) -> FloatArray:
    """Bounds of the seven states' errors as the law measures them: the nominal loop's discrete inputs.

    The law at ``t_k`` acts on the measurement taken at ``t_k - d`` (position within ``n_p``, body
    velocity within ``n_v``, heading within ``n_psi``, yaw rate within ``n_r``) and on its own ILOS
    state. Against the states at ``t_k - d`` (:data:`STATES`):

    * ``x_e``, ``y_e``: ``n_p``; ``v``: ``n_v``; ``p`` is not measured;
    * ``v_x`` (the ground velocity along the track): ``n_g = n_v + n_psi G``, ``G`` the ground speed's
      bound (the body velocity's error, turned by the heading's);
    * ``e``: ``n_psi + |s_m - s| / Delta`` (``atan`` is 1-Lipschitz; :func:`_integrand_gap`);
    * ``e_r``: ``n_r`` plus the line of sight's rate ``phi(s) (y' + sigma phi(s) y)``, ``phi = Delta/(s^2 +
      Delta^2) <= 1/Delta``, ``|phi'| <= SIGHT_SLOPE / Delta^2``, evaluated on the measurement: ``y'`` is
      off by ``n_g + omega n_p``, ``y`` by ``n_p``, ``s`` by ``|s_m - s|``.

    Parameters
    ----------
    problem : CascadeProblem
        The cascade (its noise, delay, guidance and turn rate).
    yb : float
        Bound of ``|y_e|`` (m).
    ydot : float
        Bound of ``|y_e'|`` (m/s).
    ground : float
        Bound of the ground speed (m/s).

    Returns
    -------
    ndarray, shape (7,)
        In the order of :data:`STATES` (m, m/s, m, m/s, rad, rad/s, m/s).
    """
    nz, g = problem.noise, problem.guidance
    if nz.exact:
        return np.zeros(7)
    delta, sigma, n_p = g.lookahead, g.sigma, nz.position
    ds = _integrand_gap(problem, yb)
    n_g = nz.velocity + nz.heading * ground
    n_ydot = n_g + problem.turn_rate * n_p
    n_e = nz.heading + ds / delta
    n_er = (
        nz.yaw_rate
        + SIGHT_SLOPE * ds * (ydot + n_ydot) / delta**2
        + n_ydot / delta
        + sigma * (2.0 * SIGHT_SLOPE * ds * (yb + n_p) / delta**3 + n_p / delta**2)
    )
    return np.array([n_p, n_g, n_p, 0.0, n_e, n_er, nz.velocity])


@dataclass(frozen=True)
class Residuals:
    """What an error box implies: the residuals' bounds, the commands' bounds, the sway speed's own bound.

    Attributes
    ----------
    inputs : ndarray, shape (7,)
        Bounds of the residuals ``w1 .. w7`` (SI units).
    actuation : Actuation
        Bounds of the commanded thrust and rudder, the surge range and the yaw rate.
    sway : float
        The bound of ``|v|`` (m/s) that the sway's own damped equation gives over the box (``inf``
        when it is not damped): a second bound of the sway speed beside the loop's.
    noise : ndarray, shape (7,)
        Bounds of the errors of the seven states as the law measures them (SI units): the
        discrete inputs of the nominal loop (:func:`measurement_errors`).
    """

    inputs: FloatArray
    actuation: Actuation
    sway: float
    noise: FloatArray = field(default_factory=lambda: np.zeros(7))


def residual_bounds(problem: CascadeProblem, box: FloatArray, turn: TurnTerms | None = None) -> Residuals | str:
    """Bounds of the seven residuals ``|w_j|`` while the states stay in ``box``, and of the commands.

    Each residual is a state's exact derivative less the nominal loop's (:func:`_rows`). Every
    inequality is written out in ``docs/derivations/guidance.md`` (section "Residuals"), term by
    term, in the order of this code. Ranges over the box of plants are taken at its corners,
    where each quantity (a product or ratio of positive coefficients) is extreme.

    Parameters
    ----------
    problem : CascadeProblem
        The cascade.
    box : ndarray, shape (7,) or (NB,)
        Bounds of ``|x_e|, |v_x|, |y_e|, |p|, |e|, |e_r|, |v|`` (SI units), then of :data:`DERIVED`.
    turn : TurnTerms or None
        How the turn's push is carried (:func:`turn_terms`; ``None``: as residual inputs, which the
        caller adds). The returned inputs never include it.

    Returns
    -------
    Residuals or str
        The residuals' bounds, the commands' bounds and the sway's own bound, or why the box is
        not an operating region of the cascade (the line of sight or the heading reaches its
        limit, the surge speed drops below the rudder's, or changes too much over one sample).
    """
    g, pl, act = problem.guidance, problem.plant, problem.act
    m, n = pl.model, problem.nominal_plant
    lag = problem.lag  # the measurement's largest age, h + d (s)
    nz = problem.noise
    xb, vxb, yb, pb, eb, erb, vb = (float(x) for x in box[:7])
    derived = dict(zip(DERIVED, map(float, box[7:]), strict=False))
    # the rates v' and y_e'' about the turn's equilibrium (:func:`turn_terms`): the linear expression
    # of x less the turn's push is z's, plus the equilibrium's held part measured h + d earlier
    # (its lagging part), so the box's entry less |E| omega_max bounds it
    still = dict.fromkeys(DERIVED, math.inf)
    if turn is not None and turn.equilibrium:
        rest = box[7:] - (turn.shift[7:] - turn.lagging[7:])
        still.update(zip(DERIVED, map(float, np.maximum(rest, 0.0)), strict=False))

    def tighter(name: str, crude: float) -> float:
        """The smaller of a sum of the states' bounds and the derived bound (both hold)."""
        return min(crude, derived.get(name, math.inf))

    u0 = problem.nominal_speed
    lo_u, hi_u = problem.speed
    c, c_rate = pl.current, pl.current_rate
    t_lo, t_hi = problem.along  # the current along the track, and across it: |c_n| <= c_n_max
    c_n_max = problem.across
    omega, omega_dot, accel = problem.turn_rate, problem.turn_accel, problem.speed_rate  # accel: |U'|
    delta, sigma = g.lookahead, g.sigma
    a_g, b_g = u0 / delta, sigma / delta
    ku, kx, lx = g.speed_gain, g.along_track_gain, g.along_track_length
    kp, kd = _gains(g)
    m11, m22, m33 = pl.interval("m11"), pl.interval("m22"), pl.interval("m33")
    munk, munk_hat, munk_n = pl.munk(), m.m22 - m.m11, n.m22 - n.m11
    lever = abs(act.lever_arm)
    # -- the line of sight theta, |(U - c_t) sin(theta)| = |p + c_n|, the track angle beta = e - theta
    # and the surge speed through the water, u cos(beta) = U + v_x - c_t + v sin(beta)
    if lo_u <= t_hi:
        return f"the current ({t_hi:.3g} m/s along the track) is not below the slots' slowest speed ({lo_u:.3g} m/s)"
    sin_t = (pb + c_n_max) / (lo_u - t_hi)
    if sin_t > MAX_SIGHT_SINE:
        return f"the line of sight reaches {math.degrees(math.asin(min(sin_t, 1.0))):.3g} deg off the track"
    cos_t = math.sqrt(1.0 - sin_t * sin_t)
    track = eb + math.asin(sin_t)
    if track > MAX_TRACK_ANGLE:
        return f"the heading reaches {math.degrees(track):.3g} deg off the track"
    sin_b, cos_b = math.sin(track), math.cos(track)
    u_lo = lo_u - vxb - t_hi - vb * sin_b
    u_hi = (hi_u + vxb - t_lo + vb * sin_b) / cos_b
    if u_lo < MIN_RUDDER_SPEED:
        return f"the surge speed may drop to {u_lo:.3g} m/s, below the rudder's {MIN_RUDDER_SPEED} m/s"
    du = max(u_hi - u0, u0 - u_lo)
    # -- what the law measures: u_m, v_m, r_m within the noise of the present ranges' past values
    um_lo, um_hi, vm = u_lo - nz.velocity, u_hi + nz.velocity, vb + nz.velocity
    if um_lo < MIN_RUDDER_SPEED:
        return f"the measured surge speed may drop to {um_lo:.3g} m/s, below the rudder's {MIN_RUDDER_SPEED} m/s"
    du_along = max(hi_u - t_lo - u0, u0 - lo_u + t_hi) + vxb + vb * sin_b  # |u cos(beta) - u0|
    # -- w3: y_e' less -p + U0 e + v
    w3 = (
        du * math.sin(eb)
        + u0 * (eb - math.sin(eb) * cos_t)
        + u_hi * (1.0 - math.cos(eb)) * sin_t
        + vb * (1.0 - cos_b)
        + (vxb + vb * sin_b + u_hi * (1.0 - cos_b)) * sin_t
        + omega * xb
    )
    y_lin = tighter("ydot_lin", pb + u0 * eb + vb)
    ydot = y_lin + w3
    sight_rate = (ydot + sigma * (yb + nz.position) / delta) / delta  # |theta'| (held ILOS rate or not)
    sight_lin = tighter("sight_lin", (y_lin + b_g * yb) / delta)  # the nominal loop's theta'
    sight_gap = (w3 + (1.0 - cos_t**2) * y_lin + b_g * (1.0 - cos_t**4) * yb) / delta
    yaw_lin = tighter("yaw_lin", erb + sight_lin)  # |e_r - theta'_nominal|
    rel_yaw = min(erb + sight_rate, yaw_lin + sight_gap)  # |r - omega|
    r_max = omega + rel_yaw
    rm = r_max + nz.yaw_rate
    noise = measurement_errors(problem, yb, ydot, u_hi + vb + c)
    # the law's line of sight: |tan(theta_m)| <= tan(theta) + |s_m - s| / Delta (:func:`_integrand_gap`)
    tan_m = sin_t / cos_t + _integrand_gap(problem, yb) / delta
    cos_m = 1.0 / math.sqrt(1.0 + tan_m * tan_m)
    # -- the commands on the measurement: the law's whole yaw acceleration, the thrust and the rudder
    a_x, tau, _ = commands(problem, box, noise)
    xm = xb + noise[X_E]
    sat_x = xm / math.sqrt(1.0 + (xm / lx) ** 2)
    a_x_sat = min(ku * (vxb + noise[V_X] + kx * sat_x), a_x + ku * kx * (xm - sat_x))
    a_psi = tighter("a_psi", kp * (eb + noise[E]) + kd * (erb + noise[E_R]))
    d33_hat = m.d33_lin + m.d33_quad * rm
    tau_full = min(
        a_psi + (d33_hat * rm + abs(munk_hat) * um_hi * vm) / m.m33,
        tau + (d33_hat * rm + abs(munk_hat) * (du + nz.velocity) * vm) / m.m33,
    )
    thrust = m.m11 * (accel + a_x_sat) + (m.d11_lin + m.d11_quad * um_hi) * um_hi + m.m22 * vm * rm
    rudder = m.m33 * tau_full / (abs(act.rudder_yaw) * um_lo**2)
    actuation = Actuation(thrust, rudder, (u_lo, u_hi), r_max)
    # -- |u'|: the law's thrust less the plant's drag, or else the thrust limit (both hold); the
    # lag's drag term slope11 (L |u'| + n_u) appears on both sides and is solved for (L = h + d: the
    # measurement's largest age, n_u its noise)
    d11_lin, d11_quad = pl.interval("d11_lin")[1], pl.interval("d11_quad")[1]
    d33_lin, d33_quad = pl.interval("d33_lin")[1], pl.interval("d33_quad")[1]
    slope11 = d11_lin + 2.0 * d11_quad * um_hi  # bound of d(d11(u) u)/du, measured speeds included
    slope33 = d33_lin + 2.0 * d33_quad * rm
    u_dot = (act.tau_x + m22[1] * vb * r_max + pl.damping("11", u_hi)[1] * u_hi) / m11[0]
    if m11[0] > slope11 * lag:
        law = (
            m.m11 * (accel + a_x_sat)
            + pl.damping_mismatch("11", u_hi) * u_hi
            + slope11 * nz.velocity
            + m22[1] * vb * r_max
            + m.m22 * vm * rm
        )
        u_dot = min(u_dot, law / (m11[0] - slope11 * lag))
    gap_u = lag * u_dot + nz.velocity  # |u - u_m|: the measurement's age and its error
    if gap_u >= um_lo or m33[0] <= slope33 * lag:
        return (
            f"the measurement's age (sample time plus delay, {lag:.3g} s) is too long for the surge speed's or "
            "the yaw drag's change over it"
        )
    rho = ((1.0 - gap_u / um_lo) ** 2, (1.0 + gap_u / um_lo) ** 2)  # (u / u_m)^2
    # -- w7: v' less its nominal; the rudder's side force and its nominal share one deflection
    inv_m22 = _off((rho[0] / m22[1], rho[1] / m22[0]), 1.0 / n.m22)  # |rho/m22' - 1/m22|
    # the yaw drag's compensation (rho/l) d33(r_m) r_m / m22' less its part linear in the turn,
    # d33_lin omega / (l m22), which :func:`turn_forcing` carries: r_m = omega(t) + q with the measurement
    # taken up to h + d earlier, |q| <= |r - omega| + n_r + (h + d) |omega'|
    drift = rel_yaw + nz.yaw_rate + lag * omega_dot
    drag_side = inv_m22 * d33_hat * rm + (m.d33_lin * drift + m.d33_quad * rm * rm) / n.m22
    side = (
        inv_m22 * m.m33 * a_psi + drag_side + abs(munk_hat) * vm * _product_off([rho, (um_lo, um_hi)], m22, u0 / n.m22)
    ) / lever
    # the slot's turn's own push on the sway (:func:`turn_forcing`) is not in w7: :func:`turn_terms` carries
    # it, and |v'| adds it back
    turn_push = abs(turn_forcing(problem)[0][V]) * omega
    w7 = (
        side
        + _product_off([m11, (u_lo, u_hi)], m22, n.m11 * u0 / n.m22) * r_max
        + n.m11 * u0 / n.m22 * sight_gap
        + _product_off([pl.interval("d22_lin")], m22, n.d22_lin / n.m22) * vb
        + sway_drag_gap(
            problem.sway_slope / n.m22, (pl.interval("d22_quad")[0] / m22[1], pl.interval("d22_quad")[1] / m22[0]), vb
        )
    )
    v_lin = tighter(
        "vdot_lin",
        n.m11 * u0 / n.m22 * yaw_lin + (n.d22_lin + problem.sway_slope) / n.m22 * vb + m.m33 / (lever * n.m22) * tau,
    )
    # |v'|: the nominal expression less the turn's push is the nominal expression of z (the equilibrium's
    # v' is zero), bounded directly by z's box
    v_dot = min(v_lin + turn_push, still["vdot_lin"]) + w7
    gap_v = lag * v_dot + nz.velocity  # |v - v_m|: the measurement's age and its error
    # -- the sway's own bound, by its damped scalar equation: m22' v' = -(d22'(v) + k_m) v + k_m (v - v_m)
    # + (rho/l)(m33 a_psi + d33(r_m) r_m) - m11' u r, with k_m = -rho m_u u_m / l the side force of the
    # rudder's Munk compensation (a damping when the rudder is aft, l < 0); |v| cannot pass the positive
    # root of d22q V^2 + (d22 + k_m) V = F while the other states stay in the box
    k_m = [-r * munk_hat * u / act.lever_arm for r in rho for u in (um_lo, um_hi)]
    k_lo, k_abs = min(k_m), max(abs(k) for k in k_m)
    force = rho[1] / lever * (m.m33 * a_psi + d33_hat * rm) + m11[1] * u_hi * r_max + k_abs * gap_v
    damping = pl.interval("d22_lin")[0] + k_lo
    d22q_lo = pl.interval("d22_quad")[0]
    if d22q_lo > 0.0:
        sway = (-damping + math.sqrt(damping * damping + 4.0 * d22q_lo * force)) / (2.0 * d22q_lo)
    else:
        sway = force / damping if damping > 0.0 else math.inf
    # -- |r'|: the law's moment against the plant's, the cancellations paired (the Munk moment on
    # the measured speeds, the yaw drag at the measured rate); the lag's drag term slope33 L |r'| is
    # solved for
    mu = pl.heading_gains()
    munk_held = vb * u_hi * (abs(munk_hat) * gap_u / um_lo + _off(munk, munk_hat))
    drag_cancel = (rho[1] - 1.0) * d33_hat * rm + pl.damping_mismatch("33", r_max) * r_max
    munk_r = abs(munk_hat) * rho[1] * u_hi * gap_v + munk_held
    r_dot = (mu[1] * rho[1] * m33[0] * a_psi + munk_r + drag_cancel + slope33 * nz.yaw_rate) / (m33[0] - slope33 * lag)
    gap_r = lag * r_dot + nz.yaw_rate  # |r - r_m|
    # -- w1: x_e' = v_x + omega y_e
    w1 = omega * yb
    # -- w2: v_x' = a_x + w2
    nu = (m.m11 / m11[1], m.m11 / m11[0])
    w2 = (
        ku * kx * (xm - sat_x)
        + max(abs(nu[1] - 1.0), abs(1.0 - nu[0] * cos_b)) * (accel + a_x_sat)
        + lag * problem.speed_jerk
        + (
            pl.damping_mismatch("11", u_hi) * u_hi
            + slope11 * gap_u
            + pl.spread("m22") * vb * r_max
            + m.m22 * (gap_v * rm + vb * gap_r)
        )
        / m11[0]
        + sin_b * v_dot
        + rel_yaw * (u_hi * sin_b + vb)
        + omega * c
        + c_rate
    )
    # -- w4: p' = (U' - c_t') sin(theta) + (U - c_t) cos(theta) theta' - c_n' less (U0/Delta)(y_e'_nominal + w3) + u_i
    w4 = (
        (accel + omega * c + c_rate) * sin_t
        + max(hi_u - t_lo - u0, u0 - (lo_u - t_hi) * cos_t**3) * ydot / delta
        + sigma / delta**2 * max(hi_u - t_lo - u0, u0 - (lo_u - t_hi) * cos_t**3 * cos_m**2) * (yb + nz.position)
        + omega * c
        + c_rate
    )
    # -- w5: e' = e_r + (the held ILOS rate less the continuous one): the rate's change over the
    # measurement's age, and the measured position's error in it (:func:`_ilos_rate_noise`)
    w5 = sigma * (lag * (ydot + 2.0 * sin_t * sight_rate * yb) + _ilos_rate_noise(problem, yb)) / delta**2
    # -- w6: e_r' = r' - omega' + theta_c'' less its nominal
    yddot_gap = (
        u_dot * sin_b
        + w7
        + v_dot * (1.0 - cos_b)
        + yaw_lin * (du_along + vb * sin_b)
        + sight_gap * (u_hi + vb * sin_b)
        + u0 * b_g * (lag * ydot + nz.position) / delta
        + omega * c
        + c_rate
        + omega_dot * xb
        + omega * (vxb + omega * yb)
    )
    yddot_lin = tighter("yddot_lin", a_g * (y_lin + b_g * yb) + u0 * erb + v_lin)
    sight_accel_gap = (
        yddot_gap
        + (1.0 - cos_t**2) * min(yddot_lin + turn_push, still["yddot_lin"])
        + b_g * (w3 + (1.0 - cos_t**4) * y_lin)
        + 2.0 * sin_t * sight_rate * (ydot + 2.0 * b_g * yb)
    ) / delta
    # the Munk moments against the nominal loop's (munk_hat U0 v_k - munk_n U0 v)/m33_n: the held speeds'
    # part, then (munk_n - munk') u v/m33' + (munk_hat - munk_n) v (u/m33' - U0/m33_n)
    munk_pair = (
        abs(munk_hat) * gap_v * _product_off([rho, (um_lo, um_hi)], m33, u0 / n.m33)
        + vb * u_hi * abs(munk_hat) * gap_u / (um_lo * m33[0])
        + vb * _off(munk, munk_n) * u_hi / m33[0]
        + vb * abs(munk_hat - munk_n) * _product_off([(u_lo, u_hi)], m33, u0 / n.m33)
    )
    mu_n = m.m33 / n.m33
    drag_pair = (drag_cancel + slope33 * gap_r) / m33[0]
    w6 = max(abs(mu[1] * rho[1] - mu_n), abs(mu_n - mu[0] * rho[0])) * a_psi + munk_pair + drag_pair + sight_accel_gap
    return Residuals(np.array([w1, w2, w3, w4, w5, w6, w7]), actuation, sway, noise)


@dataclass(frozen=True)
class CascadeCertificate:
    """The cascade's certificate, or why there is none.

    Attributes
    ----------
    holds : bool
        The errors stay in :attr:`errors` for every plant, current and mission time, and the
        commands stay within the limits.
    errors : ndarray or None
        The verified box (SI units; ``None`` when none is found): the seven :data:`STATES`, then
        the :data:`DERIVED` expressions.
    actuation : Actuation or None
        The commands' bounds over :attr:`errors`.
    reason : str
        Why it does not hold (empty when it does).
    iterations : int
        Fixed-point iterations used (summed over the cells).
    radius : float or None
        Spectral radius of the nominal loop's period map (``None`` when the loop is unstable; the
        largest over the cells).
    cells : int
        Cells certified one by one (1: the whole box and current at once; :func:`certify_cascade`).
    current_cells : int
        How many ranges of the current's along-track component those cells take (1: the whole
        range ``[-C, C]``).
    """

    holds: bool
    errors: FloatArray | None
    actuation: Actuation | None
    reason: str = ""
    iterations: int = 0
    radius: float | None = None
    cells: int = 1
    current_cells: int = 1

    @property
    def error_bounds(self) -> dict[str, float] | None:
        """``{along_track, cross_track, heading}`` (m, m, rad), or ``None``."""
        if self.errors is None:
            return None
        return {
            "along_track": float(self.errors[X_E]),
            "cross_track": float(self.errors[Y_E]),
            "heading": float(self.errors[E]),
        }

    @property
    def position_bound(self) -> float | None:
        """Bound of every vehicle's distance to its slot, ``sqrt(x_e^2 + y_e^2)`` (m), or ``None``."""
        if self.errors is None:
            return None
        return float(math.hypot(self.errors[X_E], self.errors[Y_E]))

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe figures (SI units)."""
        a = self.actuation
        return {
            "holds": self.holds,
            "error_bounds": self.error_bounds,
            "states": None if self.errors is None else dict(zip(STATES, map(float, self.errors[:7]), strict=True)),
            "derived": None if self.errors is None else dict(zip(DERIVED, map(float, self.errors[7:]), strict=True)),
            "certified_peak": None if a is None else {"force_x": a.thrust, "rudder": a.rudder},
            "surge_speed": None if a is None else list(a.surge),
            "yaw_rate": None if a is None else a.yaw_rate,
            "sway_speed": None if self.errors is None else float(self.errors[V]),
            "loop_radius": self.radius,
            "iterations": self.iterations,
            "cells": self.cells,
            "current_cells": self.current_cells,
            "reason": self.reason,
        }


#: The turn's scalar signals, each entering the nominal loop along one fixed direction
#: (:func:`turn_directions`): about the equilibrium, ``omega'`` and the held commands' lag
#: ``omega(t_k - d) - omega(t)``; as residuals, ``omega`` and ``omega'``.
TURN_CHANNELS = ("eq_accel", "eq_held", "push_rate", "push_accel")


def turn_directions(problem: CascadeProblem) -> FloatArray:
    """The directions along which the turn's scalar signals (:data:`TURN_CHANNELS`) drive the nominal loop.

    Each signal enters every state's rate through one fixed vector, so its response is one kernel:
    its peak gain keeps the cancellations between the states' channels that a sum of the channels'
    gains loses.

    Parameters
    ----------
    problem : CascadeProblem
        The cascade (its nominal loop).

    Returns
    -------
    ndarray, shape (7, 4)
        Per unit signal, each state's rate (SI units per rad/s^2, per rad/s): ``f' - E``, ``B K E``,
        ``f`` and ``f'`` (:func:`turn_terms`).
    """
    per_rate_force, per_accel = turn_forcing(problem)
    state = turn_equilibrium(problem)[:7]
    held = _state_rows(_rows(problem))[:, 7:] @ (_law(problem) @ state)
    return np.column_stack([per_accel - state, held, per_rate_force, per_accel])


@dataclass(frozen=True)
class TurnTerms:
    """How the slot's turn enters one fixed point of the certificate (:func:`turn_terms`).

    Attributes
    ----------
    shift : ndarray, shape (NB,)
        Bound of every output's part that is not ``z``'s (SI units; zero when the turn's push is left
        in the residuals): ``|E| omega_max``, and for the derived expressions that read the held
        commands or the measured states, :attr:`lagging` more.
    amplitudes : ndarray, shape (4,) or (0,)
        Bounds of the turn's scalar signals (:data:`TURN_CHANNELS`; rad/s^2, rad/s), zero for the
        channels not used; none on a mission that keeps its course (:attr:`CascadeProblem.turns`).
    per_rate : ndarray, shape (NB,)
        The equilibrium per unit turn rate ``E`` (signed, per rad/s; zero when not used).
    lagging : ndarray, shape (NB,)
        ``|D_held E| (h + d) omega'_max``: a derived expression's part from the equilibrium measured
        at ``t_k - d`` instead of now (``D_held`` its columns on the held commands and the measured
        states; zero for the states).
    """

    shift: FloatArray
    amplitudes: FloatArray
    per_rate: FloatArray
    lagging: FloatArray

    @property
    def equilibrium(self) -> bool:
        """The states are taken about the turn's equilibrium."""
        return bool(np.any(self.per_rate))


def turn_terms(problem: CascadeProblem, equilibrium: bool) -> TurnTerms:
    """The turn's part of the certificate: about the turn's equilibrium, or as residual inputs.

    **About the equilibrium.** The states are ``x = E omega(t) + z`` (:func:`turn_equilibrium`).
    With ``(A + B K) E = -f`` (:func:`turn_forcing`), ``z`` runs in the same nominal loop as ``x``
    without the turn's push, driven instead by ``(f' - E) omega'`` and by the held commands'
    equilibrium part measured at ``t_k - d``, ``B K E (omega(t_k - d) - omega(t))``, at most
    ``(h + d) |omega'|``: two scalar signals along fixed directions (:func:`turn_directions`), each
    through its own peak gain. The fixed point bounds ``z``; the states are within ``|E| omega_max``
    more, and a derived expression that reads the held commands or the measured states within
    ``|D_held E| (h + d) omega'_max`` more again (:attr:`TurnTerms.lagging`).

    **As residuals.** The push ``f omega + f' omega'`` drives the loop as two more scalar signals,
    ``omega`` and ``omega'``: the ILOS state then absorbs the push through the loop's gains, which
    for a turn entered slowly is the tighter of the two on some states (the certificate takes both,
    :func:`_certify_one`).

    Parameters
    ----------
    problem : CascadeProblem
        The cascade (its nominal loop, turn rate and turn acceleration).
    equilibrium : bool
        Take the states about the turn's equilibrium.
    """
    if not problem.turns:
        return TurnTerms(np.zeros(NB), np.zeros(0), np.zeros(NB), np.zeros(NB))
    if not equilibrium:
        amplitudes = np.array([0.0, 0.0, problem.turn_rate, problem.turn_accel])
        return TurnTerms(np.zeros(NB), amplitudes, np.zeros(NB), np.zeros(NB))
    per_rate = turn_equilibrium(problem)
    state = per_rate[:7]
    rows = _rows(problem)
    commands = _law(problem) @ state  # the held commands' equilibrium per unit turn rate
    held_part = _derived_outputs(problem, rows)[:, 7:] @ np.concatenate([commands, state])
    lagging = np.concatenate([np.zeros(7), np.abs(held_part) * problem.lag * problem.turn_accel])
    amplitudes = np.array([problem.turn_accel, problem.lag * problem.turn_accel, 0.0, 0.0])
    return TurnTerms(np.abs(per_rate) * problem.turn_rate + lagging, amplitudes, per_rate, lagging)


def _image(
    problem: CascadeProblem, gains: PeakGains, free: FloatArray, box: FloatArray, turn: TurnTerms
) -> FloatArray | str:
    """The bound of the states implied by ``box``: the turn's equilibrium, the free response, the residuals
    through the gains, the intersample motion (the last three of ``z = x - E omega``, :func:`turn_terms`)."""
    res = residual_bounds(problem, box, turn)
    if isinstance(res, str):
        return res
    z = np.maximum(box - turn.shift, 0.0)
    w = np.concatenate([res.inputs, turn.amplitudes])
    cmds = commands(problem, z, res.noise)
    at_steps = gains.continuous @ w + free
    if not problem.noise.exact:  # the loop has one error input per measured state
        at_steps = at_steps + gains.discrete @ res.noise
    between = gains.step * (gains.derivative @ np.concatenate([z[:7], cmds, w]))
    # both bound the sway speed; the sway's own bound is of v, so of z_v within the equilibrium's part more
    z_image = at_steps + between
    z_image[V] = min(z_image[V], max(problem.start[V], res.sway) + turn.shift[V])
    out: FloatArray = turn.shift + z_image
    return out


@functools.lru_cache(maxsize=64)
def _loop_analysis(
    problem: CascadeProblem, max_periods: int = MAX_PERIODS, turns: bool = True
) -> tuple[PeakGains, FloatArray] | None:
    """The nominal loop's peak gains and free response (``None`` when unstable): the costly part, shared by
    every box and current (the caller passes the problem without its current and start); with the turn's
    inputs when ``turns`` (:func:`cascade_loop`)."""
    loop = cascade_loop(problem, turns)
    gains = peak_gains(loop, max_periods)
    fp = free_peaks(loop, max_periods)
    return None if gains is None or fp is None else (gains, fp)


#: How many times :func:`certify_cascade` may halve a cell of the box that does not certify. The
#: masses are constant: every plant lies in one cell for ever, so the box is certified when every
#: cell is, and the mass ratios (the Coriolis and Munk terms, the rudder's authority) enter each
#: cell's nominal loop at the cell's centre instead of as spreads around the model. Only the cells
#: that fail are halved again.
MAX_CELL_DEPTH = 2
#: Most cells :func:`certify_cascade` certifies one by one before it gives up (each costs one
#: nominal loop's peak gains, about 0.9 s for a REMUS at 10 Hz): 80 is the 8 corners of three
#: masses and every cell of two levels of halving (8 + 64); the cells of the along-track current
#: share the budget, which bounds the time of a refusal.
MAX_CELLS = 80
#: The coefficients a cell is halved along: the three masses, on which the heading-sway block's
#: nominal coefficients depend (the Coriolis ratio ``m11/m22``, the Munk coefficient ``m22 - m11``
#: over ``m33``, the rudder's authority ``m33_hat/m33``).
CELL_PARAMETERS = ("m11", "m22", "m33")
#: Periods of a cell's nominal loop summed exactly before the tail bound is added (the whole box's
#: loop sums up to :data:`~auv_hinf.implementation.peak.MAX_PERIODS`): the ILOS loop's slowest mode
#: at 10 Hz contracts by about 0.997 per period, and from 4,096 periods on the outputs' Gramian
#: tails move no peak gain of a REMUS 100 cascade by more than 0.04 % and no free-response peak by
#: more than 0.4 % (larger, never smaller), at 60 % of the cost of 8,192.
CELL_MAX_PERIODS = 4096


def _split(problem: CascadeProblem) -> list[str]:
    """The uncertain :data:`CELL_PARAMETERS` of ``problem``'s box."""
    return [name for name in CELL_PARAMETERS if problem.plant.interval(name)[0] < problem.plant.interval(name)[1]]


def _cell(problem: CascadeProblem, bounds: dict[str, tuple[float, float]]) -> CascadeProblem:
    """``problem`` on the cell of its box with the ranges ``bounds`` (SI units; the others kept), about its centre."""
    pl, base = problem.plant, problem.nominal_plant
    values = {name: float(getattr(base, name)) for name in PARAMETERS}
    values.update({name: 0.5 * (a + b) for name, (a, b) in bounds.items()})
    centre = VehicleParams(**values, name=base.name)
    lo, hi = [], []
    for j, name in enumerate(PARAMETERS):
        a, b = bounds.get(name, pl.interval(name))
        value = values[name]
        lo.append(min(a / value, 1.0) if value > 0.0 else pl.box.lo[j])
        hi.append(max(b / value, 1.0) if value > 0.0 else pl.box.hi[j])
    box = ParameterBox(centre, tuple(lo), tuple(hi))
    return replace(problem, plant=replace(pl, box=box), nominal=centre)


def halves(problem: CascadeProblem) -> list[CascadeProblem]:
    """``problem``'s box halved along every uncertain :data:`CELL_PARAMETERS`, each half about its own centre.

    Parameters
    ----------
    problem : CascadeProblem
        The cascade (its box; ``nominal`` is replaced by each cell's centre).
    """
    pl = problem.plant
    split = _split(problem)
    out = []
    for sides in itertools.product((0, 1), repeat=len(split)):
        bounds = {}
        for name, side in zip(split, sides, strict=True):
            a, b = pl.interval(name)
            mid = 0.5 * (a + b)
            bounds[name] = (a, mid) if side == 0 else (mid, b)
        out.append(_cell(problem, bounds))
    return out


def _still(problem: CascadeProblem) -> CascadeProblem:
    """``problem`` for the controller's model alone, in still water (its start's bounds kept)."""
    pl = problem.plant
    return replace(problem, plant=Plant(pl.model, ParameterBox(pl.model), 0.0, 0.0), nominal=None, current_along=None)


def _centre_only(problem: CascadeProblem) -> CascadeProblem:
    """``problem`` for its nominal plant alone (a box of one plant; the same nominal loop)."""
    centre = problem.nominal_plant
    return replace(problem, plant=replace(problem.plant, box=ParameterBox(centre)), nominal=centre)


def _union(cover: list[tuple[tuple[float, float], CascadeCertificate]]) -> CascadeCertificate:
    """The certificate of a box and current from those of the cells that cover them (all hold), each with its
    range of the current's along-track component."""
    certs = [c for _, c in cover]
    errors = np.max(np.stack([c.errors for c in certs if c.errors is not None]), axis=0)
    acts = [c.actuation for c in certs if c.actuation is not None]
    actuation = Actuation(
        max(a.thrust for a in acts),
        max(a.rudder for a in acts),
        (min(a.surge[0] for a in acts), max(a.surge[1] for a in acts)),
        max(a.yaw_rate for a in acts),
    )
    radius = max(c.radius for c in certs if c.radius is not None)
    ranges = len({along for along, _ in cover})
    return CascadeCertificate(True, errors, actuation, "", sum(c.iterations for c in certs), radius, len(certs), ranges)


@functools.lru_cache(maxsize=256)
def certify_cascade(
    problem: CascadeProblem, cells: bool = True, mass_cells: bool = True, budget: int = MAX_CELLS
) -> CascadeCertificate:
    """The cascade's certificate (see the module docstring), on the whole box or else on cells of it.

    When the whole box and current do not certify, they are covered by cells (:func:`_cover`), each
    certified with its own nominal loop: when the current's along-track component is a constant of
    each run (:func:`current_cells_apply`), cells of that component (halved at most
    :data:`MAX_CURRENT_DEPTH` times), and where they do not suffice cells of the masses (halved at
    most :data:`MAX_CELL_DEPTH` times), at most ``budget`` cells in all. The
    whole certifies when every cell does, with the largest of the cells' bounds. A corner of the
    masses refused alone refuses at once, and the search gives up when a cell's centre (one plant,
    one current along the track) is refused alone; with a declared delay or noise it is not started
    when the controller's model in still water is refused on that navigation (the cell that holds
    it holds more). Otherwise the whole box's refusal is returned.

    Parameters
    ----------
    problem : CascadeProblem
        The cascade.
    cells : bool
        Try cells when the whole box does not certify (the advice's searches do not: a setting
        that certifies the whole box certifies with cells too).
    mass_cells : bool
        With ``cells``, cut the masses too (else only the along-track current: a few cells, for the
        advice's search of gains; what certifies so certifies with every kind of cell too).
    budget : int
        Most cells certified (default :data:`MAX_CELLS`, a re-run's). The search is the same whatever
        the budget, which only stops it sooner: what certifies within a smaller one certifies within
        the default.
    """
    whole = _certify_one(problem)
    if whole.holds or not cells or problem.nominal is not None or problem.current_along is not None:
        return whole
    if not ((mass_cells and _split(problem)) or current_cells_apply(problem)):
        return whole
    if (problem.delay > 0.0 or not problem.noise.exact) and not _certify_one(_still(problem)).holds:
        # the cell holding the nominal plant in still water holds more than it: no cover certifies
        # in practice, and the search would spend its whole budget to find that out
        return replace(
            whole,
            reason=f"{whole.reason} (no cells tried: the nominal plant in still water is refused on this "
            "navigation, its delay and noise)",
        )
    with tqdm(total=budget, unit="cell", desc="cells of the box", leave=False, delay=PROGRESS_DELAY) as bar:
        # the search prefers the current's cells wherever they apply, so without the masses' cells it
        # takes the same halvings and stops where the masses' would start: whatever the advice's search
        # of gains certifies so (mass_cells=False), a re-run certifies with the same cells
        cover = _cover(problem, bar, MAX_CELL_DEPTH if mass_cells else 0, MAX_CURRENT_DEPTH)
    if isinstance(cover, list):
        return _union(cover)
    cut = (("the current", current_cells_apply(problem)), ("the masses", mass_cells and bool(_split(problem))))
    split = [x for x, on in cut if on]
    what = " and ".join(split)
    return replace(whole, reason=f"{whole.reason} (cells of {what} do not certify either: {cover})")


#: How many times :func:`certify_cascade` may halve a range of the current's along-track component
#: that does not certify (2: quarters of ``[-C, C]``, each ``C/2`` wide; a range that still fails is
#: then cut along the masses, within the cells' budget :data:`MAX_CELLS`).
MAX_CURRENT_DEPTH = 2


def current_cells_apply(problem: CascadeProblem) -> bool:
    """The current's along-track component ``c_t`` is a constant of every run, so cells of it cover the current.

    On a mission that keeps its course (no turns) in a constant current, ``c_t`` and ``c_n`` never
    change: every run lies in one cell of ``c_t`` for ever. Within the cell the nominal loop's surge
    speed is ``U0`` less the cell's middle ``c_t`` (:attr:`CascadeProblem.nominal_speed`), which puts
    the ILOS gain's dependence on the water speed, ``(U - c_t)/Delta``, in the nominal loop instead
    of a residual that the integral action amplifies.

    Parameters
    ----------
    problem : CascadeProblem
        The cascade.
    """
    pl = problem.plant
    return pl.current > 0.0 and pl.current_rate == 0.0 and problem.turn_rate == 0.0


def current_halves(problem: CascadeProblem) -> list[CascadeProblem]:
    """``problem`` with its range of the current's along-track component (:attr:`CascadeProblem.along`) halved.

    Parameters
    ----------
    problem : CascadeProblem
        The cascade.
    """
    lo, hi = problem.along
    mid = 0.5 * (lo + hi)
    return [replace(problem, current_along=(lo, mid)), replace(problem, current_along=(mid, hi))]


def _current_centre(problem: CascadeProblem) -> CascadeProblem:
    """``problem`` with its range of the along-track current narrowed to its middle (when cells of it apply)."""
    if not current_cells_apply(problem):
        return problem
    mid = 0.5 * sum(problem.along)
    return replace(problem, current_along=(mid, mid))


def _cover(
    problem: CascadeProblem, bar: tqdm, mass_depth: int, current_depth: int
) -> list[tuple[tuple[float, float], CascadeCertificate]] | str:
    """Cells that cover ``problem`` (which does not certify whole), each certified, or why there are none.

    The problem is halved along the current's along-track component when its middle value alone
    certifies with the cell's whole range of masses (then the masses' spread is not what binds),
    else along the masses; a half that fails is covered the same way, at most ``mass_depth`` and
    ``current_depth`` more halvings. It gives up when the cell's centre (one plant,
    one current along the track) is refused alone: no finer cell around it would certify.
    ``bar`` counts the cells certified against its total, the budget.
    """
    if not _certify_one(_current_centre(_centre_only(problem)), CELL_MAX_PERIODS).holds:
        return f"the plant at the centre of the cell with {_masses(problem)} is refused alone"
    # finer ranges of the current help only when its middle value alone certifies with this cell's masses
    by_current = (
        current_cells_apply(problem)
        and current_depth > 0
        and _certify_one(_current_centre(problem), CELL_MAX_PERIODS).holds
    )
    by_masses = bool(_split(problem)) and mass_depth > 0
    if by_current:
        parts, current_depth = current_halves(problem), current_depth - 1
    elif by_masses:
        # the corners' quick refusal, once, on the whole current (within a range of it, the halves' centres)
        refused = (
            _refused_vertex(problem, bar) if mass_depth == MAX_CELL_DEPTH and problem.current_along is None else ""
        )
        if refused:
            return refused
        parts, mass_depth = halves(problem), mass_depth - 1
    else:
        return f"the cell {_masses(problem)} is refused, and halved as often as allowed"
    out: list[tuple[tuple[float, float], CascadeCertificate]] = []
    for part in parts:
        if bar.n >= bar.total:
            return f"{bar.total} cells were tried"
        bar.update(1)
        cert = _certify_one(part, CELL_MAX_PERIODS)
        if cert.holds:
            out.append((part.along, cert))
            continue
        deeper = _cover(part, bar, mass_depth, current_depth)
        if isinstance(deeper, str):
            return deeper
        out += deeper
    return out


def _mass_vertices(problem: CascadeProblem) -> list[CascadeProblem]:
    """``problem`` at each corner of its masses' ranges (the other coefficients' ranges kept), the
    smallest Munk coefficient ``m22 - m11`` first; each corner is its own nominal plant."""
    pl = problem.plant
    split = _split(problem)
    out = [
        _cell(problem, {name: (pl.interval(name)[end],) * 2 for name, end in zip(split, ends, strict=True)})
        for ends in itertools.product((0, 1), repeat=len(split))
    ]
    return sorted(out, key=lambda c: c.nominal_plant.m22 - c.nominal_plant.m11)


def _refused_vertex(problem: CascadeProblem, bar: tqdm) -> str:
    """Why the first corner of the masses that is refused alone is refused (empty when none is).

    A cell that holds a refused corner would have to do better than the corner's own nominal loop:
    the search does not try, and refuses at once (each corner costs one nominal loop, the smallest
    Munk coefficient first, where the heading-sway block is weakest). When cells of the along-track
    current apply, each corner is taken at the middle of the current's range: some cell holds both."""
    for corner in _mass_vertices(problem):
        bar.update(1)
        single = _current_centre(corner)
        if not _certify_one(single, CELL_MAX_PERIODS).holds:
            return f"the corner {_masses(single)} of the masses, with the box's other ranges, is refused alone"
    return ""


def _masses(problem: CascadeProblem) -> str:
    """The cell's mass ranges (or values), and its range of the along-track current when it has one, for a
    refusal (kg, kg, kg m^2, m/s)."""
    parts = []
    for name, unit in zip(CELL_PARAMETERS, ("kg", "kg", "kg m^2"), strict=True):
        lo, hi = problem.plant.interval(name)
        parts.append(f"{name} = {lo:.4g} {unit}" if lo == hi else f"{name} in [{lo:.4g}, {hi:.4g}] {unit}")
    if problem.current_along is not None:
        lo, hi = problem.current_along
        parts.append(f"c_t = {lo:.3g} m/s" if lo == hi else f"c_t in [{lo:.3g}, {hi:.3g}] m/s along the track")
    return ", ".join(parts)


def _certify_one(problem: CascadeProblem, max_periods: int = MAX_PERIODS) -> CascadeCertificate:
    """The certificate of one box, with the nominal loop at ``problem.nominal_plant`` and its quadratic sway drag
    at the turn's slope (:func:`turn_sway_slope`)."""
    if problem.guidance.sigma <= 0.0:
        return CascadeCertificate(False, None, None, 'plain LOS is not certified in this version: use kind = "ilos"')
    problem = replace(problem, sway_slope=turn_sway_slope(problem))
    model, u0 = problem.plant.model, problem.reference_speed
    key = replace(  # what the nominal loop depends on: the gains, the model, the nominal plant, the rudder, U0, h, d
        problem,
        plant=Plant(model, ParameterBox.from_ranges(model, ())),
        speed=(u0, u0),
        speed_rate=0.0,
        turn_rate=0.0,
        turn_accel=0.0,
        speed_jerk=0.0,
        start=(0.0,) * 7,
        start_turn=None,
        noise=MeasurementNoise() if problem.noise.exact else UNIT_NOISE,
    )
    analysis = _loop_analysis(key, max_periods, problem.turns)
    if analysis is None:
        return CascadeCertificate(
            False,
            None,
            None,
            f"the nominal sampled cascade is unstable at h = {problem.sample_time:.4g} s, delay {problem.delay:.4g} s",
        )
    gains, fp = analysis
    start = np.asarray(problem.start, dtype=float)
    if not np.all(np.isfinite(start)):
        return CascadeCertificate(
            False,
            None,
            None,
            "the start is not bounded: the current is too strong for the start's crab",
            0,
            gains.radius,
        )
    fixed = [_fixed_point(problem, gains, fp, turn_terms(problem, False))]
    if problem.turns:
        fixed.append(_fixed_point(problem, gains, fp, turn_terms(problem, True)))
    boxes = [f[0] for f in fixed if not isinstance(f[0], str)]
    k = sum(f[1] for f in fixed)
    if not boxes:
        return CascadeCertificate(False, None, None, str(fixed[0][0]), k, gains.radius)
    # every trajectory stays in each invariant box, so in their intersection, over which the commands are bounded
    final: FloatArray = np.min(boxes, axis=0)
    res = residual_bounds(problem, final)
    # the intersection takes each state from the box that bounds it better; a bound that is not
    # monotone in the box (the surge acceleration's hold term, solved for on both sides) can refuse
    # that mixture as an operating region, so each box is tried on its own then (each is invariant)
    for box in boxes:
        if not isinstance(res, str):
            break
        final, res = box, residual_bounds(problem, box)
    if isinstance(res, str):
        return CascadeCertificate(False, None, None, f"no error box is an operating region: {res}", k, gains.radius)
    actuation = res.actuation
    over = []
    if actuation.thrust > problem.act.tau_x:
        over.append(f"thrust {actuation.thrust:.4g} N > {problem.act.tau_x:.4g} N")
    if actuation.rudder > problem.act.rudder_max:
        over.append(f"rudder {actuation.rudder:.4g} rad > {problem.act.rudder_max:.4g} rad")
    if over:
        return CascadeCertificate(
            False, final, actuation, "the commands exceed the limits: " + ", ".join(over), k, gains.radius
        )
    return CascadeCertificate(True, final, actuation, "", k, gains.radius)


def _fixed_point(
    problem: CascadeProblem, gains: PeakGains, fp: FloatArray, turn: TurnTerms
) -> tuple[FloatArray | str, int]:
    """An invariant box of the cascade with the turn carried as ``turn`` says, or why none closes; and the iterations.

    Parameters
    ----------
    problem : CascadeProblem
        The cascade.
    gains : PeakGains
        Its nominal loop's peak gains.
    fp : ndarray
        Its nominal loop's free-response peaks (every output per unit start state).
    turn : TurnTerms
        How the turn enters (:func:`turn_terms`).
    """
    start = np.asarray(problem.start, dtype=float)
    # z(0) = x(0) - E omega(0): the free response of z, with the slots' turn at the start
    free = np.abs(fp) @ (start + np.abs(turn.per_rate[:7]) * problem.turn_start)  # every output: states and DERIVED
    box = turn.shift + free
    for k in range(1, MAX_ITERATIONS + 1):
        nxt = _image(problem, gains, free, box, turn)
        if isinstance(nxt, str):
            return f"the small-gain bound does not close: the error bounds grow until {nxt}", k
        if np.all(nxt <= box * (1.0 + FIXED_POINT_RTOL) + FIXED_POINT_FLOOR):
            break
        box = np.maximum(box, nxt)
    else:
        return "no error box closes: the fixed point does not converge", k
    # the strict inclusion, on the fixed point inflated; a component driven only by products of the
    # others grows faster than the inflation, so the inflation is repeated on the image
    final = box * (1.0 + FIXED_POINT_MARGIN) + FIXED_POINT_FLOOR
    for _ in range(INFLATIONS):
        image = _image(problem, gains, free, final, turn)
        if isinstance(image, str) or np.all(image < final):
            break
        final = np.maximum(final, image * (1.0 + FIXED_POINT_MARGIN) + FIXED_POINT_FLOOR)
    if isinstance(image, str) or not np.all(image < final):
        return f"no error box closes: {image if isinstance(image, str) else 'the inflated box is not invariant'}", k
    return final, k


def cascade_states(
    problem: CascadeProblem, states: FloatArray, integral: FloatArray, slot: SlotMotion, current: FloatArray
) -> FloatArray:
    """The seven states (:data:`STATES`) of vehicles at ``states`` with ILOS states ``integral``, shape (N, 7).

    Parameters
    ----------
    problem : CascadeProblem
        The cascade (its lookahead and integral gain).
    states : ndarray, shape (N, 6)
        ``[x, y, psi, u, v, r]`` of every vehicle (water-relative body velocities).
    integral : ndarray, shape (N,)
        The controller's ILOS states ``y_i`` (s).
    slot : SlotMotion
        The slots at that time.
    current : ndarray, shape (2,)
        The current (m/s, inertial).
    """
    g = problem.guidance
    delta, sigma = g.lookahead, g.sigma
    c = np.asarray(current, dtype=float)
    psi, u, v, r = states[:, 2], states[:, 3], states[:, 4], states[:, 5]
    speed = slot.speed
    omega = slot.course_rate
    xe, ye = slot.along_across(states[:, 0] - slot.p[:, 0], states[:, 1] - slot.p[:, 1])
    theta = np.arctan((ye + sigma * integral) / delta)
    e = wrap_angle(psi - (slot.course - theta))
    gx = np.cos(psi) * u - np.sin(psi) * v + c[0]
    gy = np.sin(psi) * u + np.cos(psi) * v + c[1]
    ct, cn = slot.along_across(c[0], c[1])
    g_along, g_across = slot.along_across(gx, gy)
    vx = g_along - speed
    ydot = g_across - omega * xe
    cos2 = np.cos(theta) ** 2
    er = r - omega + cos2 * (ydot + sigma * cos2 * ye / delta) / delta
    p = (speed - ct) * np.sin(theta) - cn
    out: FloatArray = np.stack([xe, vx, ye, p, e, er, v], axis=-1)
    return out


def start_states(
    problem: CascadeProblem, states: FloatArray, slot: SlotMotion, current: FloatArray | None
) -> FloatArray:
    """Bounds of the seven states at ``t = 0`` of vehicles started at ``states`` (shape (7,), SI units).

    The ILOS state starts as the controller starts it (:func:`~auv_hinf.guidance.law.integral_start`).

    Parameters
    ----------
    problem : CascadeProblem
        The cascade.
    states : ndarray, shape (N, 6)
        ``[x, y, psi, u, v, r]`` of every vehicle at ``t = 0`` (water-relative body velocities).
    slot : SlotMotion
        The slots at ``t = 0``.
    current : ndarray, shape (2,), or None
        The current the start is taken in (m/s); ``None``: any current up to the bound ``C``. The
        current moves ``v_x`` by at most ``C``, ``p`` by ``C sqrt(1 + sin(theta)^2)`` and ``e_r`` by
        ``C`` over the lookahead; the states are computed in no current and widened so.
    """
    c_free = problem.plant.current if current is None else 0.0
    flow = np.zeros(2) if current is None else np.asarray(current, dtype=float)
    x = np.abs(cascade_states(problem, states, integral_start(problem.guidance, states, slot), slot, flow))
    # p = (U - c_t) sin(theta) - c_n moves by |c_t sin(theta) + c_n| <= C sqrt(1 + sin(theta)^2) with the
    # current; in no current sin(theta) = p / U
    sin_t = np.minimum(x[:, P] / slot.speed, 1.0) if current is None else np.zeros(len(x))
    x[:, P] += c_free * np.sqrt(1.0 + sin_t**2)
    x[:, V_X] += c_free
    x[:, E_R] += c_free / problem.guidance.lookahead
    out: FloatArray = x.max(axis=0)
    return out


def into_current_start(problem: CascadeProblem, slot: SlotMotion) -> FloatArray:
    """Bounds of the states at ``t = 0`` of vehicles on their slots heading into any current up to the bound.

    ``simulate`` and ``campaign`` start every vehicle so: its ground velocity is its slot's and the
    ILOS state holds its crab (:func:`~auv_hinf.guidance.law.integral_start`). Then
    ``x_e = y_e = e = v_x = v = 0``, ``p = c_n (cos(theta) - 1)`` (the crab ``theta`` makes
    ``u sin(theta) = c_n`` with ``u cos(theta) = U - c_t``; ``|sin(theta)| <= C/(U - C)``) and
    ``e_r = -omega`` (rad/s). A current too strong for :data:`~auv_hinf.guidance.law.MAX_START_CRAB`
    leaves the start unbounded (``inf``).

    Parameters
    ----------
    problem : CascadeProblem
        The cascade.
    slot : SlotMotion
        The slots at ``t = 0``.
    """
    c = problem.plant.current
    speed = slot.speed
    slowest = float(speed.min())
    if c >= slowest * math.sin(MAX_START_CRAB):
        return np.full(7, math.inf)
    omega = slot.course_rate
    crab = math.asin(c / (slowest - c)) if c < 0.5 * slowest else 0.5 * math.pi
    p = c * (1.0 - math.cos(crab))
    return np.array([0.0, 0.0, 0.0, p, 0.0, float(np.abs(omega).max()), 0.0])


__all__ = [
    "FIXED_POINT_FLOOR",
    "FIXED_POINT_MARGIN",
    "FIXED_POINT_RTOL",
    "INFLATIONS",
    "MAX_ITERATIONS",
    "MAX_SIGHT_SINE",
    "MAX_TRACK_ANGLE",
    "SIGHT_SLOPE",
    "STATES",
    "TURN_CHANNELS",
    "Actuation",
    "CascadeCertificate",
    "CascadeProblem",
    "Residuals",
    "TurnTerms",
    "cascade_loop",
    "cascade_states",
    "certify_cascade",
    "into_current_start",
    "measurement_errors",
    "residual_bounds",
    "start_states",
    "sway_drag_gap",
    "turn_directions",
    "turn_equilibrium",
    "turn_forcing",
    "turn_sway_slope",
    "turn_terms",
]
