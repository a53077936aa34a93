"""From a configuration to a certified run: design point, closed-loop certificate, start, scenario.

:func:`plan_run` takes the design point (:func:`~auv_hinf.certificate.design_point.design_point`,
computed once), certifies the full error loop along the configured mission
(:func:`~auv_hinf.certificate.parts.closed_loop.closed_loop_for`), chooses the reference of one run (shaped
or raw start, :mod:`auv_hinf.closed_loop.coverage`) and builds the
:class:`~auv_hinf.simulation.scenario.Scenario`; :func:`run_report` puts the measured and the
certified numbers side by side. A ``[guidance]`` configuration runs the line-of-sight cascade
instead (:func:`guidance_run`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any, cast, get_args

import numpy as np

from auv_hinf._typing import NOISE_PATTERNS, FloatArray, NoisePattern
from auv_hinf.actuation.limits import CHANNEL_UNITS, LIMIT_UNITS, RudderActuation
from auv_hinf.certificate.design_point import DesignPoint, design_point, initial_states, raw_fleet, require_config
from auv_hinf.certificate.part import RunCheck, RunContext, run_covered
from auv_hinf.certificate.parts.implementation import ImplementationSummary
from auv_hinf.certificate.parts.robust import RobustRunCheck
from auv_hinf.certificate.registry import part_supersedes, parts, superseded_by
from auv_hinf.closed_loop.coverage import Coverage, StartMode
from auv_hinf.closed_loop.nominal import ClosedLoopCertificate
from auv_hinf.config.settings import FormationConfig
from auv_hinf.exceptions import ConfigError, ParameterError, require_count, require_finite, require_positive
from auv_hinf.guidance.simulation import GuidanceRun, Navigation, cascade_period, simulate_guidance
from auv_hinf.guidance.six_dof import simulate_guidance_6dof
from auv_hinf.implementation.sampled_loop import control_period
from auv_hinf.law.formation_law import VehicleLaw
from auv_hinf.law.gains import Gains
from auv_hinf.mission.margins import ERROR_UNITS
from auv_hinf.models.envelope import Envelope
from auv_hinf.models.vehicle import VehicleParams
from auv_hinf.numerics.integrators import NUMERICAL_FLOOR
from auv_hinf.simulation.metrics import DECAY_MEASURE_DROP, decay_rates, lyapunov_values
from auv_hinf.simulation.results import SimulationResult
from auv_hinf.simulation.scenario import Scenario


@dataclass(frozen=True)
class RunPlan:
    """A run ready to simulate, with what the certificate says about it.

    Attributes
    ----------
    design : DesignPoint
        The design of the run's configuration: its ``gains`` are the gains the run uses.
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
    implementation : ImplementationSummary or None
        The implementation certificate when the configuration declares a sampled, delayed or
        noisy controller (``None`` for the continuous law): the run is covered only if it covers.
    checks : tuple of RunCheck
        Every part's verdict on the run, in registry order (the fields above are read off them).
    """

    design: DesignPoint
    certificate: ClosedLoopCertificate | None
    coverage: Coverage | None
    covered: bool
    scenario: Scenario
    notes: tuple[str, ...]
    start: str = "shaped"
    robust: RobustRunCheck | None = None
    implementation: ImplementationSummary | None = None
    checks: tuple[RunCheck, ...] = ()

    @property
    def judged(self) -> frozenset[str]:
        """The parts whose say on this run is another's (:func:`judged_parts`)."""
        return judged_parts(self.checks)

    def uncertified_gains(self) -> str | None:
        """Why no certificate covers the gains of this run's configuration, or ``None``.

        A run may still be uncovered with certified gains (e.g. a start outside the certified
        set); this is about the gains: no nominal closed-loop certificate (small gain, envelope,
        actuators), or a declared box and current the robust certificate does not cover. A part
        whose certificate covers the gains (the composed certificate of the loop as deployed)
        waives the refusals of the parts it supersedes.
        """
        certified = {c.part for c in self.checks if c.certifies_gains}
        waived = {name for part in certified for name in part_supersedes(part)}
        refusals = (c.refuses_gains for c in self.checks if c.refuses_gains is not None and c.part not in waived)
        return next(refusals, None)


