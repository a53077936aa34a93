"""Does the closed-loop certificate cover one particular run?

A run is a start (one ``[x, y, psi, u, v, r]`` per vehicle), a mission reference and a start
mode. It is *covered* when the certificate proves that every vehicle stays inside the
envelope for all time (see ``docs/derivations/closed_loop.md``):

1. the errors at ``t = 0`` against the reference actually used give, through the certified
   non-increasing Lyapunov functions (:class:`~auv_hinf.closed_loop.region.RegionCertificate`), bounds of
   every later error (:func:`~auv_hinf.numerics.quadratic_forms.start_bounds`);
2. the reference's sound tube (:mod:`auv_hinf.mission.tubes`) plus those bounds keeps every margin
   ``>= 0`` (:func:`~auv_hinf.mission.margins.envelope_margins`);
3. the thrust the law needs stays below the configured limits (saturation voids the argument).

Start modes: ``"paper"`` tracks the raw mission from the raw start. ``"shaped"`` first checks
the raw start (a start already inside the certified set needs no shaping); otherwise it tries
shaped starts (:func:`~auv_hinf.mission.fleet.shaped_start`) with the candidate blend and turn
times in order of increasing blend time and keeps the first one that is covered.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass, replace
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike
from tqdm.auto import tqdm

from auv_hinf._typing import FloatArray, FormationFrame
from auv_hinf.actuation.limits import Actuators, actuator_shortfall
from auv_hinf.actuation.thrust import ThrustBounds, thrust_bounds
from auv_hinf.closed_loop.nominal import ClosedLoopCertificate
from auv_hinf.exceptions import AuvHinfError, ParameterError
from auv_hinf.law.gains import Gains
from auv_hinf.mission.fleet import FleetReference, ReferenceTube, shaped_start, wrap_angle
from auv_hinf.mission.margins import ErrorBounds, Margins, envelope_margins, inflate_envelope
from auv_hinf.mission.paths import MissionReference
from auv_hinf.mission.tubes import MAX_CELLS, default_cells, shaped_tube
from auv_hinf.models.envelope import Envelope
from auv_hinf.models.vehicle import VehicleParams
from auv_hinf.numerics.progress import PROGRESS_DELAY
from auv_hinf.numerics.quadratic_forms import start_bounds

StartMode = Literal["shaped", "paper"]

#: Candidate blend times ``T_b`` (s) of the shaped start, tried in this order.
BLEND_TIMES: tuple[float, ...] = (30.0, 45.0, 60.0, 90.0, 120.0, 150.0, 200.0, 250.0, 300.0)
#: Candidate turn times ``T_h`` (s) of the velocity and heading blends, tried for each ``T_b``.
TURN_TIMES: tuple[float, ...] = (20.0, 40.0, 60.0)
#: Vehicles whose tubes are built at once: bounds the memory of the cell arrays
#: (about 25,000 cells per vehicle for a 100 s blend).
TUBE_CHUNK = 16


@dataclass(frozen=True)
class Coverage:
    """Verdict of the certificate on one run.

    Attributes
    ----------
    covered : bool
        The certificate proves the run stays inside the envelope.
    start : {"shaped", "paper"}
        The start mode asked for.
    reference : FleetReference
        The reference the run should track (shaped or raw).
    bounds : ErrorBounds
        Certified sup-in-time error bounds of the run against ``reference`` (largest over the
        vehicles): m, m/s, rad, rad/s.
    margins : Margins or None
        Envelope margins of the run (m/s, rad/s), ``None`` when they could not be computed.
    thrust : ThrustBounds or None
        Certified bounds of the thrust the law needs (N, N, N m).
    blend_time, turn_time : float or None
        ``T_b`` and ``T_h`` (s) of the shaped start; ``None`` when the raw reference is used.
    reason : str
        One line: why the run is or is not covered.
    """

    covered: bool
    start: str
    reference: FleetReference
    bounds: ErrorBounds
    margins: Margins | None
    thrust: ThrustBounds | None
    blend_time: float | None
    turn_time: float | None
    reason: str

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe dictionary."""
        return {
            "covered": self.covered,
            "start": self.start,
            "blend_time": self.blend_time,
            "turn_time": self.turn_time,
            "bounds": self.bounds.to_dict(),
            "margins": None if self.margins is None else self.margins.to_dict(),
            "thrust": None if self.thrust is None else self.thrust.to_dict(),
            "reason": self.reason,
        }


