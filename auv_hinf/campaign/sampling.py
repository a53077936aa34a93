"""Campaign runs: the worker set-up, the reproducible sampling of one run, and one chunk.

See :mod:`auv_hinf.campaign.runner` for the sampling rules. Every function here is a pure function
of a :class:`CampaignSetup` and run indices, so a chunk computes the same rows on any
executor.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from auv_hinf._typing import FloatArray
from auv_hinf.campaign.starts import RobustStart, robust_start, vertex_current
from auv_hinf.certification.closed_loop import ClosedLoopCertificate
from auv_hinf.certification.coverage import initial_errors
from auv_hinf.certification.region import start_bounds
from auv_hinf.config.formation import FormationConfig
from auv_hinf.exceptions import ParameterError
from auv_hinf.models.envelope import Envelope
from auv_hinf.models.implementation import Implementation
from auv_hinf.models.reference import FleetReference
from auv_hinf.models.vehicle import VehicleParams
from auv_hinf.simulation.engine import first_exits, integrate_batch
from auv_hinf.simulation.integrators import ATOL, RTOL
from auv_hinf.simulation.law import VehicleLaw
from auv_hinf.simulation.metrics import ErrorSink, RunMetrics
from auv_hinf.simulation.sampled import integrate_sampled
from auv_hinf.simulation.scenario import Scenario, ScenarioBatch
from auv_hinf.workflow.design_point import design_point
from auv_hinf.workflow.nominal import closed_loop_for

#: Plant coefficients that the ``[uncertainty]`` box may scale, in sampling order.
COEFFICIENTS = ("m11", "m22", "m33", "d11_lin", "d11_quad", "d22_lin", "d22_quad", "d33_lin", "d33_quad")
#: Error kinds, in the order of :func:`~auv_hinf.certification.region.start_bounds` (m, m/s, rad, rad/s).
ERROR_KINDS = ("position", "velocity", "heading", "yaw_rate")
#: Table columns of the peak commanded force per channel, ``(tau_x, tau_y, tau_psi)`` (N, N, N m).
FORCE_COLUMNS = ("max_force_x", "max_force_y", "max_moment")
#: Output sample interval (s): the measured sup of the errors is taken on these samples.
SAMPLE_INTERVAL = 0.1
#: Default chunk: at most this many scenarios per batch. The per-step Python overhead of the
#: batched integrator is amortised over the chunk; measured on the paper triangle (one core,
#: 100 s runs): 1024 runs 40k, 2048 runs 48k, 4096 runs 56k vehicle-seconds per second, and
#: 8192 no faster than 4096 (50 s runs: 45.9k against 45.7k): beyond it the numpy work
#: dominates and larger chunks only coarsen the progress bar ...
MAX_CHUNK = 4096
#: ... and at most this many bytes of working set per chunk. The samples are not stored (the
#: metrics are accumulated as they are produced, :class:`~auv_hinf.simulation.metrics.ErrorSink`), so
#: the working set is the integrator's stages and the right-hand side's temporaries: measured
#: peak about 49 arrays of the batch state ``(S, 6 N)``, budgeted as :data:`WORKING_ARRAYS`.
CHUNK_BYTES = 256 * 2**20
#: Arrays of the batch state's size held at the peak of a chunk (measured 49, with margin).
WORKING_ARRAYS = 64
#: Second spawn-key word of a run's implementation draws (its inputs use ``(index,)`` alone).
IMPLEMENTATION_STREAM = 1
#: A measured error counts as inside its certified bound ``b`` if it is ``<= b (1 + tol) + tol``
#: with ``tol`` = this factor times the integrator's tolerance: the trajectory is known to
#: about rtol/atol = 1e-8, so a larger excess is a real violation, not integration noise.
BOUND_SLACK = 100.0


@dataclass(frozen=True)
class CampaignSetup:
    """Everything a worker needs to run chunks of a campaign (picklable, small).

    Attributes
    ----------
    name : str
    law : VehicleLaw
    nominal : VehicleParams
        Nominal plant (the controller's model).
    reference : FleetReference
        Raw mission reference, shared by every run.
    start : ndarray, shape (N, 4, 2)
        Desired position (m), velocity (m/s), and ``(psi, r)`` (rad, rad/s) at ``t = 0``.
    radii : ndarray, shape (4,)
        Certified start-region radii (m, m/s, rad, rad/s).
    p2, q : ndarray, shape (2, 2)
        Lyapunov matrices of the region (identity when the loop's radii are zero).
    certificate : ClosedLoopCertificate
        Its decay Lyapunov matrices give the measured decay rate.
    box : ndarray, shape (9, 2)
        Multiplier ranges of :data:`COEFFICIENTS` (``[1, 1]`` when undeclared).
    current_speed : float
        Bound of the current (m/s).
    envelope : Envelope
    horizon : float
        s.
    samples : int
    seed : int
    certificate_applies : bool
        False when the certified thrust exceeds the configured limit (saturation voids it).
    robust : RobustStart or None
        Start sets and bounds of the robust certificate, when a box or a current is declared
        and it covers them (:mod:`auv_hinf.campaign.starts`); then every run is checked
        against it.
    robust_reason : str or None
        Why a declared box or current is not checked (the robust certificate does not cover).
    implementation : Implementation
        How the controller runs in every run; a sampled one draws its noise and delays per run
        from :func:`implementation_seed`.
    """

    name: str
    law: VehicleLaw
    nominal: VehicleParams
    reference: FleetReference
    start: FloatArray
    radii: FloatArray
    p2: FloatArray
    q: FloatArray
    certificate: ClosedLoopCertificate
    box: FloatArray
    current_speed: float
    envelope: Envelope
    horizon: float
    samples: int
    seed: int
    certificate_applies: bool
    robust: RobustStart | None = None
    robust_reason: str | None = None
    implementation: Implementation = field(default_factory=Implementation)

    @property
    def n(self) -> int:
        """Number of vehicles."""
        return int(self.start.shape[0])


def _uniform_disc_radius(rng: np.random.Generator, radius: float, size: int) -> FloatArray:
    """``size`` planar vectors, magnitude uniform on ``[0, radius)``, direction uniform."""
    mag = radius * rng.random(size)
    ang = 2.0 * math.pi * rng.random(size)
    return np.stack([mag * np.cos(ang), mag * np.sin(ang)], axis=-1)


@dataclass(frozen=True)
class RunInputs:
    """Sampled inputs of one run.

    Attributes
    ----------
    errors : tuple of ndarray
        Start errors ``e (N, 2)`` m, ``e' (N, 2)`` m/s, ``e_psi (N,)`` rad, ``e_psi' (N,)`` rad/s.
    multipliers : ndarray, shape (9,)
        Plant multipliers of :data:`COEFFICIENTS`.
    current : ndarray, shape (2,)
        Inertial current (m/s).
    """

    errors: tuple[FloatArray, FloatArray, FloatArray, FloatArray]
    multipliers: FloatArray
    current: FloatArray


def sample_run(setup: CampaignSetup, index: int) -> RunInputs:
    """Inputs of run ``index``, from ``SeedSequence(setup.seed, spawn_key=(index,))`` alone."""
    rng = np.random.default_rng(np.random.SeedSequence(setup.seed, spawn_key=(index,)))
    rob = setup.robust
    corner = None if rob is None else rob.vertex_index(index)
    if rob is not None and corner is not None:
        mult, current = rob.vertex(setup.box, corner), vertex_current(rng, setup.current_speed)
    else:
        lo, hi = setup.box[:, 0], setup.box[:, 1]
        mult = lo + (hi - lo) * rng.random(lo.size)
        c_mag = setup.current_speed * math.sqrt(rng.random())  # uniform in the disc
        current = vertex_current(rng, c_mag)
    if rob is not None:
        return RunInputs(rob.sample_errors(rng, setup.n, current), mult, current)
    n, r = setup.n, setup.radii
    e = _uniform_disc_radius(rng, float(r[0]), n)
    de = _uniform_disc_radius(rng, float(r[1]), n)
    epsi = float(r[2]) * rng.uniform(-1.0, 1.0, n)
    depsi = float(r[3]) * rng.uniform(-1.0, 1.0, n)
    return RunInputs((e, de, epsi, depsi), mult, current)


def initial_state(setup: CampaignSetup, inputs: RunInputs) -> FloatArray:
    """``[x, y, psi, u, v, r]`` per vehicle: the mission's motion at ``t = 0`` plus the errors.

    The velocity error is in ground velocity: the body velocity is ``R(psi)^T (v_d + e' - c)``.
    """
    e, de, epsi, depsi = inputs.errors
    p, v, hr = setup.start[:, 0], setup.start[:, 1], setup.start[:, 2]
    psi = hr[:, 0] + epsi
    vel = v + de - inputs.current
    c, s = np.cos(psi), np.sin(psi)
    return np.column_stack(
        [p + e, psi, c * vel[:, 0] + s * vel[:, 1], -s * vel[:, 0] + c * vel[:, 1], hr[:, 1] + depsi]
    )


def _plant(setup: CampaignSetup, mult: FloatArray) -> VehicleParams:
    if np.all(mult == 1.0):
        return setup.nominal
    base = setup.nominal
    return VehicleParams(**{k: getattr(base, k) * float(m) for k, m in zip(COEFFICIENTS, mult)}, name="sampled")


def implementation_seed(seed: int, index: int) -> int:
    """Seed of the noise and delay draws of run ``index`` (:mod:`auv_hinf.simulation.draws`).

    From ``SeedSequence(seed, spawn_key=(index, IMPLEMENTATION_STREAM))``, a stream apart from the
    run's sampled inputs (:func:`sample_run`): it depends on neither the chunking nor the executor.
    """
    state = np.random.SeedSequence(seed, spawn_key=(index, IMPLEMENTATION_STREAM)).generate_state(2, np.uint32)
    return int(state[0]) << 32 | int(state[1])


def run_scenario(setup: CampaignSetup, index: int, inputs: RunInputs) -> Scenario:
    """The scenario of run ``index`` with its sampled ``inputs`` (see :func:`sample_run`)."""
    return Scenario(
        law=setup.law,
        reference=setup.reference,
        plant=_plant(setup, inputs.multipliers),
        initial=initial_state(setup, inputs),
        horizon=setup.horizon,
        current=(float(inputs.current[0]), float(inputs.current[1])),
        envelope=setup.envelope,
        samples=setup.samples,
        name=f"{setup.name}[{index}]",
        implementation=setup.implementation,
        seed=implementation_seed(setup.seed, index),
    )


def run_chunk(setup: CampaignSetup, lo: int, hi: int, progress: Callable[[float], None] | None = None) -> pd.DataFrame:
    """Sample, integrate (one batch) and measure runs ``lo .. hi - 1``: one row per run.

    Columns: ``run``, ``seed``; inputs ``<coef>_mult`` (nine plant multipliers), ``current_x``,
    ``current_y`` (m/s), ``nominal`` (plant nominal and no current), ``start_<kind>_error``
    (largest start error over the vehicles); metrics ``stayed_in_envelope``,
    ``first_exit_time`` (s, NaN if none), ``max_<kind>_error`` (sup over samples and
    vehicles), ``final_position_error`` (m), ``tail_position_error`` (m, sup over the second
    half of the horizon) and its ``ratio_tail_position_error`` to the certified bound,
    ``measured_decay_rate`` (1/s, NaN if none),
    ``bound_<kind>_error`` (largest per-start certified bound), ``ratio_<kind>_error``
    (largest measured / certified over the vehicles), ``inside_bounds`` (NA when no
    certificate applies: see :mod:`auv_hinf.campaign.report`), :data:`FORCE_COLUMNS` (peak
    commanded force before saturation over samples and vehicles, N, N, N m),
    ``within_certified_force`` (every channel's peak within the thrust bound of the certificate
    that applies, NA where none does), ``saturated_fraction`` (fraction of the samples at which
    some vehicle saturates) and ``n_steps``. ``<kind>`` is one of :data:`ERROR_KINDS` (m, m/s, rad, rad/s).

    The samples are not stored: :class:`~auv_hinf.simulation.metrics.ErrorSink` folds each one into
    the metrics as the integrator produces it (the same numbers as post-processing stored
    samples, to a few units in the last place; ``tests/simulation/test_run_metrics.py``).
    ``progress``, if given, is called with the fraction of the chunk's samples produced so far
    (0 to 1), about once per percent.
    """
    inputs = [sample_run(setup, i) for i in range(lo, hi)]
    batch = ScenarioBatch(tuple(run_scenario(setup, i, x) for i, x in zip(range(lo, hi), inputs)))
    cert = setup.certificate
    sink = ErrorSink(
        setup.reference,
        batch.scenarios[0].times,
        batch.current,
        setup.n,
        cert.position.matrix,
        cert.heading.matrix,
        progress=progress,
        law=setup.law,
    )
    if setup.implementation.continuous:
        sol = integrate_batch(batch, sink=sink)
        return _rows(setup, lo, inputs, batch, sink.result(), first_exits(sol, hi - lo), sol.n_steps)
    return _sampled_rows(setup, lo, inputs, batch, sink)


def _sampled_rows(
    setup: CampaignSetup, lo: int, inputs: list[RunInputs], batch: ScenarioBatch, sink: ErrorSink
) -> pd.DataFrame:
    """:func:`run_chunk` under a sampled implementation: the forces are the held commands.

    The sink folds the states in; the peak command and the saturated fraction are taken at the
    control samples (:class:`~auv_hinf.simulation.sampled_loop.SampledSolution`). A run stopped
    as diverged counts as leaving the envelope when it diverged (if it had not left before).
    """
    sol = integrate_sampled(batch, sink=sink)
    met = replace(sink.result(), commanded_peak=sol.commanded_peak, saturated_fraction=sol.saturated_fraction)
    ends = np.fmin(sol.event_time, sol.diverged)
    exits = [None if math.isnan(e) else float(e) for e in ends]
    table = _rows(setup, lo, inputs, batch, met, exits, sol.n_steps)
    table["implementation_seed"] = [s.seed for s in batch.scenarios]
    table["diverged_at"] = sol.diverged
    return table


def _rows(
    setup: CampaignSetup,
    lo: int,
    inputs: list[RunInputs],
    batch: ScenarioBatch,
    met: RunMetrics,
    exits: list[float | None],
    n_steps: NDArray[np.int_],
) -> pd.DataFrame:
    """The table of :func:`run_chunk`, computed for all runs of the chunk at once."""
    e0 = initial_errors(setup.reference, batch.initial, batch.current[:, None, :])
    measured = met.max_errors  # (S, N, 4)
    mult = np.array([x.multipliers for x in inputs])
    nominal = np.all(mult == 1.0, axis=1) & ~np.any(batch.current != 0.0, axis=1)
    if setup.robust is not None:
        bound = np.broadcast_to(setup.robust.bounds, measured.shape)
        applies = np.ones(len(inputs), dtype=bool)
    else:
        bound = start_bounds(setup.p2, setup.q, *e0)  # (S, N, 4)
        applies = nominal & setup.certificate_applies
    stayed = np.array([e is None for e in exits])
    starts = (np.linalg.norm(e0[0], axis=-1), np.linalg.norm(e0[1], axis=-1), np.abs(e0[2]), np.abs(e0[3]))
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(bound > 0, measured / bound, np.where(measured > 0, math.inf, 0.0))
        tail = np.where(bound[..., 0] > 0, met.tail_position / bound[..., 0], math.inf)
    tol = BOUND_SLACK * max(RTOL, ATOL)
    inside = np.all(measured <= bound * (1.0 + tol) + tol, axis=(1, 2)) & stayed
    thrust = np.array(setup.certificate.thrust.as_tuple()) if setup.robust is None else setup.robust.thrust
    peak = met.commanded_peak  # (S, 3)
    within = np.all(peak <= thrust * (1.0 + tol) + tol, axis=1)
    cols: dict[str, Any] = {"run": np.arange(lo, lo + len(inputs)), "seed": setup.seed}
    cols.update({f"{k}_mult": mult[:, j] for j, k in enumerate(COEFFICIENTS)})
    cols.update({"current_x": batch.current[:, 0], "current_y": batch.current[:, 1], "nominal": nominal})
    cols.update({f"start_{k}_error": x.max(axis=1) for k, x in zip(ERROR_KINDS, starts)})
    cols["stayed_in_envelope"] = stayed
    cols["first_exit_time"] = np.array([math.nan if e is None else e for e in exits])
    cols.update({f"max_{k}_error": measured[..., j].max(axis=1) for j, k in enumerate(ERROR_KINDS)})
    cols["final_position_error"] = met.final_position.max(axis=1)
    cols["tail_position_error"] = met.tail_position.max(axis=1)
    cols["measured_decay_rate"] = met.decay_rate
    cols.update({f"bound_{k}_error": bound[..., j].max(axis=1) for j, k in enumerate(ERROR_KINDS)})
    cols.update({f"ratio_{k}_error": ratio[..., j].max(axis=1) for j, k in enumerate(ERROR_KINDS)})
    cols["ratio_tail_position_error"] = tail.max(axis=1)
    cols["inside_bounds"] = [bool(x) if a else pd.NA for x, a in zip(inside, applies)]
    cols.update({k: peak[:, j] for j, k in enumerate(FORCE_COLUMNS)})
    cols["within_certified_force"] = [bool(x) if a else pd.NA for x, a in zip(within, applies)]
    cols["saturated_fraction"] = met.saturated_fraction
    cols["n_steps"] = n_steps.astype(np.int64)
    return pd.DataFrame(cols)


def prepare(
    cfg: FormationConfig, *, seed: int = 0, horizon: float | None = None
) -> tuple[CampaignSetup, ClosedLoopCertificate]:
    """Gains, closed-loop certificate and the worker set-up of a campaign on ``cfg``.

    Raises
    ------
    DesignError
        If the design has no gain or no closed-loop certificate (no start region to sample).
    ParameterError
        For a negative seed or a non-positive horizon.
    """
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ParameterError(f"seed must be an integer >= 0, got {seed!r}")
    hor = float(cfg.simulation.horizon if horizon is None else horizon)
    if not (math.isfinite(hor) and hor > 0):
        raise ParameterError(f"horizon must be > 0 s, got {horizon!r}")
    point = design_point(cfg)
    gains = point.require_gains()
    cert = closed_loop_for(point)
    reg = cert.region
    ref = point.fleet()
    m0 = ref.motion(0.0)
    start = np.stack([m0.p, m0.v, np.column_stack([m0.psi, m0.r])], axis=1)
    box = np.ones((len(COEFFICIENTS), 2))
    for k, (lo, hi) in cfg.uncertainty.box:
        box[COEFFICIENTS.index(k)] = (lo, hi)
    rob, why = robust_start(point, box, cert)
    limit = cfg.actuators
    t = cert.thrust
    applies = limit is None or limit.admits(t.as_tuple())
    law = VehicleLaw(params=cfg.vehicle, gains=gains, actuators=limit)
    setup = CampaignSetup(
        name=cfg.name,
        law=law,
        nominal=cfg.vehicle,
        reference=ref,
        start=start,
        radii=reg.region.as_array(),
        p2=np.eye(2) if reg.p2 is None else reg.p2,
        q=np.eye(2) if reg.q is None else reg.q,
        certificate=cert,
        box=box,
        current_speed=float(cfg.disturbance.current_speed or 0.0),
        envelope=cfg.envelope,
        horizon=hor,
        samples=round(hor / SAMPLE_INTERVAL) + 1,
        seed=int(seed),
        certificate_applies=bool(applies),
        robust=rob,
        robust_reason=why,
        implementation=cfg.implementation,
    )
    return setup, cert


def default_chunk(setup: CampaignSetup) -> int:
    """Scenarios per batch: :data:`MAX_CHUNK`, fewer when the working set would exceed :data:`CHUNK_BYTES`."""
    per_run = WORKING_ARRAYS * setup.n * 6 * 8
    return max(1, min(MAX_CHUNK, CHUNK_BYTES // per_run))


def chunks(runs: int, chunk: int) -> list[tuple[int, int]]:
    """``[lo, hi)`` index ranges of ``runs`` runs in chunks of ``chunk``."""
    return [(lo, min(runs, lo + chunk)) for lo in range(0, runs, chunk)]


__all__ = [
    "BOUND_SLACK",
    "CHUNK_BYTES",
    "COEFFICIENTS",
    "ERROR_KINDS",
    "FORCE_COLUMNS",
    "IMPLEMENTATION_STREAM",
    "MAX_CHUNK",
    "SAMPLE_INTERVAL",
    "WORKING_ARRAYS",
    "CampaignSetup",
    "RunInputs",
    "chunks",
    "default_chunk",
    "implementation_seed",
    "initial_state",
    "prepare",
    "run_chunk",
    "run_scenario",
    "sample_run",
]
