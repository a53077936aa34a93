"""From a configuration to a certified run: gains, closed-loop certificate, start, scenario.

:func:`design_gains` computes the Theorem 1 gains without the cross-checks (the
certificate runs those); :func:`closed_loop_for` certifies the full error loop along the
configured mission; :func:`plan_run` chooses the reference of one run (shaped or raw start,
:mod:`auv_hinf.coverage`) and builds the :class:`~auv_hinf.simulation.Scenario`;
:func:`run_report` puts the measured and the certified numbers side by side.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from ._typing import FloatArray
from .closed_loop import ClosedLoopCertificate, closed_loop_certificate
from .config import FormationConfig
from .control_law import VehicleLaw, heading_gains
from .coverage import Coverage, StartMode, cover_start
from .design import design_alpha
from .envelope import envelope_lambda
from .exceptions import AuvHinfError, DesignError
from .paths import MissionReference
from .postprocess import positions_from_jacobi
from .presets import spread_start
from .reference import FleetReference, reference_from_dict
from .results import SimulationResult
from .run_metrics import DECAY_MEASURE_DROP, decay_rates, lyapunov_values

if TYPE_CHECKING:
    from .robust_summary import RobustRunCheck
from .sigma import vehicle_sigma
from .simulation import Scenario
from .tubes import mission_tube

#: A heading range counts as the full circle when its width is 2 pi up to this relative
#: round-off (the default ``(-pi, pi)`` has width 2 pi exactly).
FULL_CIRCLE_RTOL = 1e-12


@dataclass(frozen=True)
class Gains:
    """Gains of one design.

    Attributes
    ----------
    lam, sigma, gamma : float
        Envelope lambda (1/s), certified vehicle-coordinate sigma (1/s) and the H-infinity
        bound used (s).
    alpha : float
        Velocity gain (1/s).
    k1 : float
        Position gain (1/s^2).
    k_psi : tuple of float
        Heading gains ``(k1psi, k2psi)`` (1/s^2, 1/s).
    """

    lam: float
    sigma: float
    gamma: float
    alpha: float
    k1: float
    k_psi: tuple[float, float]


def design_gains(cfg: FormationConfig) -> Gains:
    """Gains of ``cfg``: Theorem 1's on its envelope (no cross-checks), or the robust design's.

    With ``cfg.robust`` the gain ``alpha``, ``k1`` and the heading gains come from
    :func:`~auv_hinf.robust_summary.robust_design_for` (``lam``, ``sigma`` and ``gamma`` stay
    the nominal envelope's).

    Raises
    ------
    DesignError
        If the configured method gives no gain (e.g. gamma below the Theorem 1 bound).
    """
    lam = cfg.lam if cfg.lam is not None else envelope_lambda(cfg.vehicle, cfg.envelope)
    sigma = vehicle_sigma(cfg.vehicle, cfg.envelope, lam, cfg.n).upper
    gamma = cfg.gamma if cfg.gamma is not None else 1.0 / sigma
    if cfg.robust:
        from .robust_summary import robust_design_for

        rg = robust_design_for(cfg).gains
        return Gains(lam, sigma, gamma, rg.alpha, rg.k1, rg.k_psi)
    alpha = float(design_alpha(lam, gamma, cfg.method).alpha)
    if not math.isfinite(alpha):
        raise DesignError(f"no finite gain for method {cfg.method!r} at lambda={lam:g}, gamma={gamma:g}")
    return Gains(lam, sigma, gamma, alpha, cfg.k1, heading_gains(cfg.vehicle, tuple(cfg.heading_poles)))  # type: ignore[arg-type]


def mission_reference(cfg: FormationConfig) -> MissionReference:
    """The configured mission (centre path)."""
    return reference_from_dict(cfg.reference.kind, **cfg.reference.kwargs())


def formation_offsets(cfg: FormationConfig) -> FloatArray:
    """Vehicle offsets from the formation centre, shape ``(N, 2)`` (m), in O(N)."""
    rho = np.asarray(cfg.shape, dtype=float).reshape(cfg.n - 1, 2)
    return positions_from_jacobi(np.vstack([rho, np.zeros((1, 2))]), cfg.jacobi)


def initial_states(cfg: FormationConfig) -> FloatArray:
    """The configured initial states ``(N, 6)``, or the spread start of :func:`~auv_hinf.presets.spread_start`."""
    if cfg.simulation.initial is not None:
        return np.asarray(cfg.simulation.initial, dtype=float)
    return np.asarray(spread_start(tuple(map(tuple, cfg.shape)), cfg.transform), dtype=float)


def closed_loop_for(cfg: FormationConfig, gains: Gains) -> ClosedLoopCertificate:
    """Closed-loop certificate of ``cfg`` along its mission (raises when there is none).

    Raises
    ------
    DesignError
        If the small-gain condition fails or the mission leaves the envelope even at zero
        error.
    """
    width = cfg.envelope.psi[1] - cfg.envelope.psi[0]
    if width < 2.0 * math.pi * (1.0 - FULL_CIRCLE_RTOL):
        raise DesignError(
            f"envelope.psi = {list(cfg.envelope.psi)} rad is narrower than the full circle: the closed-loop "
            "certificate bounds surge, sway and yaw rate, not the heading itself, so it cannot promise a heading range"
        )
    tube = mission_tube(mission_reference(cfg))
    return closed_loop_certificate(
        gains.lam, gains.alpha, gains.k1, gains.sigma, cfg.vehicle, cfg.envelope, gains.k_psi, tube
    )


def coverage_for(
    cfg: FormationConfig, gains: Gains, cert: ClosedLoopCertificate, initial: FloatArray, start: StartMode
) -> Coverage:
    """Coverage of the run of ``cfg`` from ``initial`` in ``start`` mode (nominal plant, no current)."""
    return cover_start(
        cert,
        cfg.vehicle,
        cfg.envelope,
        (gains.alpha, gains.k1),
        gains.k_psi,
        mission_reference(cfg),
        formation_offsets(cfg),
        initial,
        start=start,
        blend_time=cfg.simulation.blend_time,
        thrust_limit=cfg.simulation.thrust_limit,
        current=cfg.simulation.current,
    )


@dataclass(frozen=True)
class RunPlan:
    """A run ready to simulate, with what the certificate says about it.

    Attributes
    ----------
    gains : Gains
    certificate : ClosedLoopCertificate or None
        ``None`` when the design has no closed-loop certificate (see ``notes``).
    coverage : Coverage or None
        The certificate's verdict on this run.
    covered : bool
        The certificate covers this run: certified design, covered start, nominal plant and
        no current.
    scenario : Scenario
    notes : tuple of str
        One line per reason the run is not covered.
    start : {"shaped", "paper"}
        The start mode of the run.
    robust : RobustRunCheck or None
        The robust certificate's verdict when the configuration declares a box or a current.
    """

    gains: Gains
    certificate: ClosedLoopCertificate | None
    coverage: Coverage | None
    covered: bool
    scenario: Scenario
    notes: tuple[str, ...]
    start: str = "shaped"
    robust: RobustRunCheck | None = None


def plan_run(
    cfg: FormationConfig, *, start: StartMode | None = None, horizon: float | None = None, samples: int = 3001
) -> RunPlan:
    """Gains, certificate and scenario of one configured run.

    Parameters
    ----------
    cfg : FormationConfig
        The configuration (its ``simulation`` table gives the start, current and plant).
    start : {"shaped", "paper"}, optional
        Overrides ``cfg.simulation.start``.
    horizon : float, optional
        Overrides ``cfg.simulation.horizon`` (s).
    samples : int
        Output samples.
    """
    sim = cfg.simulation
    mode: StartMode = start or sim.start
    gains = design_gains(cfg)
    initial = initial_states(cfg)
    notes: list[str] = []
    cert: ClosedLoopCertificate | None = None
    cov: Coverage | None = None
    try:
        cert = closed_loop_for(cfg, gains)
        cov = coverage_for(cfg, gains, cert, initial, mode)
        if not cov.covered:
            notes.append(cov.reason)
    except AuvHinfError as exc:
        notes.append(f"design not certified: {exc}")
    plant = sim.plant_params(cfg.vehicle)
    if plant != cfg.vehicle:
        notes.append("the plant differs from the controller's model; the nominal certificate assumes it is known")
    if any(c != 0.0 for c in sim.current):
        notes.append("a current is present; the nominal certificate assumes none")
    reference = cov.reference if cov is not None else FleetReference(mission_reference(cfg), formation_offsets(cfg))
    law = VehicleLaw(
        params=cfg.vehicle, alpha=gains.alpha, k1=gains.k1, k_psi=gains.k_psi, thrust_limit=sim.thrust_limit
    )
    scn = Scenario(
        law=law,
        reference=reference,
        plant=plant,
        initial=initial,
        horizon=float(horizon if horizon is not None else sim.horizon),
        current=sim.current,
        envelope=cfg.envelope,
        samples=samples,
        name=cfg.name,
        jacobi=cfg.jacobi,
    )
    nominal = cov is not None and cov.covered and not notes
    rob = None
    if cfg.uncertainty.box or cfg.disturbance.current_speed:
        from .robust_summary import check_robust_run

        rob = check_robust_run(cfg, reference, initial)
    return RunPlan(gains, cert, cov, nominal or (rob is not None and rob.covered), scn, tuple(notes), mode, rob)


def measured_decay_rate(result: SimulationResult, cert: ClosedLoopCertificate) -> float | None:
    """Average decay rate (1/s) of the slowest vehicle's certified Lyapunov norm.

    ``V_i = x_i^T (P2 kron I2) x_i + z_i^T Q z_i`` with the decay matrices of ``cert``;
    ``sqrt(V_i)`` must decay at least at ``cert.rate``. The rate is
    ``ln(sqrt(V_i(0)/V_i(t*)))/t*`` with ``t*`` the first sample where ``V_i`` has fallen by
    :data:`~auv_hinf.run_metrics.DECAY_MEASURE_DROP` (or the end), minimised over the vehicles
    whose initial norm exceeds :data:`~auv_hinf.run_metrics.DECAY_MEASURE_FLOOR`; ``None`` when
    no vehicle starts with an error.
    """
    v = lyapunov_values(result.tracking, cert.position.matrix, cert.heading.matrix)  # (T, N)
    below = v <= DECAY_MEASURE_DROP * v[0]
    k = np.where(below.any(axis=0), below.argmax(axis=0), v.shape[0] - 1)  # first drop, else the end
    cols = np.arange(v.shape[1])
    tk = np.where(k == 0, 0.0, result.t[k])
    rate = float(decay_rates(v[0], v[k, cols], tk))
    return None if math.isnan(rate) else rate


def run_report(plan: RunPlan, result: SimulationResult) -> dict[str, Any]:
    """The simulation summary plus the certificate's verdict and bounds next to the measured ones."""
    out = result.summary()
    tr = result.tracking
    measured = {
        "position_error": float(np.linalg.norm(tr.e, axis=-1).max()),
        "velocity_error": float(np.linalg.norm(tr.e_dot, axis=-1).max()),
        "heading_error": float(np.abs(tr.e_psi).max()),
        "yaw_rate_error": float(np.abs(tr.e_psi_dot).max()),
    }
    cov = plan.coverage
    certified = None
    if cov is not None:
        b = cov.bounds
        certified = {
            "position_error": b.position,
            "velocity_error": b.velocity,
            "heading_error": b.heading,
            "yaw_rate_error": b.yaw_rate,
        }
    cert = plan.certificate
    out.update(
        {
            "start": plan.start,
            "blend_time": None if cov is None else cov.blend_time,
            "turn_time": None if cov is None else cov.turn_time,
            "certificate_covers_run": plan.covered,
            "coverage_reason": "; ".join(plan.notes) if plan.notes else (cov.reason if cov is not None else None),
            "measured_decay_rate": None if cert is None else measured_decay_rate(result, cert),
            "certified_decay_rate": None if cert is None else cert.rate,
            "measured_errors": measured,
            "certified_errors": certified,
            "certified_thrust": None if cov is None or cov.thrust is None else cov.thrust.to_dict(),
            "robust_covers_run": None if plan.robust is None else plan.robust.covered,
            "robust_bounds": None if plan.robust is None else plan.robust.bounds,
            "robust_reason": None if plan.robust is None else plan.robust.reason,
            "alpha": plan.gains.alpha,
            "k1": plan.gains.k1,
            "k_psi": list(plan.gains.k_psi),
        }
    )
    return out


def with_start(cfg: FormationConfig, initial: FloatArray) -> FormationConfig:
    """Copy of ``cfg`` whose simulation starts from ``initial`` ``(N, 6)``."""
    return replace(cfg, simulation=replace(cfg.simulation, initial=tuple(map(tuple, np.asarray(initial).tolist()))))