def initial_errors(
    fleet: FleetReference, initial: ArrayLike, current: ArrayLike = (0.0, 0.0)
) -> tuple[FloatArray, ...]:
    """Errors of each vehicle at ``t = 0`` against ``fleet``.

    Parameters
    ----------
    fleet : FleetReference
        The reference tracked.
    initial : array_like, shape (..., N, 6)
        ``[x, y, psi, u, v, r]`` per vehicle (m, m, rad, m/s, m/s body frame, rad/s); leading
        axes are independent starts (scenarios).
    current : array_like
        Water current (m/s, inertial), broadcastable to ``(..., N, 2)``; the ground velocity
        is ``R(psi) [u, v] + current``.

    Returns
    -------
    e, de : ndarray, shape (..., N, 2)
        Position (m) and ground-velocity (m/s) errors, inertial frame.
    epsi, depsi : ndarray, shape (..., N)
        Heading error wrapped to (-pi, pi] (rad) and yaw-rate error (rad/s).
    """
    init = np.asarray(initial, dtype=float)
    m = fleet.motion(0.0)
    psi, u, v, r = init[..., 2], init[..., 3], init[..., 4], init[..., 5]
    c, s = np.cos(psi), np.sin(psi)
    vel = np.stack([c * u - s * v, s * u + c * v], axis=-1) + np.asarray(current, dtype=float)
    return init[..., :2] - m.p, vel - m.v, wrap_angle(psi - m.psi), r - m.r


def _merge_margins(parts: list[Margins]) -> Margins:
    return Margins(*(min(getattr(m, f) for m in parts) for f in ("u_hi", "u_lo", "v_hi", "v_lo", "r_hi", "r_lo")))


def _chunks(fleet: FleetReference) -> Iterable[FleetReference]:
    n = fleet.offsets.shape[0]
    sh = fleet.shaping
    for lo in range(0, n, TUBE_CHUNK):
        sl = slice(lo, min(n, lo + TUBE_CHUNK))
        if sh is None:
            yield FleetReference(fleet.mission, fleet.offsets[sl], None, fleet.frame)
            return
        part = type(sh)(sh.blend_time, sh.dp[sl], sh.dv[sl], sh.dpsi[sl], sh.dr[sl], sh.turn_time)
        yield FleetReference(fleet.mission, fleet.offsets[sl], part, fleet.frame)


def _fleet_margins(
    envelope: Envelope, fleet: FleetReference, bounds: ErrorBounds, tick: Callable[[], object]
) -> tuple[Margins, int]:
    """Margins of ``fleet``, :data:`TUBE_CHUNK` vehicles at a time, on one time grid, and its cell count.

    The cell count is chosen once for the whole fleet (:func:`~auv_hinf.mission.tubes.default_cells`)
    so that the result does not depend on the chunking; it is multiplied by 4 (up to
    :data:`~auv_hinf.mission.tubes.MAX_CELLS`) while some cell's speed cannot be bounded away from
    zero. ``tick`` is called after every chunk.
    """
    cells = default_cells(fleet)
    while True:
        try:
            parts = []
            for part in _chunks(fleet):
                parts.append(envelope_margins(_tube(part, cells), bounds, envelope))
                tick()
            return _merge_margins(parts), cells
        except ParameterError:
            if cells >= MAX_CELLS:
                raise
            cells = min(MAX_CELLS, 4 * cells)


def _fleet_thrust(
    params: VehicleParams, envelope: Envelope, gains: Gains, fleet: FleetReference, bounds: ErrorBounds, cells: int
) -> ThrustBounds:
    """Thrust bounds of ``fleet`` on the grid of ``cells`` cells that :func:`_fleet_margins` settled on."""
    env = inflate_envelope(envelope)
    parts = [thrust_bounds(params, env, _tube(part, cells), bounds, gains) for part in _chunks(fleet)]
    return ThrustBounds(*(max(getattr(t, f) for t in parts) for f in ("force_x", "force_y", "moment")))


