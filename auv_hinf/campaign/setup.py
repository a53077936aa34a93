"""The worker set-up of a campaign: what every chunk needs, and how the runs are chunked.

:func:`prepare` designs and certifies the configuration once; the :class:`CampaignSetup` it
returns is small and picklable, so Dask workers receive it once
(:mod:`auv_hinf.campaign.runner`) and :mod:`auv_hinf.campaign.runs` draws every run from it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from auv_hinf._typing import FloatArray
from auv_hinf.campaign.composed_start import ComposedStart, composed_start
from auv_hinf.campaign.starts import RobustStart, declared_rows, robust_start
from auv_hinf.certificate.design_point import design_point
from auv_hinf.certificate.parts.closed_loop import closed_loop_for
from auv_hinf.certificate.parts.separation import separation_refusal
from auv_hinf.closed_loop.nominal import ClosedLoopCertificate
from auv_hinf.composed.loops import Errors
from auv_hinf.config.settings import FormationConfig
from auv_hinf.exceptions import DesignError, ParameterError
from auv_hinf.implementation.model import Implementation
from auv_hinf.law.formation_law import VehicleLaw
from auv_hinf.mission.fleet import FleetReference
from auv_hinf.models.envelope import Envelope
from auv_hinf.models.vehicle import VehicleParams

#: Plant coefficients that the ``[uncertainty]`` box may scale, in sampling order.
COEFFICIENTS = ("m11", "m22", "m33", "d11_lin", "d11_quad", "d22_lin", "d22_quad", "d33_lin", "d33_quad")
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
    certificate : ClosedLoopCertificate or None
        Its decay Lyapunov matrices give the measured decay rate; ``None`` with integral
        action (the robust certificate, ``robust``, covers it; the rate is then measured on
        the identity).
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
        False when the certified thrust exceeds the configured limit (saturation voids it), or
        when the bounds runs are checked against do not keep ``[formation] min_separation``.
    robust : RobustStart or None
        Start sets and bounds of the robust certificate, when a box or a current is declared
        and it covers them (:mod:`auv_hinf.campaign.starts`); then every run is checked
        against it.
    robust_reason : str or None
        Why a declared box or current is not checked (the robust certificate does not cover),
        or, with a sampled implementation, why no run is covered (the composed certificate does
        not cover the deployed loop).
    composed : ComposedStart or None
        With a sampled implementation: the start set and bounds of the composed certificate when
        it covers the deployed loop (:mod:`auv_hinf.campaign.composed_start`); then every run is
        checked against it. The continuous certificates do not cover sampled runs.
    implementation : Implementation
        How the controller runs in every run; a sampled one draws its noise and delays per run
        from :func:`implementation_seed`.
    noise_pattern : str
        The ``[simulation] noise_pattern`` setting: run ``i``'s pattern is
        :func:`~auv_hinf.certificate.run_plan.run_pattern` of it.
    separation : str or None
        Why the bounds of the composed or robust certificate the runs are checked against do not
        keep ``[formation] min_separation`` (``None``: they do, or the nominal one is checked).
    """

    name: str
    law: VehicleLaw
    nominal: VehicleParams
    reference: FleetReference
    start: FloatArray
    radii: FloatArray
    p2: FloatArray
    q: FloatArray
    certificate: ClosedLoopCertificate | None
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
    noise_pattern: str = "uniform"
    composed: ComposedStart | None = None
    separation: str | None = None

    @property
    def n(self) -> int:
        """Number of vehicles."""
        return int(self.start.shape[0])

    @property
    def checked(self) -> ComposedStart | RobustStart | None:
        """The certificate every run is drawn from and checked against, when not the nominal one.

        The composed one for a sampled implementation, else the robust one when a box or a
        current is declared and it covers them; ``None``: the nominal certificate's region.
        """
        return self.composed if self.composed is not None else self.robust

    @property
    def covers_sampled_runs(self) -> bool:
        """A continuous law, or a sampled one that the composed certificate covers."""
        return self.implementation.continuous or self.composed is not None