def judged_parts(checks: tuple[RunCheck, ...]) -> frozenset[str]:
    """The parts whose say on a run is another's: superseded by a part that certifies the gains as they run.

    That part judges the run; the idealised parts it supersedes are evaluated only because it does
    not cover this run (a plant outside the box, a start outside its set), and their notes would
    repeat its reason or mislead (an implementation certificate of the model as the plant).

    Parameters
    ----------
    checks : tuple of RunCheck
        The run's checks.
    """
    return frozenset(name for c in checks if c.certifies_gains for name in part_supersedes(c.part))


#: Stored output samples of a run of few vehicles (one every 0.1 s over the paper's 300 s).
RUN_SAMPLES = 3001
#: Vehicle-samples a run stores at most (3001 samples of 1000 vehicles, about 1 GB with the
#: forces and the post-processing): larger fleets store fewer samples, so memory stays bounded
#: at any N. Sampling does not decide envelope exits: the integrator locates them between samples.
SAMPLE_BUDGET = 3_001_000
#: Fewest samples a run stores, however large the fleet.
MIN_RUN_SAMPLES = 101


def run_samples(n: int) -> int:
    """Stored output samples of a run of ``n`` vehicles: :data:`RUN_SAMPLES`, fewer above the budget.

    Parameters
    ----------
    n : int
        Number of vehicles.
    """
    return int(max(MIN_RUN_SAMPLES, min(RUN_SAMPLES, SAMPLE_BUDGET // max(n, 1))))


def plan_run(
    cfg: FormationConfig,
    *,
    start: StartMode | None = None,
    horizon: float | None = None,
    samples: int | None = None,
    design: DesignPoint | None = None,
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
    samples : int, optional
        Output samples (default :func:`run_samples` of the fleet size).
    design : DesignPoint, optional
        The design point of ``cfg`` when the caller has it (otherwise computed, or taken from
        the cache).

    Raises
    ------
    ConfigError
        If ``cfg`` is not a configuration, steers its fleet by ``[guidance]`` (see
        :func:`guidance_run`), or ``start`` is not a start mode.
    ParameterError
        If ``horizon`` is not a positive number of seconds or ``samples`` not an integer >= 2.
    DesignError
        If the design gives no gains.
    """
    if require_config(cfg).guidance is not None:
        raise ConfigError(
            "plan_run: this fleet is steered by its [guidance] cascade, not the fully actuated formation law: "
            "simulate it with guidance_run(cfg) (auv_hinf.guidance_run), as `auv-hinf simulate` does"
        )
    if start is not None and start not in get_args(StartMode):
        raise ConfigError(f"start must be one of {list(get_args(StartMode))}, got {start!r}")
    if horizon is not None:
        require_positive("horizon (s)", horizon)
    if samples is not None:
        samples = require_count("samples (output samples of the run)", samples, 2)
    if design is not None and not isinstance(design, DesignPoint):
        raise ConfigError(f"design must be the DesignPoint of cfg (design_point(cfg)), got {type(design).__name__}")
    point = design if design is not None else design_point(cfg)
    sim = cfg.simulation
    mode: StartMode = start or sim.start
    gains = point.require_gains()
    initial = initial_states(point)
    span = float(horizon if horizon is not None else sim.horizon)
    checks: dict[str, RunCheck] = {}
    for part in parts():
        if superseded_by(part.name, checks) is not None:
            continue  # a covering certificate of the loop as it runs makes this part's check redundant
        check = part.check_run(RunContext(point, initial, mode, span, dict(checks)))
        if check is not None:
            checks[part.name] = check
    ctx = RunContext(point, initial, mode, span, checks)
    scn = Scenario(
        law=VehicleLaw(params=cfg.vehicle, gains=gains, actuators=cfg.actuators),
        reference=ctx.reference,
        plant=sim.plant_params(cfg.vehicle),
        initial=initial,
        horizon=span,
        current=sim.current,
        envelope=cfg.envelope,
        samples=run_samples(cfg.n) if samples is None else samples,
        name=cfg.name,
        jacobi=cfg.jacobi,
        frame=cfg.frame,
        implementation=cfg.implementation,
        seed=sim.seed,
        noise_pattern=run_pattern(sim.noise_pattern, 0),
    )
    nominal = checks.get("closed_loop")
    cert, cov = (None, None) if nominal is None else nominal.detail
    robust = checks.get("robust")
    impl = checks.get("implementation")
    robust_detail = None if robust is None else robust.detail
    composed = checks.get("composed")
    if robust_detail is None and composed is not None and point.declared:
        # the declared box and current are judged, for this sampled run, by the composed certificate
        robust_detail = RobustRunCheck(
            composed.covers,
            composed.bounds if composed.covers else None,
            "covered by the composed certificate of the deployed loop" if composed.covers else composed.reason,
            composed.detail.covers,
        )
    judged = judged_parts(tuple(checks.values()))
    return RunPlan(
        design=point,
        certificate=cert,
        coverage=cov,
        covered=run_covered(list(checks.values())),
        scenario=scn,
        notes=tuple(n for c in checks.values() if c.part not in judged for n in c.notes),
        start=mode,
        robust=robust_detail,
        implementation=None if impl is None else impl.detail,
        checks=tuple(checks.values()),
    )


def run_pattern(setting: str, index: int) -> NoisePattern:
    """The noise pattern of run ``index`` under the ``[simulation] noise_pattern`` setting.

    ``mixed`` gives run ``i`` the pattern ``NOISE_PATTERNS[i mod 5]`` (a single run: the first,
    ``uniform``); any other setting is every run's pattern.

    Parameters
    ----------
    setting : str
        The configured pattern, or ``mixed``.
    index : int
        The run's index (0 for a single run).
    """
    if setting == "mixed":
        return NOISE_PATTERNS[index % len(NOISE_PATTERNS)]
    return cast(NoisePattern, setting)


def measured_decay_rate(result: SimulationResult, cert: ClosedLoopCertificate) -> float | None:
    """Average decay rate (1/s) of the slowest vehicle's certified Lyapunov norm.

    ``V_i = x_i^T (P2 kron I2) x_i + z_i^T Q z_i`` with the decay matrices of ``cert``;
    ``sqrt(V_i)`` must decay at least at ``cert.rate``. The rate is
    ``ln(sqrt(V_i(0)/V_i(t*)))/t*`` with ``t*`` the first sample where ``V_i`` has fallen by
    :data:`~auv_hinf.simulation.metrics.DECAY_MEASURE_DROP` (or the end), minimised over the vehicles
    whose initial norm exceeds :data:`~auv_hinf.simulation.metrics.DECAY_MEASURE_FLOOR`; ``None`` when
    no vehicle starts with an error.

    Parameters
    ----------
    result : SimulationResult
        The run (its tracking errors and sample times).
    cert : ClosedLoopCertificate
        The certificate whose decay matrices define ``V_i``.
    """
    v = lyapunov_values(result.tracking, cert.position.matrix, cert.heading.matrix)  # (T, N)
    below = v <= DECAY_MEASURE_DROP * v[0]
    k = np.where(below.any(axis=0), below.argmax(axis=0), v.shape[0] - 1)  # first drop, else the end
    cols = np.arange(v.shape[1])
    tk = np.where(k == 0, 0.0, result.t[k])
    rate = float(decay_rates(v[0], v[k, cols], tk))
    return None if math.isnan(rate) else rate


def measured_errors(result: SimulationResult, start: int = 0) -> dict[str, float]:
    """Sup over the samples from index ``start`` and the vehicles of each tracking error (m, m/s, rad, rad/s).

    Parameters
    ----------
    result : SimulationResult
        The run.
    start : int
        First sample index taken.
    """
    tr = result.tracking
    return {
        "position_error": float(np.linalg.norm(tr.e[start:], axis=-1).max()),
        "velocity_error": float(np.linalg.norm(tr.e_dot[start:], axis=-1).max()),
        "heading_error": float(np.abs(tr.e_psi[start:]).max()),
        "yaw_rate_error": float(np.abs(tr.e_psi_dot[start:]).max()),
    }


def certified_errors(plan: RunPlan) -> dict[str, float] | None:
    """The per-vehicle error bounds (m, m/s, rad, rad/s) the run's measured errors are compared with.

    The one place :func:`run_report` reads them from: today the nominal coverage's bounds, never
    below :data:`~auv_hinf.numerics.integrators.NUMERICAL_FLOOR` (the exact solution obeys the
    bounds; the simulated one to the integrator's accuracy). For a sampled, delayed or noisy
    implementation they are the composed certificate's bounds when it covers the run, else the
    implementation certificate's, over the whole run. ``None`` when no certificate bounds the run.

    Parameters
    ----------
    plan : RunPlan
        The planned run (its coverage and implementation summary).
    """
    return certified_errors_of(plan)[0]


def certified_errors_of(plan: RunPlan) -> tuple[dict[str, float] | None, str | None]:
    """:func:`certified_errors` and the part whose bounds they are (``None`` with no bounds).

    The part is ``"composed"``, ``"implementation"``, ``"closed_loop"`` or ``"robust"``: the
    robust certificate's bounds when it covers a run that the nominal closed-loop certificate does
    not (a plant of the box other than the model, or a current).

    Parameters
    ----------
    plan : RunPlan
        The planned run.
    """
    composed = next((c for c in plan.checks if c.part == "composed" and c.covers and c.bounds is not None), None)
    if composed is not None and composed.bounds is not None:  # the deployed loop's own certificate
        return {f"{k}_error": v for k, v in composed.bounds.items()}, "composed"
    nominal = next((c for c in plan.checks if c.part == "closed_loop" and c.role == "certificate"), None)
    robust = plan.robust
    if plan.implementation is not None:
        c = plan.implementation.certificate
        if not plan.implementation.covers or c is None or c.bounds is None:
            return None, None
        b, source = c.bounds.to_dict(), "implementation"
    elif (
        nominal is not None
        and not (nominal.applies and nominal.covers)
        and robust is not None
        and robust.covered
        and robust.bounds is not None
    ):
        b, source = robust.bounds, "robust"
    elif plan.coverage is None:
        return None, None
    else:
        b, source = plan.coverage.bounds.to_dict(), "closed_loop"
    keys = ("position", "velocity", "heading", "yaw_rate")
    return {f"{k}_error": max(b[k], NUMERICAL_FLOOR) for k in keys}, source


def force_floor(vehicle: VehicleParams, gains: Gains, envelope: Envelope) -> dict[str, float]:
    """The numerical floor of a certified force compared with a simulated one (N, N, N m).

    The certificate bounds the force the law commands on the exact trajectory; the integrator
    returns the trajectory to :data:`~auv_hinf.numerics.integrators.NUMERICAL_FLOOR` in every error
    coordinate, so the commanded force it reports is off by at most the law's sensitivity to those
    errors: the feedback ``m_jj (k1 + alpha)`` (``m33 (k1_psi + k2_psi)`` in yaw) and the drift
    compensation's slope at the envelope's fastest motion, ``d_lin + 2 d_quad |x|_max``. A run from
    exactly on its slots is certified the force at the reference alone; its simulation commands
    about 3e-5 N more in surge and 6e-5 N of sway (a review's BlueROV2 line), below this floor
    (about 0.01 N at the robust gains).

    Parameters
    ----------
    vehicle : VehicleParams
        The controller's model.
    gains : Gains
        The law's gains.
    envelope : Envelope
        The declared envelope (its largest ``|u|``, ``|v|``, ``|r|``).
    """
    u = max(abs(x) for x in envelope.u)
    v = max(abs(x) for x in envelope.v)
    r = max(abs(x) for x in envelope.r)
    k1p, k2p = gains.k_psi
    pos = gains.k1 + gains.alpha
    return {
        "force_x": NUMERICAL_FLOOR * (vehicle.m11 * pos + vehicle.d11_lin + 2.0 * vehicle.d11_quad * u),
        "force_y": NUMERICAL_FLOOR * (vehicle.m22 * pos + vehicle.d22_lin + 2.0 * vehicle.d22_quad * v),
        "moment": NUMERICAL_FLOOR * (vehicle.m33 * (k1p + k2p) + vehicle.d33_lin + 2.0 * vehicle.d33_quad * r),
    }


def certified_thrust_of(plan: RunPlan) -> dict[str, float] | None:
    """The certified commanded-force bound of the run (N, N, N m), or ``None`` when none bounds it.

    The bound of the certificate that covers the run: the deployed loop's composed certificate
    (its whole-run force bound; with a sampled law no other certificate bounds the force), else the
    nominal closed-loop certificate's over its start region when it covers the run (the controller's
    model in still water), else the robust certificate's over its invariant set when it covers the
    run (a plant of the box, a current within the bound); each channel with its numerical floor
    (:func:`force_floor`), as the certified errors carry theirs, so that the simulated run's
    ``commanded_peak`` is compared with what a computed trajectory can reach.

    Parameters
    ----------
    plan : RunPlan
        The planned run.
    """
    covering = {c.part: c for c in plan.checks if c.covers}
    cov, cfg = plan.coverage, plan.design.config
    composed, robust = covering.get("composed"), covering.get("robust")
    if composed is not None and composed.thrust is not None:
        bound = dict(composed.thrust.to_dict())
    elif cfg.implementation.sampled:
        return None  # the continuous law's force bounds do not bound the held, delayed, noisy law's
    elif "closed_loop" in covering and cov is not None and cov.thrust is not None:
        bound = dict(cov.thrust.to_dict())
    elif robust is not None and robust.thrust is not None:
        bound = dict(robust.thrust.to_dict())
    else:
        return None  # the nominal bound holds for the controller's model in still water only
    floor = force_floor(cfg.vehicle, plan.design.require_gains(), cfg.envelope)
    return {k: float(b) + floor[k] for k, b in bound.items()}


def implementation_report(scn: Scenario) -> dict[str, Any]:
    """What implementation a run simulated: the declared one, its seed, the law's period (s).

    Parameters
    ----------
    scn : Scenario
        The run's scenario.
    """
    impl = scn.implementation
    return {
        **impl.to_dict(),
        "seed": scn.seed,
        "noise_pattern": scn.noise_pattern,
        "control_period": None if impl.continuous else control_period(impl, scn.horizon),
        "description": impl.describe(),
    }


def run_report(plan: RunPlan, result: SimulationResult) -> dict[str, Any]:
    """The simulation summary plus the certificate's verdict and bounds next to the measured ones.

    Parameters
    ----------
    plan : RunPlan
        The planned run (design, certificate, coverage).
    result : SimulationResult
        Its simulation.
    """
    out = result.summary()
    measured = measured_errors(result)
    cov = plan.coverage
    certified, source = certified_errors_of(plan)
    cert = plan.certificate
    covered_by = [c.part for c in plan.checks if c.role == "certificate" and c.applies and c.covers]
    if plan.covered and cov is not None and cov.covered and "closed_loop" in covered_by:
        why: str | None = cov.reason  # the nominal certificate's own account of what covers the start
    elif plan.covered and covered_by:  # the certificate that covers says so, not another one's refusal
        why = f"covered by the {' and '.join(covered_by)} certificate"
    else:
        why = "; ".join(plan.notes) if plan.notes else (cov.reason if cov is not None else None)
    out.update(
        {
            "start": plan.start,
            "blend_time": None if cov is None else cov.blend_time,
            "turn_time": None if cov is None else cov.turn_time,
            "certificate_covers_run": plan.covered,
            "coverage_reason": why,
            "measured_decay_rate": None if cert is None else measured_decay_rate(result, cert),
            "certified_decay_rate": None if cert is None else cert.rate,
            "measured_errors": measured,
            "measured_tail_errors": measured_errors(result, result.t.size // 2),
            "certified_errors": certified,
            "certified_errors_source": source,
            "covered_by": covered_by if plan.covered else [],
            "numerical_floor": NUMERICAL_FLOOR,
            "certified_thrust": certified_thrust_of(plan),
            "robust_covers_run": None if plan.robust is None else plan.robust.covered,
            "robust_bounds": None if plan.robust is None else plan.robust.bounds,
            "robust_reason": None if plan.robust is None else plan.robust.reason,
            **plan.design.require_gains().to_dict(),
            "gain_source": plan.design.source,
            "implementation": implementation_report(plan.scenario),
        }
    )
    out["null_reasons"] = {k: _NULL_REASONS.get(k, "not applicable to this run") for k, v in out.items() if v is None}
    out["definitions"] = DEFINITIONS
    return out


#: What the fleet-wide numbers of :func:`run_report` are, in words (they are not per vehicle).
DEFINITIONS = {
    "final_shape_error": "fleet-wide Jacobi shape error at the end (m): Frobenius norm over the N-1 Jacobi vectors",
    "rms_shape_error": "root mean square over the samples of the fleet-wide Jacobi shape error (m); it grows with "
    "sqrt(N) for equal per-vehicle errors",
    "final_position_error": "largest |p_i - p_d,i| over the vehicles at the end (m)",
    "measured_errors": "sup over samples and vehicles of each tracking error (m, m/s, rad, rad/s)",
    "measured_tail_errors": "the same sup over the second half of the run (where ultimate bounds apply)",
    "implementation": "how the controller ran: sample time and delay (s), noise bounds, seed of the draws, "
    "the law's period (s; null: continuous)",
    "certified_errors": "per-vehicle bounds of the certificate, never below the numerical floor",
    "certified_errors_source": "the part whose bounds certified_errors are (composed, implementation, closed_loop, "
    "or robust for a run of a plant or current that only the robust certificate covers)",
    "covered_by": "the parts whose certificates cover this run (empty when a condition fails: the thrust, the "
    "separation)",
    "max_force": "largest applied |tau_x| or |tau_y| over samples and vehicles (N)",
    "shape_errors": "error of each Jacobi shape vector against the mission, in the formation's frame (along and "
    "cross track in the path frame, x and y in the inertial one): largest |component| over the vectors at the end "
    "('final') and over the run ('max') (m)",
    "commanded_peak": "largest commanded force per channel before saturation (N, N, N m)",
    "min_separation": "smallest distance between any two vehicles over the samples (m); min_separation_pair is "
    "the pair (0-based) and min_separation_time the time (s)",
    "saved_until": "when Ctrl-C stopped simulate --save: the time of the last sample in the file (s)",
}


#: Units of the numbers of :func:`run_report`, for its text (``auv-hinf simulate`` without ``--json``): a
#: unit for a number, or for every number of a list or table; a table of units by key; a tuple of units by
#: position. A key without a unit holds no number (a name, a verdict, a sentence).
REPORT_UNITS: dict[str, Any] = {
    "n": "vehicles",
    "horizon": "s",
    **dict.fromkeys(
        ("final_shape_error", "final_center_error", "final_position_error", "rms_shape_error", "min_separation"), "m"
    ),
    "max_force": "N",
    "max_moment": "N m",
    **dict.fromkeys(("max_speed", "max_sway", "final_sway"), "m/s"),
    "max_yaw_rate": "rad/s",
    "saturation_fraction": "of the vehicle-samples",
    **dict.fromkeys(("commanded_peak", "certified_thrust"), CHANNEL_UNITS),
    "actuator_limits": LIMIT_UNITS,
    **dict.fromkeys(
        ("first_exit_time", "diverged_at", "blend_time", "turn_time", "saved_until", "min_separation_time"), "s"
    ),
    "min_separation_pair": "of the vehicles (the first is vehicle zero)",
    "shape_errors": {"final": "m", "max": "m"},
    **dict.fromkeys(("measured_decay_rate", "certified_decay_rate"), "1/s"),
    **{
        key: {f"{kind}_error": unit for kind, unit in ERROR_UNITS.items()}
        for key in ("measured_errors", "measured_tail_errors", "certified_errors")
    },
    "robust_bounds": ERROR_UNITS,
    "numerical_floor": "in each error's unit (m, m/s, rad, rad/s)",
    "alpha": "1/s",
    "k1": "1/s^2",
    "k_psi": ("1/s^2", "1/s"),
    "ki": "1/s^3",
}


#: Why a key of :func:`run_report` can be ``null``, in words.
_NULL_REASONS = {
    "first_exit_time": "the run never left the envelope",
    "blend_time": "no blended start: the run starts on the raw mission, or no certificate evaluated it",
    "turn_time": "no blended start: the run starts on the raw mission, or no certificate evaluated it",
    "coverage_reason": "no certificate evaluated the run",
    "measured_decay_rate": "no vehicle starts with an error large enough to measure a decay (or no certificate)",
    "certified_decay_rate": "no closed-loop certificate",
    "certified_errors": "no certificate covers the run's start",
    "certified_errors_source": "no certified_errors",
    "certified_thrust": (
        "no certificate that covers the run bounds its force (a sampled law's: only the composed certificate does)"
    ),
    "robust_covers_run": "no [uncertainty] box or [disturbance] current declared",
    "robust_bounds": "no robust bound for this run (none declared, or not covered)",
    "robust_reason": "no [uncertainty] box or [disturbance] current declared",
    "actuator_limits": "no [actuators] declared: unlimited thrust",
    "diverged_at": "the run did not diverge",
}


def with_start(cfg: FormationConfig, initial: FloatArray) -> FormationConfig:
    """Copy of ``cfg`` whose simulation starts from ``initial`` ``(N, 6)``.

    Parameters
    ----------
    cfg : FormationConfig
        The configuration.
    initial : ndarray, shape (N, 6)
        Initial states ``[x, y, psi, u, v, r]`` (m, m, rad, m/s, m/s, rad/s).
    """
    return replace(cfg, simulation=replace(cfg.simulation, initial=tuple(map(tuple, np.asarray(initial).tolist()))))


__all__ = [
    "DEFINITIONS",
    "MIN_RUN_SAMPLES",
    "REPORT_UNITS",
    "RUN_SAMPLES",
    "SAMPLE_BUDGET",
    "RunPlan",
    "certified_errors",
    "certified_errors_of",
    "guidance_run",
    "implementation_report",
    "judged_parts",
    "measured_decay_rate",
    "measured_errors",
    "plan_run",
    "run_report",
    "run_samples",
    "with_start",
]


def guidance_run(
    cfg: FormationConfig,
    horizon: float | None = None,
    plant: VehicleParams | None = None,
    current: tuple[float, float] | None = None,
    six_dof: bool = False,
    noise: tuple[int, str] | None = None,
) -> GuidanceRun:
    """Simulate a ``[guidance]`` configuration: its fleet under the line-of-sight cascade.

    The plant is ``[simulation] plant`` applied to the vehicle, the current ``[simulation] current``,
    the start ``[simulation] initial`` (default: every vehicle on its slot, heading into the current).
    The cascade runs at ``[implementation] sample_time`` (default: the 10 Hz of
    :data:`~auv_hinf.guidance.simulation.STEP`) on measurements ``[implementation] delay`` old, with
    errors within ``[implementation.noise]`` drawn from ``[simulation] seed`` in its
    ``noise_pattern`` (``mixed``: the first pattern, ``uniform``).

    Parameters
    ----------
    cfg : FormationConfig
        A configuration with ``[guidance]`` and an underactuated ``[actuators]``.
    horizon : float, optional
        Simulated time (s); default ``[simulation] horizon``.
    plant : VehicleParams, optional
        The true vehicle instead of the configured one (a campaign's sample of the box).
    current : tuple of float, optional
        The constant current (m/s, inertial) instead of ``[simulation] current``.
    six_dof : bool
        Run the cascade on the 6-DOF REMUS 100 (:mod:`auv_hinf.guidance.six_dof`) instead of the
        3-DOF model; only for a REMUS 100 fleet, started on its slots, without ``plant``.
    noise : tuple of (int, str), optional
        The seed and pattern of the measurement errors instead of the ``[simulation]`` ones (a
        campaign's run).

    Raises
    ------
    ConfigError
        If ``cfg`` is not a configuration, has no ``[guidance]`` table, or declares a varying
        ``[implementation]`` delay (the cascade is run, and certified, with a fixed one).
    ParameterError
        If ``horizon`` is not a positive number of seconds, ``plant`` not a vehicle, ``current`` not
        two numbers, or ``noise`` not an integer seed >= 0 and a noise pattern.
    """
    require_config(cfg)
    if cfg.guidance is None or not isinstance(cfg.actuators, RudderActuation):
        raise ConfigError("guidance_run: the configuration has no [guidance] table for a propeller-and-rudder vehicle")
    if horizon is not None:
        require_positive("horizon (s)", horizon)
    if plant is not None and not isinstance(plant, VehicleParams):
        raise ParameterError(f"plant must be a VehicleParams (the true vehicle), got {type(plant).__name__}")
    if current is not None:
        if isinstance(current, (str, bytes)) or np.shape(current) != (2,):
            raise ParameterError(f"current must be two numbers (m/s, inertial x and y), got {current!r}")
        current = (require_finite("current x (m/s)", current[0]), require_finite("current y (m/s)", current[1]))
    if noise is not None:
        if not isinstance(noise, (tuple, list)) or len(noise) != 2 or noise[1] not in NOISE_PATTERNS:
            raise ParameterError(f"noise must be (seed, pattern), the pattern one of {NOISE_PATTERNS}, got {noise!r}")
        noise = (require_count("noise seed", noise[0], 0), noise[1])
    impl = cfg.implementation
    if impl.varying_delay:
        raise ConfigError(
            "a [guidance] fleet is simulated with a fixed [implementation] delay in this version: set "
            "[implementation] varying_delay = false"
        )
    step = cascade_period(impl)
    sim = cfg.simulation
    seed, pattern = noise if noise is not None else (sim.seed, sim.noise_pattern)
    navigation = Navigation(impl.delay, impl, seed, NOISE_PATTERNS[0] if pattern == "mixed" else pattern)
    initial = None if sim.initial is None else np.asarray(sim.initial, dtype=float)
    fleet = raw_fleet(cfg)
    if six_dof:
        if not cfg.vehicle.name.startswith("remus100") or plant is not None or initial is not None or sim.plant:
            raise ConfigError(
                "the 6-DOF model is the REMUS 100's (Prestero's coefficients): it runs a fleet of the "
                "remus100 vehicle preset, started on its slots, without [simulation] plant or initial"
            )
        return simulate_guidance_6dof(
            cfg.guidance,
            cfg.vehicle,
            cfg.actuators,
            fleet,
            sim.horizon if horizon is None else horizon,
            sim.current if current is None else current,
            step=step,
            navigation=navigation,
        )
    return simulate_guidance(
        cfg.guidance,
        sim.plant_params(cfg.vehicle) if plant is None else plant,
        cfg.vehicle,
        cfg.actuators,
        fleet,
        sim.horizon if horizon is None else horizon,
        sim.current if current is None else current,
        initial,
        step,
        navigation=navigation,
    )
