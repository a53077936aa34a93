"""The certified law as it runs on vehicles, and what its certificate assumed.

:meth:`RuntimeLaw.from_certificate` takes the law a :class:`~auv_hinf.certificate.assembly.Certificate`
is about (its gains on the configured model, with the configured saturation or thruster allocation)
and the raw mission its bounds refer to. :meth:`RuntimeLaw.step` evaluates it exactly as the sampled
simulation does (:mod:`auv_hinf.implementation.sampled_loop`): on states measured at time ``t``,
against the desired motion at ``t``, with the ground velocity ``R(psi) [u, v]`` of the measured
heading and body velocity (plus a current, when the caller knows one), and returns the saturated
forces that are then held until the next sample. The delay is physical here: ``t`` is the
instant the measurement was taken, so a measurement ``a`` seconds old at the sample instant
``t_k`` is stepped at ``t = t_k - a``, as the simulation steps ``s_k = t_k - d_k``.

:class:`Assumptions` are the conditions under which the certificate holds, read off its verdicts
(:meth:`Assumptions.from_certificate`): the sample time and delay, the envelope, the actuator
limits, the current bound, the noise bounds, and the certified error bounds (the invariant set).
The runtime monitor (:mod:`auv_hinf.deployment.monitor`) checks them at every step.

States are ``(N, 6)`` ``[x, y, psi, u, v, r]`` (m, m, rad, m/s, m/s, rad/s; ``x`` north, ``y`` east,
``psi`` clockwise from north, ``u, v`` body frame); forces ``(N, 3)`` ``[tau_x, tau_y, tau_psi]``
(N, N, N m, body frame); times in s from the start of the run.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from auv_hinf._typing import FloatArray
from auv_hinf.certificate.assembly import Certificate
from auv_hinf.deployment.ardusub import MODE_MANUAL
from auv_hinf.exceptions import DesignError, ParameterError
from auv_hinf.implementation.model import MeasurementNoise
from auv_hinf.law.formation_law import MotionSource, VehicleLaw, VehicleMotionSource, saturate
from auv_hinf.mission.fleet import Motion, wrap_angle
from auv_hinf.mission.margins import ErrorBounds
from auv_hinf.models.envelope import Envelope
from auv_hinf.models.vehicle import ground_velocity

#: Where the invariant set comes from, in the order :meth:`Assumptions.from_certificate` tries them.
INVARIANT_SOURCES = ("composed", "implementation", "robust", "closed_loop")
#: Largest gap between a vehicle's HEARTBEATs (s): ArduSub sends one a second and its own GCS
#: failsafe waits 2.5 s for ours; three missed beats is a lost vehicle.
HEARTBEAT_TIMEOUT = 3.0
#: The four error channels of the invariant set, with their units.
ERROR_CHANNELS = (("position", "m"), ("velocity", "m/s"), ("heading", "rad"), ("yaw_rate", "rad/s"))


def _bounds(data: Mapping[str, Any] | None, keys: tuple[str, str, str, str]) -> ErrorBounds | None:
    """Error bounds from a part's figures (``None`` when the part gives none)."""
    if data is None or any(data.get(k) is None for k in keys):
        return None
    return ErrorBounds(*(float(data[k]) for k in keys))