def _tube(part: FleetReference, cells: int) -> ReferenceTube:
    return shaped_tube(part, cells=cells if part.shaping is not None else None)


def check_run(
    cert: ClosedLoopCertificate,
    params: VehicleParams,
    envelope: Envelope,
    gains: Gains,
    fleet: FleetReference,
    initial: ArrayLike,
    *,
    actuators: Actuators | None = None,
    start: str = "paper",
    lazy_thrust: bool = False,
    on_tube: Callable[[], object] = lambda: None,
) -> Coverage:
    """Coverage of the run that tracks ``fleet`` from ``initial`` (see the module docstring).

    Parameters
    ----------
    cert : ClosedLoopCertificate
        The certificate (its region's Lyapunov matrices are used).
    params : VehicleParams
        The controller's (and, for a covered run, the plant's) parameters.
    envelope : Envelope
        The certified envelope.
    gains : Gains
        The gains of the law.
    fleet : FleetReference
        Reference tracked by the run.
    initial : array_like, shape (N, 6)
        Initial states.
    actuators : Actuators, optional
        What the vehicles can push; the run is covered only if its certified thrust fits.
    start : str
        Start mode recorded in the result.
    lazy_thrust : bool
        Leave ``thrust`` as ``None`` when the margins already fail: it cannot change the verdict
        (:func:`cover_start` computes it only for the candidate it reports).
    on_tube : callable, optional
        Called after each chunk of :data:`TUBE_CHUNK` vehicles' tubes (progress).
    """
    e, de, ep, dep = initial_errors(fleet, initial)
    p2, q = cert.region.p2, cert.region.q
    if (p2 is None and (np.any(e != 0) or np.any(de != 0))) or (q is None and (np.any(ep != 0) or np.any(dep != 0))):
        nan = ErrorBounds(math.inf, math.inf, math.inf, math.inf)
        why = "the certificate has no Lyapunov function for nonzero initial errors"
        return Coverage(False, start, fleet, nan, None, None, None, None, why)
    eye = np.eye(2)
    per = start_bounds(eye if p2 is None else p2, eye if q is None else q, e, de, ep, dep)
    bounds = ErrorBounds(*(float(x) for x in per.max(axis=0)))
    sh = fleet.shaping
    tb, th = (None, None) if sh is None else (sh.blend_time, sh.th)
    if not bounds.heading < 0.5 * math.pi:
        why = f"heading error bound {bounds.heading:.4g} rad reaches pi/2"
        return Coverage(False, start, fleet, bounds, None, None, tb, th, why)
    try:
        marg, cells = _fleet_margins(envelope, fleet, bounds, on_tube)
        thrust = None if lazy_thrust and not marg.ok else _fleet_thrust(params, envelope, gains, fleet, bounds, cells)
    except AuvHinfError as exc:
        return Coverage(False, start, fleet, bounds, None, None, tb, th, str(exc))
    covered = False
    if not marg.ok:
        worst = min(("u_hi", "u_lo", "v_hi", "v_lo", "r_hi", "r_lo"), key=lambda f: getattr(marg, f))
        unit = "rad/s" if worst.startswith("r") else "m/s"
        side = "upper" if worst.endswith("hi") else "lower"
        channel = {"u": "surge speed", "v": "sway speed", "r": "yaw rate"}[worst[0]]
        reason = (
            f"not covered: the {channel} would cross the envelope's {side} edge "
            f"(certified margin {getattr(marg, worst):.4g} {unit} < 0)"
        )
    elif actuators is not None and thrust is not None and not actuators.admits(thrust.as_tuple()):
        reason = "not covered: " + actuator_shortfall(actuators, thrust.as_tuple())
    else:
        covered = True
        reason = "covered: start inside the certified invariant set, reference inside the envelope"
    return Coverage(covered, start, fleet, bounds, marg, thrust, tb, th, reason)


