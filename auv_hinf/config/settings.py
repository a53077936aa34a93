"""Design configurations: frozen runtime objects, validated from TOML files or from Python.

The TOML format is defined by the strict pydantic models of :mod:`auv_hinf.config.schema`
(``auv-hinf schema`` prints it as JSON Schema). :class:`FormationConfig` and its tables
(``[reference]``, ``[simulation]``, ``[uncertainty]``, ``[disturbance]``) are frozen dataclasses
that validate themselves with the same models at construction, so a bad value raises
:class:`~auv_hinf.exceptions.ConfigError` whether it comes from a file or from Python.
:func:`read_document` reads every input file of the toolbox (configurations and certificates).
The built-in presets live in :mod:`auv_hinf.config.presets`.
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, cast

from auv_hinf._typing import FormationFrame, GainMethod, JacobiKind, NoisePatternSetting, SynthesisKind
from auv_hinf.actuation.limits import VEHICLE_ACTUATORS, Actuation, Actuators, RudderActuation, vehicle_actuators
from auv_hinf.config.messages import as_dict, parse_config, plain_data, set_fields, validate_table
from auv_hinf.config.schema import (
    DEFAULT_FRAME,
    DEFAULT_HORIZON,
    DEFAULT_INTEGRAL,
    DEFAULT_METHOD,
    DEFAULT_MIN_SEPARATION,
    DEFAULT_NOISE_PATTERN,
    DEFAULT_POLES,
    DEFAULT_SEED,
    DEFAULT_START,
    DEFAULT_SYNTHESIS,
    REFERENCE_MODELS,
    ActuatorsTable,
    DesignTable,
    DisturbanceTable,
    EnvelopeTable,
    FormationTable,
    ImplementationTable,
    ReferenceKind,
    SimulationTable,
    StartKind,
    UncertaintyTable,
    speed_misfit,
)
from auv_hinf.exceptions import AuvHinfError, ConfigError
from auv_hinf.guidance.law import GuidanceConfig
from auv_hinf.implementation.model import Implementation, MeasurementNoise
from auv_hinf.law.gains import DEFAULT_K1
from auv_hinf.models.envelope import Envelope
from auv_hinf.models.jacobi import JacobiTransform
from auv_hinf.models.vehicle import PRESETS as VEHICLE_PRESETS
from auv_hinf.models.vehicle import VehicleParams, preset


@dataclass(frozen=True)
class ReferenceConfig:
    """Mission reference (the formation centre's path), validated but not built.

    Parameters
    ----------
    kind : {"sine", "line", "circle", "lawnmower"}
    params : tuple of (str, float) pairs, or a dict
        Parameters of that kind (m, m/s, rad, rad/s; see ``auv-hinf schema``); missing
        ones take their defaults, so the stored tuple is complete.
    """

    kind: ReferenceKind = "sine"
    params: tuple[tuple[str, float], ...] = ()

    def __post_init__(self) -> None:
        model = REFERENCE_MODELS.get(self.kind) if isinstance(self.kind, str) else None
        if model is None:
            raise ConfigError(f"reference.kind must be one of {tuple(REFERENCE_MODELS)}, got {self.kind!r}")
        given = plain_data(as_dict(self.params, "reference params"))
        table = validate_table(model, {**given, "kind": self.kind}, ("reference", self.kind))
        set_fields(self, params=tuple((k, float(v)) for k, v in table.model_dump(exclude={"kind"}).items()))

    def kwargs(self) -> dict[str, float]:
        """The parameters as keyword arguments, e.g. for ``reference_from_dict(kind, **kwargs)``."""
        return dict(self.params)

    def to_dict(self) -> dict[str, Any]:
        """``{"kind": ..., **params}``: JSON-safe and a valid ``[reference]`` table."""
        return {"kind": self.kind, **self.kwargs()}


@dataclass(frozen=True)
class SimulationConfig:
    """Closed-loop simulation settings (the ``[simulation]`` table).

    Attributes
    ----------
    horizon : float
        Simulated time, s (> 0).
    start : {"shaped", "paper"}
        ``"shaped"``: the reference blends from the actual start; ``"paper"``: raw reference.
    initial : tuple of tuples or None
        One ``[x, y, psi, u, v, r]`` per vehicle (m, m, rad, m/s, m/s, rad/s); ``None``
        lets the scenario choose.
    current : tuple of float
        Constant ocean current, inertial frame, m/s.
    blend_time : float or None
        Reference blending time, s (``None``: chosen by the certificate).
    plant : tuple of (str, float) pairs
        True plant as multipliers (> 0) of the controller's parameters; a dict is accepted.
    seed : int
        Seed of the noise and delay draws of a sampled implementation (>= 0).
    noise_pattern : {"uniform", "bang-bang", "bias", "slow", "against-error", "mixed"}
        How a sampled run's measurement errors are drawn within their bounds
        (:mod:`auv_hinf.implementation.draws`); ``mixed``: campaign run ``i`` takes the ``i``-th
        pattern in turn.
    """

    horizon: float = DEFAULT_HORIZON
    start: StartKind = DEFAULT_START
    initial: tuple[tuple[float, ...], ...] | None = None
    current: tuple[float, float] = (0.0, 0.0)
    blend_time: float | None = None
    plant: tuple[tuple[str, float], ...] = ()
    seed: int = DEFAULT_SEED
    noise_pattern: NoisePatternSetting = DEFAULT_NOISE_PATTERN

    def __post_init__(self) -> None:
        raw = {
            "horizon": self.horizon,
            "start": self.start,
            "current": self.current,
            "plant": as_dict(self.plant, "simulation.plant"),
            "seed": self.seed,
            "noise_pattern": self.noise_pattern,
        }
        raw.update({k: getattr(self, k) for k in ("initial", "blend_time") if getattr(self, k) is not None})
        t = validate_table(SimulationTable, plain_data(raw), ("simulation",))
        rows = None if t.initial is None else tuple(tuple(row) for row in t.initial)
        set_fields(
            self,
            horizon=t.horizon,
            start=t.start,
            initial=rows,
            current=tuple(t.current),
            blend_time=t.blend_time,
            plant=tuple((k, v) for k, v in t.plant.model_dump().items() if v is not None),
            seed=t.seed,
            noise_pattern=t.noise_pattern,
        )

    def plant_params(self, nominal: VehicleParams) -> VehicleParams:
        """The simulated plant: ``nominal`` with the :attr:`plant` multipliers applied.

        Parameters
        ----------
        nominal : VehicleParams
            The configured vehicle.
        """
        if not self.plant:
            return nominal
        scaled = {k: getattr(nominal, k) * m for k, m in self.plant}
        label = ", ".join(f"{k} x{m:g}" for k, m in self.plant)
        return replace(nominal, name=f"{nominal.name} ({label})", **scaled)

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe dictionary; absent options are ``None``."""
        return {
            "horizon": self.horizon,
            "start": self.start,
            "initial": None if self.initial is None else [list(r) for r in self.initial],
            "current": list(self.current),
            "blend_time": self.blend_time,
            "plant": dict(self.plant),
            "seed": self.seed,
            "noise_pattern": self.noise_pattern,
        }


@dataclass(frozen=True)
class UncertaintyConfig:
    """Declared parameter box (``[uncertainty]``): name -> relative ``(lo, hi)``, 0.1 <= lo <= 1 <= hi <= 10.

    Attributes
    ----------
    box : tuple of (str, (float, float))
        The declared parameters (vehicle coefficient names) with their multipliers ``(lo, hi)``.
    """

    box: tuple[tuple[str, tuple[float, float]], ...] = ()

    def __post_init__(self) -> None:
        t = validate_table(UncertaintyTable, plain_data(as_dict(self.box, "uncertainty")), ("uncertainty",))
        set_fields(self, box=tuple((k, (v[0], v[1])) for k, v in t.model_dump().items() if v is not None))

    def to_dict(self) -> dict[str, list[float]]:
        """``{name: [lo, hi]}``: JSON-safe and a valid ``[uncertainty]`` table."""
        return {k: list(v) for k, v in self.box}


@dataclass(frozen=True)
class DisturbanceConfig:
    """Declared current bounds (``[disturbance]``): speed in m/s, rate in m/s^2 (``None``: not declared).

    Attributes
    ----------
    current_speed : float or None
        Bound on ``|current|`` (m/s, inertial frame).
    current_rate : float or None
        Bound on ``|d current / dt|`` (m/s^2).
    """

    current_speed: float | None = None
    current_rate: float | None = None

    def __post_init__(self) -> None:
        raw = {
            k: v
            for k, v in (("current_speed", self.current_speed), ("current_rate", self.current_rate))
            if v is not None
        }
        t = validate_table(DisturbanceTable, plain_data(raw), ("disturbance",))
        set_fields(self, current_speed=t.current_speed, current_rate=t.current_rate)

    def to_dict(self) -> dict[str, float]:
        """The declared bounds only (a valid ``[disturbance]`` table)."""
        return {
            k: v
            for k, v in (("current_speed", self.current_speed), ("current_rate", self.current_rate))
            if v is not None
        }


if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib


@dataclass(frozen=True)
class FormationConfig:
    """Everything needed to certify and simulate one formation design.

    Attributes
    ----------
    name : str
        Preset name or file stem.
    vehicle : VehicleParams
    n : int
        Number of vehicles (>= 2).
    jacobi : {"paper", "orthonormal"}
    shape : tuple
        Desired Jacobi shape vectors ``rho_d`` (N-1 pairs, m) in the ``jacobi`` convention;
        no two vehicles may share a desired position.
    envelope : Envelope
    method : {"paper", "stabilizing", "minimal"}
        Gain method used by the certificate.
    gamma : float or None
        Override of ``1/sigma_upper`` (s, > 0).
    lam : float or None
        Override of the envelope lambda (1/s, < 0).
    k1 : float
        Theorem 2 position gain (1/s^2, > 0).
    heading_poles : tuple of float
        Two distinct negative poles of the heading loop (1/s).
    robust : bool
        Use the robust design (:mod:`auv_hinf.robust.bandwidth`) instead of the Theorem 1 gain,
        ``k1`` and ``heading_poles``.
    synthesis : {"bandwidth", "lmi", "deployed"}
        How the robust design chooses its gains: the bandwidth family, LMI synthesis
        (:mod:`auv_hinf.robust.synthesis`) or a search over the composed certificate of the
        deployed loop (:mod:`auv_hinf.composed.synthesis`; needs a sampled ``[implementation]``).
    integral : bool
        Integral action in the position loop (``[design] integral``; needs ``robust``): the
        robust design adds ``ki`` (:func:`~auv_hinf.law.gains.integral_gain`) to each candidate.
    actuators : Actuators, RudderActuation or None
        What the vehicles can push (``None``: none declared, unlimited thrust): independent
        surge, sway and yaw limits, or a propeller and a rudder (an underactuated vehicle, on
        which the fully actuated formation law is refused).
    implementation : Implementation
        The controller as it runs: sample time, delay, measurement noise (default:
        continuous, undelayed, exact, as in the paper).
    frame : {"inertial", "path"}
        Frame of the formation offsets (``[formation] frame``): ``"inertial"`` (the paper, the
        default: the Jacobi shape is fixed in the earth frame, vehicle i tracks ``q + d_i``) or
        ``"path"`` (the offsets, ``x`` along the track and ``y`` across it on the body y axis, turn with the
        path's course: ``q + R(chi) d_i``; see :mod:`auv_hinf.mission.fleet`).
    min_separation : float
        Smallest distance between any two vehicles (m, > 0) the certificate must prove for the
        configured run (``[formation] min_separation``; see
        :mod:`auv_hinf.certificate.parts.separation`).
    reference, simulation, uncertainty, disturbance
        The ``[reference]``, ``[simulation]``, ``[uncertainty]`` and ``[disturbance]`` tables.
    guidance : GuidanceConfig or None
        The ``[guidance]`` table: line-of-sight guidance for a propeller-and-rudder vehicle
        (:mod:`auv_hinf.guidance.law`); ``None``: the fully actuated formation law.

    Raises
    ------
    ConfigError
        At construction, for any invalid field: e.g. ``len(shape) != n - 1``, coincident
        vehicles, ``simulation.initial`` without one row per vehicle, an envelope in degrees
        (:data:`~auv_hinf.config.schema.MAX_RATE`), or a reference speed far above the envelope
        (:func:`~auv_hinf.config.schema.speed_misfit`).
    """

    name: str
    vehicle: VehicleParams
    n: int
    jacobi: JacobiKind
    shape: tuple[tuple[float, float], ...]
    envelope: Envelope
    method: GainMethod = DEFAULT_METHOD
    gamma: float | None = None
    lam: float | None = None
    k1: float = DEFAULT_K1
    heading_poles: tuple[float, float] = DEFAULT_POLES
    robust: bool = False
    synthesis: SynthesisKind = DEFAULT_SYNTHESIS
    integral: bool = DEFAULT_INTEGRAL
    reference: ReferenceConfig = field(default_factory=ReferenceConfig)
    simulation: SimulationConfig = field(default_factory=SimulationConfig)
    uncertainty: UncertaintyConfig = field(default_factory=UncertaintyConfig)
    disturbance: DisturbanceConfig = field(default_factory=DisturbanceConfig)
    actuators: Actuation | None = None
    implementation: Implementation = field(default_factory=Implementation)
    frame: FormationFrame = DEFAULT_FRAME
    min_separation: float = DEFAULT_MIN_SEPARATION
    guidance: GuidanceConfig | None = None

    def __post_init__(self) -> None:
        for key, kind in (
            ("name", str),
            ("vehicle", VehicleParams),
            ("envelope", Envelope),
            ("reference", ReferenceConfig),
            ("simulation", SimulationConfig),
            ("uncertainty", UncertaintyConfig),
            ("disturbance", DisturbanceConfig),
            ("implementation", Implementation),
        ):
            if not isinstance(getattr(self, key), kind):
                raise ConfigError(f"{key} must be a {kind.__name__}, got {getattr(self, key)!r}")
        if self.actuators is not None and not isinstance(self.actuators, (Actuators, RudderActuation)):
            raise ConfigError(f"actuators must be an Actuators, a RudderActuation or None, got {self.actuators!r}")
        if self.guidance is not None:
            if not isinstance(self.guidance, GuidanceConfig):
                raise ConfigError(f"guidance must be a GuidanceConfig or None, got {self.guidance!r}")
            if not isinstance(self.actuators, RudderActuation):
                raise ConfigError(
                    "guidance: line-of-sight guidance steers a propeller-and-rudder vehicle; declare its "
                    '[actuators] with kind = "underactuated" (tau_x, rudder_max, rudder_sway, rudder_yaw) or a '
                    'preset such as "remus100", or remove [guidance] to use the fully actuated law'
                )
        form = validate_table(FormationTable, plain_data(self._formation_table()), ("formation",))
        validate_table(EnvelopeTable, plain_data(self.envelope.to_dict()), ("envelope",))  # the units, from Python too
        misfit = speed_misfit(self.reference.kwargs()["speed"], self.envelope.u)
        if misfit is not None:
            raise ConfigError(misfit)
        design = self._design_table()
        des = validate_table(DesignTable, plain_data({k: v for k, v in design.items() if v is not None}), ("design",))
        if self.synthesis == "deployed" and not self.implementation.sampled:
            raise ConfigError(
                'design.synthesis: "deployed" designs the gains for the sampled law: declare [implementation] '
                'sample_time (s), or choose synthesis = "lmi" or "bandwidth"'
            )
        if self.integral and not self.implementation.continuous:
            raise ConfigError(
                "design.integral: integral action runs with the continuous, exact implementation only in this "
                "version (the implementation certificate does not cover the integrator); remove the "
                "[implementation] sample time, delay and noise, or set integral = false"
            )
        init = self.simulation.initial
        if init is not None and len(init) != form.n:
            raise ConfigError(f"simulation.initial must have one row per vehicle ({form.n}), got {len(init)}")
        set_fields(
            self,
            n=form.n,
            shape=form.jacobi_shape(),
            gamma=des.gamma,
            lam=des.lam,
            k1=des.k1,
            heading_poles=(des.heading_poles[0], des.heading_poles[1]),
            min_separation=form.min_separation,
        )

    def _formation_table(self) -> dict[str, Any]:
        """The ``[formation]`` table of this configuration."""
        return {
            "n": self.n,
            "jacobi": self.jacobi,
            "frame": self.frame,
            "shape": [list(s) for s in self.shape],
            "min_separation": self.min_separation,
        }

    def _design_table(self) -> dict[str, Any]:
        """The ``[design]`` table of this configuration (``None`` for an option not set)."""
        return {
            "method": self.method,
            "gamma": self.gamma,
            "lambda": self.lam,
            "k1": self.k1,
            "heading_poles": list(self.heading_poles),
            "robust": self.robust,
            "synthesis": self.synthesis,
            "integral": self.integral,
        }

    @property
    def transform(self) -> JacobiTransform:
        """The Jacobi transform of this configuration."""
        return JacobiTransform(self.n, self.jacobi)

    @property
    def force_limits(self) -> Actuators | None:
        """The force box limits the certificates hold the law's peaks against (N, N, N m).

        The declared :class:`~auv_hinf.actuation.limits.Actuators`; ``None`` when none are
        declared, or when the vehicle is underactuated (a rudder has no force box: the actuator
        part refuses the fully actuated law on it, and the other parts bound the force it would need).
        """
        return self.actuators if isinstance(self.actuators, Actuators) else None

    def with_method(self, method: str) -> FormationConfig:
        """Copy with another gain method (validated).

        Parameters
        ----------
        method : {"paper", "stabilizing", "minimal"}
            The Theorem 1 gain method.
        """
        return replace(self, method=cast(GainMethod, method))

    def to_dict(self) -> dict[str, Any]:
        """Full JSON-safe dictionary (absent options are ``None``)."""
        return {
            "name": self.name,
            "vehicle": self.vehicle.to_dict(),
            "n": self.n,
            "jacobi": self.jacobi,
            "frame": self.frame,
            "shape": [list(s) for s in self.shape],
            "min_separation": self.min_separation,
            "envelope": self.envelope.to_dict(),
            **self._design_table(),
            "reference": self.reference.to_dict(),
            "simulation": self.simulation.to_dict(),
            "uncertainty": self.uncertainty.to_dict(),
            "disturbance": self.disturbance.to_dict(),
            "actuators": None if self.actuators is None else self.actuators.to_dict(),
            "implementation": self.implementation.to_dict(),
            "guidance": None if self.guidance is None else self.guidance.to_dict(),
        }

    def to_toml_dict(self) -> dict[str, Any]:
        """The configuration as TOML tables (no ``None``): ``config_from_dict`` of it reproduces it."""
        speed = float(self.reference.kwargs()["speed"])  # a speed-linearised preset is the mission speed's
        vehicle: dict[str, Any] = next(
            ({"preset": key} for key in VEHICLE_PRESETS if preset(key, speed) == self.vehicle),
            {k: v for k, v in self.vehicle.to_dict().items()},
        )
        design = self._design_table()
        sim = {k: v for k, v in self.simulation.to_dict().items() if v not in (None, {})}
        out = {
            "name": self.name,
            "vehicle": vehicle,
            "formation": self._formation_table(),
            "envelope": self.envelope.to_dict(),
            "design": {k: v for k, v in design.items() if v is not None},
            "reference": self.reference.to_dict(),
            "simulation": sim,
            "uncertainty": self.uncertainty.to_dict(),
            "disturbance": self.disturbance.to_dict(),
            "actuators": _actuators_table(self.actuators),
            "implementation": {} if self.implementation == Implementation() else self.implementation.to_dict(),
            "guidance": {} if self.guidance is None else self.guidance.to_dict(),
        }
        return {k: v for k, v in out.items() if v != {}}


def _actuators_table(act: Actuation | None) -> dict[str, Any]:
    """The ``[actuators]`` table of ``act`` (empty when none is declared)."""
    if act is None:
        return {}
    if act.source in VEHICLE_ACTUATORS and VEHICLE_ACTUATORS[act.source] == act:
        return {"preset": act.source}
    if isinstance(act, RudderActuation):
        return {
            "kind": act.kind,
            "tau_x": act.tau_x,
            "rudder_max": act.rudder_max,
            "rudder_sway": act.rudder_sway,
            "rudder_yaw": act.rudder_yaw,
        }
    return {"tau_x": act.tau_x, "tau_y": act.tau_y, "tau_psi": act.tau_psi}


def _actuators(table: ActuatorsTable | None) -> Actuation | None:
    """Runtime actuation of a validated ``[actuators]`` table."""
    if table is None:
        return None
    if table.preset is not None:
        return vehicle_actuators(table.preset)
    if table.kind == "underactuated":
        return RudderActuation(
            float(table.tau_x or 0.0),
            float(table.rudder_max or 0.0),
            float(table.rudder_sway or 0.0),
            float(table.rudder_yaw or 0.0),
        )
    return Actuators(float(table.tau_x or 0.0), float(table.tau_y or 0.0), float(table.tau_psi or 0.0))


def _implementation(table: ImplementationTable) -> Implementation:
    """Runtime implementation of a validated ``[implementation]`` table."""
    return Implementation(
        sample_time=table.sample_time,
        delay=table.delay,
        varying_delay=table.varying_delay,
        noise=MeasurementNoise(**table.noise.model_dump()),
    )


def config_from_dict(data: Any, name: str = "config") -> FormationConfig:
    """Build and validate a :class:`FormationConfig` from parsed TOML (a dict of tables).

    Parameters
    ----------
    data : Any
        The parsed document.
    name : str
        The configuration's name unless the document has a top-level ``name``.

    Raises
    ------
    ConfigError
        With one line per problem, each naming its TOML path.
    """
    cf = parse_config(data)
    label = cf.name or name
    try:
        vehicle = cf.vehicle.to_params(label, float(cf.reference.speed))
    except AuvHinfError as exc:
        raise ConfigError(f"vehicle: {exc}") from None
    sim = cf.simulation
    return FormationConfig(
        name=label,
        vehicle=vehicle,
        n=cf.formation.n,
        jacobi=cf.formation.jacobi,
        shape=cf.formation.jacobi_shape(),
        envelope=Envelope(**cf.envelope.model_dump()),
        method=cf.design.method,
        gamma=cf.design.gamma,
        lam=cf.design.lam,
        k1=cf.design.k1,
        heading_poles=(cf.design.heading_poles[0], cf.design.heading_poles[1]),
        robust=cf.design.robust,
        synthesis=cf.design.synthesis,
        integral=cf.design.integral,
        reference=ReferenceConfig(cf.reference.kind, tuple(cf.reference.model_dump(exclude={"kind"}).items())),
        simulation=SimulationConfig(
            horizon=sim.horizon,
            start=sim.start,
            initial=None if sim.initial is None else tuple(map(tuple, sim.initial)),
            current=(sim.current[0], sim.current[1]),
            blend_time=sim.blend_time,
            plant=tuple((k, v) for k, v in sim.plant.model_dump().items() if v is not None),
            seed=sim.seed,
            noise_pattern=sim.noise_pattern,
        ),
        uncertainty=UncertaintyConfig(tuple((k, (v[0], v[1])) for k, v in cf.uncertainty.model_dump().items() if v)),
        disturbance=DisturbanceConfig(cf.disturbance.current_speed, cf.disturbance.current_rate),
        actuators=_actuators(cf.actuators),
        implementation=_implementation(cf.implementation),
        frame=cf.formation.frame,
        min_separation=cf.formation.min_separation,
        guidance=None if cf.guidance is None else GuidanceConfig(**cf.guidance.model_dump()),
    )


def with_settings(cfg: FormationConfig, settings: Iterable[tuple[str, str, Any]]) -> FormationConfig:
    """``cfg`` with each ``(table, key, value)`` written into its TOML tables, validated again.

    The advice of a certificate (``Reason.settings``) is in this form: a table such as
    ``"uncertainty"`` or ``"implementation.noise"`` (dotted for a nested table), a key and the
    value to write there. ``None`` removes the key.

    Parameters
    ----------
    cfg : FormationConfig
        The configuration.
    settings : iterable of (str, str, Any)
        ``(table, key, value)`` triples.

    Raises
    ------
    ConfigError
        If the result is not a valid configuration.
    """
    doc = cfg.to_toml_dict()
    for table, key, value in settings:
        node = doc
        for part in table.split("."):
            node = node.setdefault(part, {})
        if value is None:
            node.pop(key, None)
        else:
            node[key] = value
    return config_from_dict(doc, cfg.name)


def load_config(path: str | Path) -> FormationConfig:
    """Read and validate a TOML configuration file (the name defaults to the file stem).

    Parameters
    ----------
    path : str or Path
        The TOML file.

    Raises
    ------
    ConfigError
        If the file cannot be read, is not TOML, or fails validation; every line of the
        message starts with the file name.
    """
    return read_config(path)[0]


def read_document(path: Path, what: str, syntax: str, parse: Callable[[str], Any]) -> Any:
    """The parsed document of a UTF-8 text file (a TOML config, a JSON certificate), or a one-line error.

    Parameters
    ----------
    path : Path
        The file.
    what : str
        What it is, for the messages (``"config"``, ``"certificate"``).
    syntax : str
        Its syntax, for the messages (``"TOML"``, ``"JSON"``).
    parse : callable
        ``str -> document``; raises ``ValueError`` (``tomllib.TOMLDecodeError`` and
        ``json.JSONDecodeError`` are) on a syntax error.

    Raises
    ------
    ConfigError
        If the file cannot be read, is not UTF-8 text, or does not parse.
    """
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        reason = exc.strerror if isinstance(exc, OSError) else "not UTF-8 text"
        raise ConfigError(f"cannot read {what} {str(path)!r}: {reason}") from None
    try:
        return parse(text)
    except ValueError as exc:
        raise ConfigError(f"{path}: invalid {syntax}: {exc}") from None


def read_config(path: str | Path) -> tuple[FormationConfig, dict[str, Any]]:
    """:func:`load_config`, also returning the parsed TOML document (for input warnings).

    Parameters
    ----------
    path : str or Path
        The TOML file.

    Raises
    ------
    ConfigError
        As :func:`load_config`.
    """
    if not isinstance(path, (str, Path)):
        raise ConfigError(f"expected the path of a TOML configuration file (str or Path), got {type(path).__name__}")
    p = Path(path)
    data = read_document(p, "config", "TOML", tomllib.loads)
    try:
        return config_from_dict(data, name=p.stem), data
    except ConfigError as exc:
        raise ConfigError("\n".join(f"{p}: {line}" for line in str(exc).splitlines())) from None


__all__ = [
    "DisturbanceConfig",
    "FormationConfig",
    "ReferenceConfig",
    "SimulationConfig",
    "UncertaintyConfig",
    "config_from_dict",
    "load_config",
    "read_config",
    "with_settings",
]
