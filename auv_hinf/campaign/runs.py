"""Campaign runs: the reproducible sampling of one run, and one chunk.

See :mod:`auv_hinf.campaign.runner` for the sampling rules. Every function here is a pure function
of a :class:`~auv_hinf.campaign.setup.CampaignSetup` and run indices, so a chunk computes the
same rows on any executor.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from auv_hinf._typing import FloatArray
from auv_hinf.campaign.setup import COEFFICIENTS, CampaignSetup, nominal_certificate, scaled_plant
from auv_hinf.campaign.starts import sample_plant_and_current
from auv_hinf.certificate.run_plan import run_pattern
from auv_hinf.closed_loop.coverage import initial_errors
from auv_hinf.implementation.sampled_loop import integrate_sampled
from auv_hinf.models.vehicle import VehicleParams
from auv_hinf.numerics.integrators import ATOL, RTOL
from auv_hinf.numerics.quadratic_forms import start_bounds
from auv_hinf.simulation.engine import first_exits, integrate_batch
from auv_hinf.simulation.metrics import ErrorSink, RunMetrics
from auv_hinf.simulation.scenario import Scenario, ScenarioBatch

#: Error kinds, in the order of :func:`~auv_hinf.numerics.quadratic_forms.start_bounds` (m, m/s, rad, rad/s).
ERROR_KINDS = ("position", "velocity", "heading", "yaw_rate")
#: Table columns of the peak commanded force per channel, ``(tau_x, tau_y, tau_psi)`` (N, N, N m).
FORCE_COLUMNS = ("max_force_x", "max_force_y", "max_moment")
#: Second spawn-key word of a run's implementation draws (its inputs use ``(index,)`` alone).
IMPLEMENTATION_STREAM = 1
#: A measured error counts as inside its certified bound ``b`` if it is ``<= b (1 + tol) + tol``
#: with ``tol`` = this factor times the integrator's tolerance: the trajectory is known to
#: about rtol/atol = 1e-8, so a larger excess is a real violation, not integration noise.
BOUND_SLACK = 100.0


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
        Plant multipliers of :data:`~auv_hinf.campaign.setup.COEFFICIENTS`.
    current : ndarray, shape (2,)
        Inertial current (m/s).
    """

    errors: tuple[FloatArray, FloatArray, FloatArray, FloatArray]
    multipliers: FloatArray
    current: FloatArray


def sample_run(setup: CampaignSetup, index: int) -> RunInputs:
    """Inputs of run ``index``, from ``SeedSequence(setup.seed, spawn_key=(index,))`` alone.

    Parameters
    ----------
    setup : CampaignSetup
        The campaign (seed, fleet, box, current, start radii or robust sets).
    index : int
        Run index within the campaign.
    """
    rng = np.random.default_rng(np.random.SeedSequence(setup.seed, spawn_key=(index,)))
    rob = setup.checked
    corner = None if rob is None else rob.vertex_index(index)
    declared = () if rob is None else rob.declared
    mult, current = sample_plant_and_current(rng, setup.box, declared, setup.current_speed, corner)
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

    Parameters
    ----------
    setup : CampaignSetup
        The campaign (its mission's motion at ``t = 0``).
    inputs : RunInputs
        The run's sampled start errors and current.
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
    return scaled_plant(setup.nominal, mult)


def implementation_seed(seed: int, index: int) -> int:
    """Seed of the noise and delay draws of run ``index`` (:mod:`auv_hinf.implementation.draws`).

    From ``SeedSequence(seed, spawn_key=(index, IMPLEMENTATION_STREAM))``, a stream apart from the
    run's sampled inputs (:func:`sample_run`): it depends on neither the chunking nor the executor.

    Parameters
    ----------
    seed : int
        The campaign seed.
    index : int
        Run index within the campaign.
    """
    state = np.random.SeedSequence(seed, spawn_key=(index, IMPLEMENTATION_STREAM)).generate_state(2, np.uint32)
    return int(state[0]) << 32 | int(state[1])


def run_scenario(setup: CampaignSetup, index: int, inputs: RunInputs) -> Scenario:
    """The scenario of run ``index`` with its sampled ``inputs`` (see :func:`sample_run`).

    Parameters
    ----------
    setup : CampaignSetup
        The campaign.
    index : int
        Run index within the campaign (names the scenario and seeds its implementation draws).
    inputs : RunInputs
        The run's sampled inputs.
    """
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
        noise_pattern=run_pattern(setup.noise_pattern, index),
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

    Parameters
    ----------
    setup : CampaignSetup
        The campaign.
    lo, hi : int
        First run index and one past the last.
    progress : callable, optional
        Called with the fraction of the chunk's samples produced so far (0 to 1), about once
        per percent.
    """
    inputs = [sample_run(setup, i) for i in range(lo, hi)]
    batch = ScenarioBatch(tuple(run_scenario(setup, i, x) for i, x in zip(range(lo, hi), inputs)))
    cert = setup.certificate  # None with integral action: the rate is then measured on the identity
    sink = ErrorSink(
        setup.reference,
        batch.scenarios[0].times,
        batch.current,
        setup.n,
        np.eye(2) if cert is None else cert.position.matrix,
        np.eye(2) if cert is None else cert.heading.matrix,
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
    control samples (:class:`~auv_hinf.implementation.sampled_loop.SampledSolution`). A run stopped
    as diverged counts as leaving the envelope when it diverged (if it had not left before).
    """
    sol = integrate_sampled(batch, sink=sink)
    met = replace(sink.result(), commanded_peak=sol.commanded_peak, saturated_fraction=sol.saturated_fraction)
    ends = np.fmin(sol.event_time, sol.diverged)
    exits = [None if math.isnan(e) else float(e) for e in ends]
    table = _rows(setup, lo, inputs, batch, met, exits, sol.n_steps)
    table["implementation_seed"] = [s.seed for s in batch.scenarios]
    table["noise_pattern"] = [s.noise_pattern for s in batch.scenarios]
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
    checked = setup.checked
    if checked is not None:
        bound = np.broadcast_to(checked.bounds, measured.shape)
        applies = np.full(len(inputs), setup.certificate_applies, dtype=bool)
    else:  # the nominal certificate's region; it is about the continuous law only
        bound = start_bounds(setup.p2, setup.q, *e0)  # (S, N, 4)
        applies = nominal & setup.certificate_applies & setup.covers_sampled_runs
    stayed = np.array([e is None for e in exits])
    starts = (np.linalg.norm(e0[0], axis=-1), np.linalg.norm(e0[1], axis=-1), np.abs(e0[2]), np.abs(e0[3]))
    tol = BOUND_SLACK * max(RTOL, ATOL)
    # every ratio is to the bound as checked, widened by the integrator's slack: a bound at round-off
    # (a channel the mission never loads, ~1e-19) against a trajectory known to ~1e-8 is no ratio of 1e10
    checked_bound = bound * (1.0 + tol) + tol
    ratio = measured / checked_bound
    tail = met.tail_position / checked_bound[..., 0]
    inside = np.all(measured <= checked_bound, axis=(1, 2)) & stayed
    thrust = checked.thrust if checked is not None else np.array(nominal_certificate(setup).thrust.as_tuple())
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


__all__ = [
    "BOUND_SLACK",
    "ERROR_KINDS",
    "FORCE_COLUMNS",
    "IMPLEMENTATION_STREAM",
    "RunInputs",
    "implementation_seed",
    "initial_state",
    "run_chunk",
    "run_scenario",
    "sample_run",
]