def prepare(
    cfg: FormationConfig, *, seed: int = 0, horizon: float | None = None
) -> tuple[CampaignSetup, ClosedLoopCertificate | None]:
    """Gains, closed-loop certificate and the worker set-up of a campaign on ``cfg``.

    Parameters
    ----------
    cfg : FormationConfig
        The configuration.
    seed : int
        Campaign seed (>= 0).
    horizon : float, optional
        Length of every run (s, > 0); default ``cfg.simulation.horizon``.

    Raises
    ------
    DesignError
        If the design has no gain or no certificate to sample the starts from (the nominal
        one, or with integral action the robust one).
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
    cert = None if gains.integral else closed_loop_for(point)  # integral action: the robust certificate only
    ref = point.fleet()
    m0 = ref.motion(0.0)
    start = np.stack([m0.p, m0.v, np.column_stack([m0.psi, m0.r])], axis=1)
    box = box_multipliers(cfg)
    composed: ComposedStart | None = None
    if cfg.implementation.sampled:  # the sampled runs: the composed certificate or none
        reference = None if cert is None else Errors(*(float(x) for x in cert.region.region.as_array()))
        composed, why = composed_start(point, declared_rows(box), reference)
        rob = None
    else:
        rob, why = robust_start(point, box, cert)
    # the thrust the actuators must admit for a certificate to apply (the composed one fits them by construction)
    if composed is not None:
        thrust = (float(composed.thrust[0]), float(composed.thrust[1]), float(composed.thrust[2]))
    elif cert is not None:
        thrust = cert.thrust.as_tuple()
    elif rob is not None:
        thrust = (float(rob.thrust[0]), float(rob.thrust[1]), float(rob.thrust[2]))
    else:
        raise DesignError(f"integral action is certified by the robust certificate, which does not cover this: {why}")
    limit = cfg.force_limits  # none for a rudder: the fully actuated law's forces are not deliverable there
    fits = cfg.actuators is None or (limit is not None and limit.admits(thrust))
    # the bounds a run is checked against must keep [formation] min_separation, as certify requires
    checked = composed if composed is not None else rob
    separation = None if checked is None else separation_refusal(point, float(checked.bounds[0]))
    reg = None if cert is None else cert.region
    law = VehicleLaw(params=cfg.vehicle, gains=gains, actuators=cfg.actuators)
    setup = CampaignSetup(
        name=cfg.name,
        law=law,
        nominal=cfg.vehicle,
        reference=ref,
        start=start,
        radii=np.zeros(4) if reg is None else reg.region.as_array(),
        p2=np.eye(2) if reg is None or reg.p2 is None else reg.p2,
        q=np.eye(2) if reg is None or reg.q is None else reg.q,
        certificate=cert,
        box=box,
        current_speed=float(cfg.disturbance.current_speed or 0.0),
        envelope=cfg.envelope,
        horizon=hor,
        samples=max(2, round(hor / SAMPLE_INTERVAL) + 1),  # a horizon shorter than one interval: its two ends
        seed=int(seed),
        certificate_applies=bool(fits) and separation is None,
        robust=rob,
        robust_reason=why,
        implementation=cfg.implementation,
        noise_pattern=cfg.simulation.noise_pattern,
        composed=composed,
        separation=separation,
    )
    return setup, cert


def box_multipliers(cfg: FormationConfig) -> FloatArray:
    """``[lo, hi]`` multipliers of the :data:`COEFFICIENTS` (shape (9, 2)): the declared ``[uncertainty]`` box.

    Parameters
    ----------
    cfg : FormationConfig
        The configuration; coefficients it does not declare are ``[1, 1]``, and so are those whose
        value is zero (a multiple of zero is zero: their ranges would only repeat every vertex).
    """
    box = np.ones((len(COEFFICIENTS), 2))
    for k, (lo, hi) in cfg.uncertainty.box:
        if float(getattr(cfg.vehicle, k)) != 0.0:
            box[COEFFICIENTS.index(k)] = (lo, hi)
    return box


def scaled_plant(nominal: VehicleParams, mult: FloatArray, name: str = "sampled") -> VehicleParams:
    """``nominal`` with its :data:`COEFFICIENTS` times ``mult`` (``nominal`` itself when all are 1).

    Parameters
    ----------
    nominal : VehicleParams
        The configured vehicle.
    mult : ndarray, shape (9,)
        Multipliers in :data:`COEFFICIENTS` order.
    name : str
        Name of the scaled plant.
    """
    if np.all(mult == 1.0):
        return nominal
    scaled = {k: getattr(nominal, k) * float(m) for k, m in zip(COEFFICIENTS, mult, strict=True)}
    return VehicleParams(**scaled, name=name)


def nominal_certificate(setup: CampaignSetup) -> ClosedLoopCertificate:
    """The nominal certificate of a campaign whose runs it decides (without a robust one there always is one).

    Parameters
    ----------
    setup : CampaignSetup
        The campaign.
    """
    if setup.certificate is None:  # pragma: no cover - prepare refuses integral action without the robust one
        raise DesignError("this campaign has no nominal certificate (integral action): the robust one decides")
    return setup.certificate


def default_chunk(setup: CampaignSetup) -> int:
    """Scenarios per batch: :data:`MAX_CHUNK`, fewer when the working set would exceed :data:`CHUNK_BYTES`.

    Parameters
    ----------
    setup : CampaignSetup
        The campaign (its fleet size).
    """
    per_run = WORKING_ARRAYS * setup.n * 6 * 8
    return max(1, min(MAX_CHUNK, CHUNK_BYTES // per_run))


def implementation_summary(impl: Implementation, pattern: str, drawn: bool) -> dict[str, Any]:
    """The ``implementation`` object of a campaign's ``summary.json``: the declared law as it runs.

    Parameters
    ----------
    impl : Implementation
        The declared sample time (s), delay (s) and noise bounds.
    pattern : str
        The ``[simulation] noise_pattern``.
    drawn : bool
        Each run draws its own delays or measurement errors (then seeded per run).
    """
    return {
        **impl.to_dict(),
        "description": impl.describe(),
        "draws": "per run, seeded by runs.parquet's implementation_seed (from the campaign seed and the run index)"
        if drawn
        else None,
        "noise_pattern": pattern,
    }


def chunks(runs: int, chunk: int) -> list[tuple[int, int]]:
    """``[lo, hi)`` index ranges of ``runs`` runs in chunks of ``chunk``.

    Parameters
    ----------
    runs : int
        Number of runs.
    chunk : int
        Runs per chunk (the last may be shorter).
    """
    return [(lo, min(runs, lo + chunk)) for lo in range(0, runs, chunk)]


__all__ = [
    "CHUNK_BYTES",
    "COEFFICIENTS",
    "MAX_CHUNK",
    "SAMPLE_INTERVAL",
    "WORKING_ARRAYS",
    "CampaignSetup",
    "box_multipliers",
    "chunks",
    "default_chunk",
    "implementation_summary",
    "nominal_certificate",
    "prepare",
    "scaled_plant",
]