@dataclass(frozen=True)
class Assumptions:
    """What a certificate assumed of the run, as the runtime monitor checks it.

    Attributes
    ----------
    sample_time : float
        Certified control period (s); 0 for a continuous certificate (not runnable at a fixed rate).
    delay : float
        Certified lumped delay (s): the largest age of the measurement a command is computed from,
        plus the command's own transport.
    varying_delay : bool
        The certificate covers any delay in ``[0, delay]`` (``False``: exactly ``delay``).
    envelope : Envelope
        The operating envelope of the body velocities (m/s, m/s, rad/s).
    force_limits : tuple of float or None
        Actuator limits ``|tau_x|, |tau_y|, |tau_psi|`` (N, N, N m); ``None``: none declared.
    current_bound : float
        Largest current speed the certificate covers (m/s; 0 without a declared current).
    noise : MeasurementNoise
        Bounds of the measurement errors (m, m/s, rad, rad/s).
    error_bounds : ErrorBounds or None
        The certified bounds of every vehicle's errors against the raw mission, the invariant set
        (m, m/s, rad, rad/s); ``None`` when the certificate gives none.
    invariant_source : str or None
        The part ``error_bounds`` come from (one of :data:`INVARIANT_SOURCES`).
    certified : bool
        Every part of the certificate holds.
    heartbeat_timeout : float
        Largest gap between a vehicle's HEARTBEATs (s).
    command_latency : float
        The share of ``delay`` reserved for the command's way to the thrusters (s): MAVLink does
        not acknowledge MANUAL_CONTROL, so it cannot be measured and is budgeted here.
    pilot_gain : float or None
        The ArduSub pilot gain the force mapping assumes (checked against "PilotGain").
    mode : int or None
        The ArduSub custom_mode the force mapping assumes (19, MANUAL).
    """

    sample_time: float
    delay: float
    varying_delay: bool
    envelope: Envelope
    force_limits: tuple[float, float, float] | None
    current_bound: float
    noise: MeasurementNoise
    error_bounds: ErrorBounds | None
    invariant_source: str | None
    certified: bool
    heartbeat_timeout: float = HEARTBEAT_TIMEOUT
    command_latency: float = 0.0
    pilot_gain: float | None = None
    mode: int | None = MODE_MANUAL

    def __post_init__(self) -> None:
        for name in ("sample_time", "delay", "current_bound", "heartbeat_timeout", "command_latency"):
            value = float(getattr(self, name))
            if not (math.isfinite(value) and value >= 0.0):
                raise ParameterError(f"assumption {name} must be a finite number >= 0, got {getattr(self, name)!r}")
            object.__setattr__(self, name, value)
        if self.command_latency > self.delay:
            raise ParameterError(
                f"command_latency ({self.command_latency:g} s) cannot exceed the certified delay ({self.delay:g} s)"
            )
        if self.invariant_source is not None and self.invariant_source not in INVARIANT_SOURCES:
            raise ParameterError(f"invariant_source must be one of {INVARIANT_SOURCES}, got {self.invariant_source!r}")

    @property
    def max_lag(self) -> float:
        """Largest certified age ``sample_time + delay`` (s) of the measurement behind the force held at any time."""
        return self.sample_time + self.delay

    @property
    def measurement_age_bound(self) -> float:
        """Largest age (s) a measurement may have when the law is stepped: ``delay - command_latency``."""
        return self.delay - self.command_latency

    @property
    def timed(self) -> bool:
        """The certificate is about a sampled loop (a sample time is declared): its timing is checked.

        A certificate of the continuous law certifies no loop period, measurement age or staleness,
        so the monitor does not check them (a replayed simulation has sample spacings, not a period).
        """
        return self.sample_time > 0.0

    @property
    def stale_after(self) -> float:
        """A vehicle is stale when no navigation message arrived for one sample time (s)."""
        return self.sample_time

    @classmethod
    def from_certificate(cls, cert: Certificate) -> Assumptions:
        """The assumptions of ``cert`` (a fresh certificate or one read back from its file).

        The invariant set is the composed part's error bounds when it covers the declared
        implementation, else the implementation part's when an implementation is declared, else
        the robust part's ultimate bounds when it applies and holds, else the closed loop's region
        bounds.

        Parameters
        ----------
        cert : Certificate
            The certificate.

        Returns
        -------
        Assumptions
            With ``certified`` as the certificate says and ``pilot_gain`` unset.
        """
        cfg = cert.config
        impl = cfg.implementation

        def figures(name: str) -> Mapping[str, Any] | None:
            v = cert.verdict(name)
            return None if v is None or v.figures is None else v.figures

        plain = ("position", "velocity", "heading", "yaw_rate")
        bounds, source = None, "implementation"
        composed = cert.verdict("composed")
        if not impl.continuous and composed is not None and composed.applies and composed.ok:
            bounds, source = _bounds((figures("composed") or {}).get("error_bounds"), plain), "composed"
        elif not impl.continuous:
            bounds = _bounds((figures("implementation") or {}).get("error_bounds"), plain)
        else:
            rob = cert.verdict("robust")
            if rob is not None and rob.applies and rob.ok:
                bounds, source = _bounds((figures("robust") or {}).get("ultimate_bounds"), plain), "robust"
            if bounds is None:
                region = (figures("closed_loop") or {}).get("region_error_bounds")
                keys = ("position_error", "velocity_error", "heading_error", "yaw_rate_error")
                bounds, source = _bounds(region, keys), "closed_loop"
        limits = None if cfg.force_limits is None else cfg.force_limits.limits()
        current = cfg.disturbance.current_speed
        return cls(
            sample_time=impl.sample_time,
            delay=impl.delay,
            varying_delay=impl.varying_delay,
            envelope=cfg.envelope,
            force_limits=limits,
            current_bound=0.0 if current is None else float(current),
            noise=impl.noise,
            error_bounds=bounds,
            invariant_source=None if bounds is None else source,
            certified=cert.certified,
        )

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe dictionary (stored in a run log's metadata)."""
        return {
            "sample_time": self.sample_time,
            "delay": self.delay,
            "varying_delay": self.varying_delay,
            "envelope": self.envelope.to_dict(),
            "force_limits": None if self.force_limits is None else list(self.force_limits),
            "current_bound": self.current_bound,
            "noise": self.noise.to_dict(),
            "error_bounds": None if self.error_bounds is None else self.error_bounds.to_dict(),
            "invariant_source": self.invariant_source,
            "certified": self.certified,
            "heartbeat_timeout": self.heartbeat_timeout,
            "command_latency": self.command_latency,
            "pilot_gain": self.pilot_gain,
            "mode": self.mode,
        }

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> Assumptions:
        """Inverse of :meth:`to_dict`.

        Parameters
        ----------
        data : Mapping
            A dictionary :meth:`to_dict` wrote.

        Returns
        -------
        Assumptions
            The same assumptions.

        Raises
        ------
        ParameterError
            If a key is missing or a value is invalid.
        """
        try:
            env, b, lim = data["envelope"], data["error_bounds"], data["force_limits"]
            return cls(
                sample_time=float(data["sample_time"]),
                delay=float(data["delay"]),
                varying_delay=bool(data["varying_delay"]),
                envelope=Envelope(
                    u=tuple(env["u"]),
                    v=tuple(env["v"]),
                    r=tuple(env["r"]),
                    psi=tuple(env.get("psi", (-math.pi, math.pi))),
                ),
                force_limits=None if lim is None else (float(lim[0]), float(lim[1]), float(lim[2])),
                current_bound=float(data["current_bound"]),
                noise=MeasurementNoise(**data["noise"]),
                error_bounds=None if b is None else ErrorBounds(**b),
                invariant_source=data["invariant_source"],
                certified=bool(data["certified"]),
                heartbeat_timeout=float(data["heartbeat_timeout"]),
                command_latency=float(data["command_latency"]),
                pilot_gain=None if data["pilot_gain"] is None else float(data["pilot_gain"]),
                mode=None if data["mode"] is None else int(data["mode"]),
            )
        except (KeyError, TypeError, ValueError) as exc:
            raise ParameterError(f"invalid assumptions record: {type(exc).__name__}: {exc}") from None


@dataclass(frozen=True)
class StationReference:
    """Every vehicle held where it is: fixed positions and headings, no motion (the monitor's ``hold``).

    Parameters
    ----------
    positions : ndarray, shape (N, 2)
        Where each vehicle holds (m, inertial).
    headings : ndarray, shape (N,)
        The heading each holds (rad).
    """

    positions: FloatArray
    headings: FloatArray

    def __post_init__(self) -> None:
        p, h = np.asarray(self.positions, dtype=float), np.asarray(self.headings, dtype=float)
        if p.ndim != 2 or p.shape[1] != 2 or h.shape != p.shape[:1] or not np.all(np.isfinite(p)):
            raise ParameterError(f"a station needs finite positions (N, 2) and headings (N,), got {p.shape}, {h.shape}")
        object.__setattr__(self, "positions", p)
        object.__setattr__(self, "headings", h)

    def motion(self, t: float | FloatArray) -> Motion:
        """The held motion: positions and headings, zero rates.

        Parameters
        ----------
        t : float or ndarray
            Time(s) (s; scalar or ``(S,)``).

        Returns
        -------
        Motion
            Shapes ``(N, 2)`` / ``(N,)``, with a leading ``(S,)`` for an array of times.
        """
        lead = np.shape(np.asarray(t, dtype=float))
        n = self.positions.shape[0]
        zero2, zero1 = np.zeros((*lead, n, 2)), np.zeros((*lead, n))
        p = np.broadcast_to(self.positions, (*lead, n, 2)).copy()
        psi = np.broadcast_to(self.headings, (*lead, n)).copy()
        return Motion(p=p, v=zero2, a=zero2.copy(), psi=psi, r=zero1, r_dot=zero1.copy())

    def motion_per_vehicle(self, t: FloatArray) -> Motion:
        """The held motion of vehicle ``i`` at ``t[..., i]``: the same at every time.

        Parameters
        ----------
        t : ndarray, shape (..., N)
            One time per vehicle (s).

        Returns
        -------
        Motion
            Shapes ``(..., N, 2)`` / ``(..., N)``.
        """
        return self.motion(np.asarray(t, dtype=float)[..., 0])


def vehicle_times(t: float | ArrayLike, n: int) -> FloatArray | float:
    """``t`` as a scalar time or one time per vehicle, checked (s).

    Parameters
    ----------
    t : float or array_like
        A time, or ``n`` times.
    n : int
        Number of vehicles.

    Returns
    -------
    float or ndarray
        The scalar, or an array of shape ``(n,)``.

    Raises
    ------
    ParameterError
        If a time is not finite or the shape is neither scalar nor ``(n,)``.
    """
    arr = np.asarray(t, dtype=float)
    if not np.all(np.isfinite(arr)) or arr.shape not in ((), (n,)):
        raise ParameterError(f"times must be finite, one scalar or one per vehicle ({n},), got {np.shape(t)}")
    return float(arr) if arr.ndim == 0 else arr


def motion_at(reference: MotionSource, t: float | FloatArray, n: int) -> Motion:
    """The desired motion of each of ``n`` vehicles at its own time (s), shapes ``(n, 2)`` and ``(n,)``.

    Parameters
    ----------
    reference : MotionSource
        The fleet reference.
    t : float or ndarray
        One time for all, or one per vehicle, shape ``(n,)``.
    n : int
        Number of vehicles.

    Returns
    -------
    Motion
        Vehicle ``i`` at ``t[i]``: with :meth:`~auv_hinf.law.formation_law.VehicleMotionSource.motion_per_vehicle`
        when the reference has it, else the diagonal of ``reference.motion(t)`` (O(N^2), fine for
        the fleets a MAVLink loop drives).
    """
    if np.ndim(t) == 0:
        return reference.motion(float(t))
    tt = np.asarray(t, dtype=float)
    if isinstance(reference, VehicleMotionSource):
        return reference.motion_per_vehicle(tt)
    m, i = reference.motion(tt), np.arange(n)
    return Motion(p=m.p[i, i], v=m.v[i, i], a=m.a[i, i], psi=m.psi[i, i], r=m.r[i, i], r_dot=m.r_dot[i, i])


@dataclass(frozen=True)
class RuntimeLaw:
    """The certified law stepped on measurements (see the module docstring).

    Attributes
    ----------
    law : VehicleLaw
        Gains, controller model and saturation (the configured actuators or thruster allocation).
    reference : MotionSource
        The desired motion (the raw mission of the certificate; a station while holding).
    n : int
        Number of vehicles.
    assumptions : Assumptions
        What the certificate assumed.
    name : str
        ``"certified"``, or ``"hold"`` for :meth:`holding`.
    """

    law: VehicleLaw
    reference: MotionSource
    n: int
    assumptions: Assumptions
    name: str = "certified"

    @classmethod
    def from_certificate(cls, cert: Certificate, reference: MotionSource | None = None) -> RuntimeLaw:
        """The law ``cert`` is about, along its raw mission, with its assumptions.

        Parameters
        ----------
        cert : Certificate
            A certificate with gains (fresh, or read back from its file).
        reference : MotionSource, optional
            Another desired motion (default: the raw mission, which the certified bounds refer to).

        Returns
        -------
        RuntimeLaw
            The runtime law.

        Raises
        ------
        DesignError
            If the certificate has no gains, or gains with integral action (the runtime law keeps
            no integrator: integral action is certified for the continuous law only).
        """
        law = cert.law()
        if law.gains.integral:
            raise DesignError(
                "integral action is certified for the continuous law only; the runtime law keeps no integrator"
            )
        ref = cert.mission_fleet() if reference is None else reference
        return cls(law, ref, cert.config.n, Assumptions.from_certificate(cert))

    @property
    def sample_time(self) -> float:
        """Certified sample time (s)."""
        return self.assumptions.sample_time

    @property
    def delay(self) -> float:
        """Certified delay (s)."""
        return self.assumptions.delay

    def _measured(
        self, states: ArrayLike, ground: ArrayLike | None, current: ArrayLike
    ) -> tuple[FloatArray, FloatArray, tuple[FloatArray, FloatArray]]:
        s = np.asarray(states, dtype=float)
        if s.shape != (self.n, 6) or not np.all(np.isfinite(s)):
            raise ParameterError(f"measured states must be finite with shape ({self.n}, 6), got {s.shape}")
        cs = (np.cos(s[:, 2]), np.sin(s[:, 2]))
        if ground is None:
            p_dot = ground_velocity(s, np.asarray(current, dtype=float), cs)
        else:
            p_dot = np.asarray(ground, dtype=float)
            if p_dot.shape != (self.n, 2) or not np.all(np.isfinite(p_dot)):
                raise ParameterError(f"ground velocities must be finite with shape ({self.n}, 2), got {p_dot.shape}")
        return s, p_dot, cs

    def motion(self, t: float | ArrayLike) -> Motion:
        """The desired motion at ``t`` (s; one time, or one per vehicle), shapes ``(N, 2)`` and ``(N,)``.

        Parameters
        ----------
        t : float or array_like
            The time(s) of the measurements.

        Returns
        -------
        Motion
            Desired position, velocity and acceleration (m, m/s, m/s^2), heading, yaw rate and
            yaw acceleration (rad, rad/s, rad/s^2) of every vehicle.
        """
        return motion_at(self.reference, vehicle_times(t, self.n), self.n)

    def commanded(
        self,
        t: float | ArrayLike,
        states: ArrayLike,
        ground: ArrayLike | None = None,
        current: ArrayLike = (0.0, 0.0),
    ) -> FloatArray:
        """The law's command before saturation, shape ``(N, 3)`` (N, N, N m).

        Parameters
        ----------
        t : float or array_like
            When ``states`` were measured (s): one time, or one per vehicle.
        states : array_like, shape (N, 6)
            Measured ``[x, y, psi, u, v, r]``.
        ground : array_like, shape (N, 2), optional
            Measured ground velocity (m/s, inertial); default ``R(psi) [u, v] + current``.
        current : array_like, shape (2,)
            The current added to ``R(psi) [u, v]`` when ``ground`` is not given (m/s, inertial).

        Returns
        -------
        ndarray
            ``[tau_x, tau_y, tau_psi]`` per vehicle.
        """
        s, p_dot, cs = self._measured(states, ground, current)
        out: FloatArray = self.law.unsaturated(s, p_dot, self.motion(t), cs)
        return out

    def step(
        self,
        t: float | ArrayLike,
        states: ArrayLike,
        ground: ArrayLike | None = None,
        current: ArrayLike = (0.0, 0.0),
    ) -> FloatArray:
        """The forces to hold until the next sample, shape ``(N, 3)`` (N, N, N m): :meth:`commanded`, saturated.

        Parameters
        ----------
        t : float or array_like
            When ``states`` were measured (s): one time, or one per vehicle.
        states : array_like, shape (N, 6)
            Measured ``[x, y, psi, u, v, r]``.
        ground : array_like, shape (N, 2), optional
            Measured ground velocity (m/s, inertial); default ``R(psi) [u, v] + current``.
        current : array_like, shape (2,)
            The current added to ``R(psi) [u, v]`` when ``ground`` is not given (m/s, inertial).

        Returns
        -------
        ndarray
            The delivered forces of the configured actuators (unchanged without any).
        """
        return saturate(
            self.commanded(t, states, ground, current), self.law.actuators, np.asarray(states, dtype=float)[..., 3]
        )[0]

    def errors(
        self, t: float | ArrayLike, states: ArrayLike, ground: ArrayLike | None = None, current: ArrayLike = (0.0, 0.0)
    ) -> FloatArray:
        """The measured errors against the desired motion, shape ``(N, 4)``.

        Parameters
        ----------
        t : float or array_like
            When ``states`` were measured (s): one time, or one per vehicle.
        states : array_like, shape (N, 6)
            Measured ``[x, y, psi, u, v, r]``.
        ground : array_like, shape (N, 2), optional
            Measured ground velocity (m/s, inertial); default ``R(psi) [u, v] + current``.
        current : array_like, shape (2,)
            The current added to ``R(psi) [u, v]`` when ``ground`` is not given (m/s, inertial).

        Returns
        -------
        ndarray
            ``|p - p_d|`` (m), ``|p' - p_d'|`` (m/s), ``|wrap(psi - psi_d)|`` (rad), ``|r - r_d|``
            (rad/s): the channels of :class:`~auv_hinf.mission.margins.ErrorBounds`.
        """
        s, p_dot, _ = self._measured(states, ground, current)
        return error_channels(s, p_dot, self.motion(t))

    def holding(self, states: ArrayLike) -> RuntimeLaw:
        """The same gains holding every vehicle where ``states`` put it (the monitor's ``hold``).

        The certificate does not cover station keeping (its mission moves); ``hold`` is the mildest
        response that still controls the vehicles, and the run is reported as not covered.

        Parameters
        ----------
        states : array_like, shape (N, 6)
            Measured ``[x, y, psi, u, v, r]``: positions and headings to hold.

        Returns
        -------
        RuntimeLaw
            Named ``"hold"``, with the same assumptions.
        """
        s, _, _ = self._measured(states, None, (0.0, 0.0))
        station = StationReference(s[:, 0:2].copy(), s[:, 2].copy())
        return replace(self, reference=station, name="hold")


def error_channels(states: FloatArray, p_dot: FloatArray, motion: Motion) -> FloatArray:
    """``|e|, |e'|, |e_psi|, |e_r|`` of states ``(N, 6)`` with ground velocities ``(N, 2)``, shape ``(N, 4)``.

    Parameters
    ----------
    states : ndarray, shape (N, 6)
        ``[x, y, psi, u, v, r]`` (m, m, rad, m/s, m/s, rad/s).
    p_dot : ndarray, shape (N, 2)
        Ground velocity (m/s, inertial).
    motion : Motion
        Desired motion of the same vehicles.

    Returns
    -------
    ndarray
        Position (m), velocity (m/s), heading (rad) and yaw-rate (rad/s) errors, as magnitudes.
    """
    e = states[:, 0:2] - motion.p
    de = p_dot - motion.v
    return np.column_stack(
        [
            np.hypot(e[:, 0], e[:, 1]),
            np.hypot(de[:, 0], de[:, 1]),
            np.abs(wrap_angle(states[:, 2] - motion.psi)),
            np.abs(states[:, 5] - motion.r),
        ]
    )


__all__ = [
    "ERROR_CHANNELS",
    "HEARTBEAT_TIMEOUT",
    "INVARIANT_SOURCES",
    "Assumptions",
    "RuntimeLaw",
    "StationReference",
    "error_channels",
    "motion_at",
    "vehicle_times",
]
