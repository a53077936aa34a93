"""The certificate of a configuration: its parts, assembled.

:func:`certify` computes the design point once
(:func:`~auv_hinf.certificate.design_point.design_point`) and runs every registered part on
it, in order (:mod:`auv_hinf.certificate.registry`): the paper's Theorem 1, the closed loop
along the mission, the robust certificate of a declared box and current, the actuators and the
implementation. The :class:`Certificate` holds their verdicts; it is certified when every part
holds. Its JSON record (``certify --json``), its text, its stored file and the CLI's exit code
are all read off the verdicts, so a new part needs no change here.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import control as ct

from auv_hinf.actuation.limits import RudderActuation
from auv_hinf.certificate.design_point import design_point, raw_fleet
from auv_hinf.certificate.document import read_certificate, record_from_document, save_certificate
from auv_hinf.certificate.part import LAW_IDLE, PartContext, Verdict, control_law, part_laws, reasons_of
from auv_hinf.certificate.parts.robust import figures_kept_inside, run_kept_inside
from auv_hinf.certificate.parts.theorem1 import DEFAULT_JACOBI_SAMPLES, Theorem1Result
from auv_hinf.certificate.reason import Reason
from auv_hinf.certificate.registry import part_supersedes, parts, superseded_by, superseded_figures
from auv_hinf.certificate.text import certificate_text
from auv_hinf.config.settings import FormationConfig
from auv_hinf.exceptions import ConfigError, DesignError, ParameterError, require_count
from auv_hinf.guidance.export import sampled_guidance_controller
from auv_hinf.guidance.simulation import cascade_period
from auv_hinf.law.formation_law import MotionSource, VehicleLaw
from auv_hinf.law.gains import Gains
from auv_hinf.law.interconnect import fleet_closed_loop, formation_controller, sampled_formation_controller
from auv_hinf.mission.fleet import FleetReference
from auv_hinf.models.vehicle import VehicleParams


@dataclass(frozen=True)
class Certificate:
    """Result of :func:`certify`: the verdicts of every part on one configuration.

    Attributes
    ----------
    config : FormationConfig
        The certified configuration.
    verdicts : tuple of Verdict
        One per part, in evaluation order (:mod:`auv_hinf.certificate.registry`).
    gains : Gains or None
        The gains that run: the ones every part is about, that ``simulate`` uses and that
        :meth:`controller` exports (``None`` when the design gives none).
    gain_source : {"theorem1", "robust"}
        Where ``gains`` come from: Theorem 1 (the configured method, ``k1``, the heading poles)
        or the robust design.
    design : dict or None
        How the gains were chosen (:meth:`~auv_hinf.certificate.design_point.DesignPoint.summary`),
        with what binds the design.

    Notes
    -----
    A certificate read back from its file (:meth:`load`) keeps every part's figures, verdict and
    reasons, the configuration and the gains, but not the parts' typed results (LMI matrices,
    coverage objects): those properties are ``None`` there, and :func:`certify` recomputes them.
    """

    config: FormationConfig
    verdicts: tuple[Verdict, ...]
    gains: Gains | None = None
    gain_source: str = "theorem1"
    design: dict[str, Any] | None = None

    def verdict(self, name: str) -> Verdict | None:
        """The verdict of the part called ``name`` (``None``: no such part).

        Parameters
        ----------
        name : str
            Part name (e.g. ``"theorem1"``, ``"closed_loop"``).
        """
        return next((v for v in self.verdicts if v.part == name), None)

    @property
    def certified(self) -> bool:
        """Every part holds."""
        return all(v.ok for v in self.verdicts)

    @property
    def findings(self) -> tuple[Reason, ...]:
        """Why it is not certified, as data (part, kind, channel, vehicle, value, limit, settings)."""
        return reasons_of(self.verdicts)

    @property
    def reasons(self) -> tuple[str, ...]:
        """Why it is not certified, one sentence per reason (empty when certified)."""
        return tuple(r.message for r in self.findings)

    def _detail(self, name: str) -> Any:
        v = self.verdict(name)
        return None if v is None else v.detail

    def _figure(self, key: str) -> Any:
        t = self.verdict("theorem1")
        return None if t is None or t.figures is None else t.figures.get(key)

    @property
    def closed_loop(self) -> Any:
        """The closed-loop part's :class:`~auv_hinf.certificate.parts.closed_loop.ClosedLoopSummary` (or ``None``)."""
        return self._detail("closed_loop")

    @property
    def robust(self) -> Any:
        """The robust part's :class:`~auv_hinf.certificate.parts.robust.RobustSummary` (or ``None``)."""
        return self._detail("robust")

    @property
    def actuators(self) -> Any:
        """The actuator part's :class:`~auv_hinf.certificate.parts.actuators.ActuatorCheck` (or ``None``)."""
        return self._detail("actuators")

    @property
    def implementation(self) -> Any:
        """The implementation part's :class:`~auv_hinf.certificate.parts.implementation.ImplementationSummary`."""
        return self._detail("implementation")

    @property
    def theorem1_result(self) -> Theorem1Result | None:
        """The Theorem 1 part's typed result (sigma bounds, gain designs, cross-check)."""
        detail = self._detail("theorem1")
        return detail if isinstance(detail, Theorem1Result) else None

    @property
    def lam(self) -> float:
        """Constant lambda of the envelope (1/s)."""
        return float(self._figure("lambda"))

    @property
    def gamma(self) -> float:
        """The H-infinity bound of Theorem 1 (s)."""
        return float(self._figure("gamma"))

    @property
    def alpha_used(self) -> float | None:
        """The configured method's Theorem 1 gain (1/s)."""
        alpha = self._figure("alpha")
        return None if alpha is None else alpha.get("used")

    @property
    def small_gain_margin(self) -> float | None:
        """``(alpha - lam) - sigma_upper`` (1/s)."""
        value = self._figure("small_gain_margin")
        return None if value is None else float(value)

    @property
    def position_loop_hinf(self) -> float | None:
        """Theorem 2 loop norm ``1/(alpha - lam)`` (s)."""
        value = self._figure("position_loop_hinf")
        return None if value is None else float(value)

    @property
    def sigma(self) -> Any:
        """Vehicle-coordinate sigma bounds (:class:`~auv_hinf.design.sigma.SigmaBounds`)."""
        r = self.theorem1_result
        return None if r is None else r.sigma

    @property
    def sigma_jacobi(self) -> Any:
        """Jacobi-coordinate sigma bounds, for the record."""
        r = self.theorem1_result
        return None if r is None else r.sigma_jacobi

    @property
    def theorem1(self) -> Any:
        """The hypotheses of Theorem 1 (:class:`~auv_hinf.design.theorem1.Theorem1Conditions`)."""
        r = self.theorem1_result
        return None if r is None else r.theorem1

    @property
    def designs(self) -> Any:
        """``GainDesign`` per Theorem 1 method (``None`` where infeasible)."""
        r = self.theorem1_result
        return None if r is None else r.designs

    @property
    def crosscheck(self) -> Any:
        """The four-way cross-check of the Theorem 1 gain (:class:`~auv_hinf.design.crosscheck.CrosscheckReport`)."""
        r = self.theorem1_result
        return None if r is None else r.crosscheck

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe dictionary (the ``auv-hinf certify --json`` layout).

        Top-level: ``preset``, ``n``, the figures of the parts without a key (Theorem 1's
        ``lambda``, ``sigma``, ``alpha``, ...), ``certified``, ``reasons`` (sentences),
        ``envelope``, ``vehicle``, then one object per part under its key, ``gains``,
        ``design`` and ``parts`` (each part's verdict and reasons as data).
        """
        cfg = self.config
        out: dict[str, Any] = {"preset": cfg.name, "n": cfg.n}
        for v in self.verdicts:
            if v.key is None and v.figures is not None:
                out.update(v.figures)
        out.update(
            {
                "certified": self.certified,
                "reasons": list(self.reasons),
                "envelope": cfg.envelope.to_dict(),
                "vehicle": cfg.vehicle.to_dict(),
            }
        )
        for v in self.verdicts:
            if v.key is not None:
                out[v.key] = v.figures
        out["gains"] = None if self.gains is None else {**self.gains.to_dict(), "source": self.gain_source}
        out["design"] = self.design
        out["parts"] = {v.part: v.record() for v in self.verdicts}
        return out

    @classmethod
    def from_record(cls, config: FormationConfig, record: Mapping[str, Any]) -> Certificate:
        """The certificate a stored record describes (the figures and verdicts, no typed results).

        Parameters
        ----------
        config : FormationConfig
            The configuration stored beside the record.
        record : mapping
            The record in the version 4 layout (:meth:`to_dict`'s).

        Raises
        ------
        KeyError, TypeError, ValueError
            If the record lacks what the layout requires (the stored document is validated first).
        """
        verdicts = tuple(Verdict.restored(name, entry, record) for name, entry in record["parts"].items())
        g = record.get("gains")
        gains = None if g is None else Gains.from_dict(g)
        source = "theorem1" if g is None else str(g.get("source", "theorem1"))
        return cls(config, verdicts, gains, source, record.get("design"))

    def save(self, path: str | Path) -> Path:
        """Write the certificate as its stored document; see :mod:`auv_hinf.certificate.document`.

        Parameters
        ----------
        path : str or Path
            The file to write; its parent directory must exist.

        Returns
        -------
        Path
            The file written.
        """
        return save_certificate(self, path)

    @classmethod
    def load(cls, path: str | Path) -> Certificate:
        """Read a file written by :meth:`save` (any format version) without re-certifying.

        Parameters
        ----------
        path : str or Path
            The certificate file.

        Raises
        ------
        ConfigError
            Not a certificate file, an unknown version, an invalid configuration, or an edited record.
        """
        return load_certificate(path)

    def law(self) -> VehicleLaw:
        """The law this certificate is about: its :attr:`gains` on the configured model and thrust limit.

        Raises
        ------
        DesignError
            If the design gave no gains (see :attr:`reasons`).
        """
        if self.gains is None:
            raise DesignError(f"certificate of {self.config.name!r} has no gains: {'; '.join(self.reasons)}")
        cfg = self.config
        return VehicleLaw(params=cfg.vehicle, gains=self.gains, actuators=cfg.actuators)

    def controller(self, reference: MotionSource | None = None) -> ct.NonlinearIOSystem:
        """The certified law along the raw mission as a python-control ``nlsys``.

        Inputs ``x[i], y[i], psi[i], u[i], v[i], r[i]``, outputs ``tau_x[i], tau_y[i],
        tau_psi[i]`` (N, N, N m). With a declared sample time it is the law as it runs: discrete
        time, ``dt = sample_time``, the delay a shift of whole samples (a fractional delay is
        rounded down; see :func:`auv_hinf.law.interconnect.sampled_formation_controller`).
        Otherwise it is the continuous static law
        (:func:`auv_hinf.law.interconnect.formation_controller`, ``dt = 0``), and a delay declared
        with ``sample_time = 0`` is not in it. With ``[guidance]`` it is the line-of-sight cascade as
        it runs and as its certificate covers it (:func:`auv_hinf.guidance.export.sampled_guidance_controller`:
        discrete time at the cascade's control period, the declared sample time or 0.1 s, the ILOS
        integrators as states, the delay a shift of whole samples; inputs each vehicle's state and
        ground velocity, outputs its thrust and rudder); ``reference`` is then ignored.

        Parameters
        ----------
        reference : MotionSource, optional
            Overrides the raw mission reference (e.g. a shaped start from
            :func:`~auv_hinf.certificate.run_plan.plan_run`).

        Returns
        -------
        control.NonlinearIOSystem
            The controller.
        """
        if reference is not None and not callable(getattr(reference, "motion", None)):
            raise ParameterError(
                f"reference must give the desired motion (an object with motion(t), such as plan_run(cfg)"
                f".scenario.reference), got {type(reference).__name__}"
            )
        cfg = self.config
        if cfg.guidance is not None and isinstance(cfg.actuators, RudderActuation):  # the cascade runs
            period, delay = cascade_period(cfg.implementation), cfg.implementation.delay
            fleet = self.mission_fleet()
            return sampled_guidance_controller(cfg.guidance, cfg.vehicle, cfg.actuators, fleet, period, delay)
        ref, impl = reference or self.mission_fleet(), self.config.implementation
        if impl.sampled:
            return sampled_formation_controller(self.law(), ref, self.config.n, impl.sample_time, impl.delay)
        return formation_controller(self.law(), ref, self.config.n)

    def closed_loop_system(
        self, reference: MotionSource | None = None, plant: VehicleParams | None = None
    ) -> ct.NonlinearIOSystem:
        """The closed loop as ``control.interconnect`` of the N plants and :meth:`controller`.

        No inputs; the state is the stacked fleet state (``(N, 6).ravel()``) and so are the
        outputs; see :func:`auv_hinf.law.interconnect.fleet_closed_loop`.

        Parameters
        ----------
        reference : MotionSource, optional
            Overrides the raw mission reference, as in :meth:`controller`.
        plant : VehicleParams, optional
            The plant; default the nominal model ``config.vehicle`` (the one the nominal
            certificate covers).
        """
        cfg = self.config
        ref = reference or self.mission_fleet()
        return fleet_closed_loop(self.law(), ref, cfg.vehicle if plant is None else plant, cfg.n)

    def mission_fleet(self) -> FleetReference:
        """Raw mission reference: formation offsets (in their frame) around the mission path, no shaping."""
        return raw_fleet(self.config)

    def summary(self) -> str:
        """Readable table (:func:`~auv_hinf.certificate.text.certificate_text`)."""
        return certificate_text(self.to_dict())


def load_certificate(path: str | Path) -> Certificate:
    """The certificate stored in ``path`` (any format version), without re-certifying.

    Parameters
    ----------
    path : str or Path
        A file written by :meth:`Certificate.save` (or by an earlier version).

    Raises
    ------
    ConfigError
        Not a certificate file, an unknown version, an invalid configuration, or an edited record.
    """
    return _rebuilt(*read_certificate(path), str(path))


def certificate_from_document(doc: Any, source: str = "certificate") -> Certificate:
    """The certificate of a parsed certificate file (any format version).

    Parameters
    ----------
    doc : Any
        The parsed JSON document.
    source : str
        The file's name, for the messages.

    Raises
    ------
    ConfigError
        As :func:`load_certificate`.
    """
    return _rebuilt(*record_from_document(doc, source), source)


def _rebuilt(config: FormationConfig, record: Mapping[str, Any], source: str) -> Certificate:
    """:meth:`Certificate.from_record`, its failures (values the types refuse) as one-line errors."""
    try:
        return Certificate.from_record(config, record)
    except (KeyError, TypeError, ValueError) as exc:
        raise ConfigError(f"{source}: cannot rebuild the certificate: {exc}") from None


def certify(
    config: FormationConfig, *, jacobi_samples: int = DEFAULT_JACOBI_SAMPLES, refine_jacobi: bool = False
) -> Certificate:
    """Certify the configured design: every registered part, on one design point.

    Parameters
    ----------
    config : FormationConfig
        The configuration.
    jacobi_samples : int
        Size of the Jacobi-coordinate search reported for the record.
    refine_jacobi : bool
        Tighten that bound by branch-and-bound (slow; the certificate itself uses vehicle
        coordinates).
    """
    jacobi_samples = require_count("jacobi_samples", jacobi_samples)
    if not isinstance(refine_jacobi, bool):
        raise ParameterError(f"refine_jacobi must be True or False, got {refine_jacobi!r}")
    point = design_point(config)
    options = {"jacobi_samples": jacobi_samples, "refine_jacobi": refine_jacobi}
    verdicts: dict[str, Verdict] = {}
    law = control_law(config.guidance is not None)
    for part in parts():
        by = superseded_by(part.name, verdicts)
        if law not in part_laws(part):
            # the part's law does not run; a part may say what covers its concern instead
            note = getattr(part, "idle_notes", {}).get(law, LAW_IDLE[law])
            verdict = Verdict(part.name, True, False, note=note)
        elif by is not None:
            figures = superseded_figures(by, part.name, verdicts[by].figures)
            note = f"superseded: the {by} certificate covers the deployed loop"
            verdict = Verdict(part.name, True, False, figures=figures, note=note)
        else:
            verdict = part.evaluate(PartContext(point, dict(verdicts), options))
            # advice that leaves the configured run outside what it declares gets the run's values too
            verdict = replace(
                verdict,
                reasons=tuple(run_kept_inside(config, r) for r in verdict.reasons),
                figures=figures_kept_inside(config, verdict.figures),
            )
        verdicts[part.name] = replace(verdict, part=part.name, key=part.key)
        verdicts = waived(verdicts, keep=_force_bounding(config))  # before the later parts read the verdicts
    binding = next((v.binding for v in reversed(list(verdicts.values())) if v.binding is not None), None)
    design = {**point.summary(), "binding": binding}
    return Certificate(config, tuple(verdicts.values()), point.gains, point.source, design)


def _force_bounding(config: FormationConfig) -> tuple[str, ...]:
    """The superseding parts that cannot be waived: with declared actuators and a sampled formation
    law, only the composed certificate bounds the force the actuators are checked against."""
    sampled = config.implementation.sampled and config.guidance is None
    return ("composed",) if sampled and config.actuators is not None else ()


def waived(verdicts: Mapping[str, Verdict], keep: tuple[str, ...] = ()) -> dict[str, Verdict]:
    """The verdicts, with a failing superseding part waived when the parts it would supersede all hold.

    Two routes certify a deployed loop: the superseding part, or the parts it supersedes
    together. When the first fails and the second holds (every one of those parts holds, and one
    of them applies), the fleet is certified by the second, and the first is marked as not
    needed (it does not apply; its figures and the reasons it would give are kept in its figures).
    A part of ``keep`` is never waived: the second route bounds the errors but not what only the
    first bounds (a sampled law's force, which the actuators need), so its refusal and its advice stay.

    Parameters
    ----------
    verdicts : mapping of str to Verdict
        Every part's verdict, by name.
    keep : tuple of str
        Superseding parts that are not waived.
    """
    out = dict(verdicts)
    for name, v in verdicts.items():
        names = part_supersedes(name)
        if name in keep or not names or not all(a in verdicts for a in names):
            continue  # not a superseding part, or the other route is not evaluated yet
        alternatives = [verdicts[a] for a in names]
        if v.applies and not v.ok and all(a.ok for a in alternatives) and any(a.applies for a in alternatives):
            note = f"not needed: {', '.join(a.part for a in alternatives if a.applies)} certify the deployed loop"
            out[name] = replace(v, ok=True, applies=False, reasons=(), note=note)
    return out


__all__ = [
    "Certificate",
    "certificate_from_document",
    "certify",
    "load_certificate",
    "waived",
]