def cover_start(
    cert: ClosedLoopCertificate,
    params: VehicleParams,
    envelope: Envelope,
    gains: Gains,
    mission: MissionReference,
    offsets: ArrayLike,
    initial: ArrayLike,
    *,
    start: StartMode = "shaped",
    blend_time: float | None = None,
    actuators: Actuators | None = None,
    current: tuple[float, float] = (0.0, 0.0),
    frame: FormationFrame = "inertial",
    progress: bool = False,
) -> Coverage:
    """Choose the reference for a run and decide whether the certificate covers it.

    Parameters
    ----------
    cert, params, envelope, gains
        As in :func:`check_run`.
    mission : MissionReference
        The mission's centre path.
    offsets : array_like, shape (N, 2)
        Formation offsets (m).
    initial : array_like, shape (N, 6)
        Initial states ``[x, y, psi, u, v, r]``.
    start : {"shaped", "paper"}
        Start mode (see the module docstring).
    blend_time : float, optional
        Fixed ``T_b`` (s) of the shaped start; by default the candidates :data:`BLEND_TIMES`.
    actuators : Actuators, optional
        What the vehicles can push.
    current : tuple of float
        Water current of the run (m/s, inertial): the shaped start matches the actual ground
        velocity ``R(psi) [u, v] + current``. A run with a current is covered only by the
        robust certificate (:mod:`auv_hinf.robust.summary`).
    frame : {"inertial", "path"}
        Frame of the offsets (:class:`~auv_hinf.mission.fleet.FleetReference`).
    progress : bool
        Show a tqdm bar (stderr) over the candidates' tubes once the search has taken
        :data:`~auv_hinf.numerics.progress.PROGRESS_DELAY` s (a search that ends sooner, as every
        start near its slots does, prints nothing).

    Returns
    -------
    Coverage
        For ``"shaped"``, the first covered candidate; when none is covered, the candidate
        with the largest smallest margin (the first of equals), its reason prefixed.
    """
    if start not in ("shaped", "paper"):
        raise ParameterError(f"start must be 'shaped' or 'paper', got {start!r}")
    raw = FleetReference(mission, np.asarray(offsets, dtype=float), None, frame)
    base = check_run(cert, params, envelope, gains, raw, initial, actuators=actuators, start=start)
    if start == "paper" or base.covered:
        return base
    blends = BLEND_TIMES if blend_time is None else (float(blend_time),)
    order = [(tb, th) for tb in blends for th in ([t for t in TURN_TIMES if t <= tb] or [tb])]
    n_chunks = math.ceil(raw.offsets.shape[0] / TUBE_CHUNK)
    best: Coverage | None = None
    desc = f"coverage of the start ({raw.offsets.shape[0]} vehicles, {len(order)} candidate blends)"
    with tqdm(total=len(order) * n_chunks, disable=not progress, delay=PROGRESS_DELAY, desc=desc, unit="tube") as bar:
        for i, (tb, th) in enumerate(order):
            try:
                fleet = shaped_start(mission, offsets, initial, tb, turn_time=th, current=current, frame=frame)
            except AuvHinfError as exc:
                return Coverage(
                    False, start, raw, base.bounds, base.margins, base.thrust, None, None, f"no shaped start: {exc}"
                )
            bar.update((i * n_chunks) - bar.n)  # a retry with finer cells ticks more than once per chunk
            cov = check_run(
                cert,
                params,
                envelope,
                gains,
                fleet,
                initial,
                actuators=actuators,
                start=start,
                lazy_thrust=True,
                on_tube=lambda: bar.update(1),
            )
            if cov.covered:
                bar.update(bar.total - bar.n)  # the search is over
                return cov
            if best is None or _score(cov) > _score(best):
                best = cov
    assert best is not None
    if best.thrust is None and best.margins is not None:  # skipped while searching: computed as check_run would
        cells = _fleet_margins(envelope, best.reference, best.bounds, lambda: None)[1]
        best = replace(best, thrust=_fleet_thrust(params, envelope, gains, best.reference, best.bounds, cells))
    return replace(
        best,
        reason="not covered: no candidate blend time covers this start; the best one: "
        + best.reason.removeprefix("not covered: "),
    )


def _score(cov: Coverage) -> float:
    """Smallest envelope margin of a candidate (-inf when it has none)."""
    return -math.inf if cov.margins is None else cov.margins.min


__all__ = [
    "BLEND_TIMES",
    "TUBE_CHUNK",
    "TURN_TIMES",
    "Coverage",
    "StartMode",
    "check_run",
    "cover_start",
    "initial_errors",
]
