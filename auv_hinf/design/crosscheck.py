"""Independent checks of the Theorem 1 and 2 designs: one report, four routes.

1. Riccati solvers on the full ``2N x 2N`` eq. (37) (:mod:`auv_hinf.design.riccati`);
2. LMIs in cvxpy solved by Clarabel (:mod:`auv_hinf.design.lmi`);
3. python-control ``StateSpace`` models of the per-block closed loops and their H-infinity
   norms from ``control.norm`` (:mod:`auv_hinf.design.blocks`);
4. the exact values ``1/(alpha - lam)`` of :mod:`auv_hinf.design.theorem1`.

Every comparison is relative to the compared quantity itself (never to an absolute floor
that could swamp it): alphas relative to alpha, norms relative to the norm, the BRL
synthesis on ``beta = alpha - lam`` relative to beta, the structure of the Riccati solution
relative to alpha. So a value 1 % off fails every check at every scale of lambda. Which
equivalent formulation each route used (Riccati regime, LMI normalisation, fallbacks) is
recorded in :attr:`CrosscheckReport.formulations`.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, replace
from typing import Any

from auv_hinf.design.blocks import NORM_RTOL, hinf_norm, position_block, velocity_block
from auv_hinf.design.brl import lmi_hinf_norm, lmi_minimal_alpha, lmi_stabilizing_alpha
from auv_hinf.design.riccati import ARE_RTOL, riccati_alpha, root_condition
from auv_hinf.design.theorem1 import alpha_minimal, alpha_paper, alpha_stabilizing, position_loop, theorem1_conditions
from auv_hinf.exceptions import DesignError, require_finite, require_fleet_size
from auv_hinf.law.gains import DEFAULT_K1
from auv_hinf.numerics.lmi import LMI_RTOL

#: Relative tolerance of ``max |L - alpha I|`` against alpha: the Riccati solvers return a
#: multiple of the identity up to round-off of a 2N x 2N Schur form (~1e-15 of alpha).
STRUCTURE_RTOL = ARE_RTOL

#: Relative tolerance of the Riccati-inequality LMI's ``max |L - alpha I|`` against alpha:
#: the LMI optimum is only accurate to the interior-point gap, like its alpha.
LMI_STRUCTURE_RTOL = LMI_RTOL


def _rel(a: float, b: float, scale: float) -> float:
    """``|a - b| / max(|b|, scale)``: relative to the reference, or to ``scale`` if it is 0."""
    denom = max(abs(b), scale)
    if denom == 0.0:
        return 0.0 if a == b else math.inf
    return abs(a - b) / denom


@dataclass(frozen=True)
class Check:
    """One comparison: ``value`` against ``reference`` with relative tolerance ``tol``.

    ``rel_diff = |value - reference| / max(|reference|, scale)``. ``scale`` is 0 for every
    check whose reference is a positive quantity (alpha, beta, a norm), so the comparison is
    relative to the compared quantity itself; it is the size of L (alpha) for the checks
    whose reference is exactly 0 (``max |L - alpha I|``).

    Attributes
    ----------
    name : str
        What is compared, in words.
    value : float
        The value of the route checked.
    reference : float
        The value it is compared with, in the same unit.
    rel_diff : float
        ``|value - reference| / max(|reference|, scale)``.
    tol : float
        Relative tolerance.
    scale : float
        Floor of the denominator (0: relative to the reference alone).
    """

    name: str
    value: float
    reference: float
    rel_diff: float
    tol: float
    scale: float = 0.0

    @property
    def ok(self) -> bool:
        """True when ``rel_diff <= tol``."""
        return self.rel_diff <= self.tol

    def with_value(self, value: float) -> Check:
        """The same comparison for another ``value`` (to test that a wrong value fails).

        Parameters
        ----------
        value : float
            The new compared value, in the unit of ``reference``; ``rel_diff`` is recomputed.
        """
        return replace(self, value=value, rel_diff=_rel(value, self.reference, self.scale))


@dataclass(frozen=True)
class CrosscheckReport:
    """Every alpha and norm for one ``(lam, gamma, n, k1)``, with the comparisons.

    ``alpha_*`` are in 1/s, norms in s. ``alpha_paper`` is ``None`` when gamma is below
    ``1/sqrt(lam^2+2)`` (then so are the stabilising and Riccati values). ``formulations``
    maps each numerical route to the equivalent formulation it used (e.g. the Riccati regime
    ``"double-root"`` solved by its closed form, the LMI normalisation, a modal fallback).

    Attributes
    ----------
    lam : float
        Nominal value lambda (1/s).
    gamma : float
        Requested H-infinity bound (s).
    n : int
        Number of vehicles; the Riccati problems have size ``2n``, the LMIs one vehicle's block
        (:func:`~auv_hinf.design.brl.vehicle_block`).
    k1 : float
        Theorem 2 position gain (1/s^2).
    conditions : dict
        The hypotheses of Theorem 1 (:meth:`~auv_hinf.design.theorem1.Theorem1Conditions.to_dict`).
    alpha_paper, alpha_stabilizing : float or None
        Eq. (32) as printed and the stabilising root of eq. (37), closed forms.
    alpha_minimal : float
        Smallest alpha with ``||T||_inf <= gamma``, closed form.
    alpha_care, alpha_scipy_care : float or None
        Eq. (37) solved at full size with python-control and with scipy
        (:func:`~auv_hinf.design.riccati.riccati_alpha`).
    alpha_lmi : float or None
        The Riccati-inequality LMI (:func:`~auv_hinf.design.brl.lmi_stabilizing_alpha`).
    alpha_lmi_minimal : float
        The BRL bisection (:func:`~auv_hinf.design.brl.lmi_minimal_alpha`).
    paper_flags : tuple of str
        Flags of eq. (32), or why it is infeasible.
    riccati_regime : str or None
        Regime of eq. (37) the Riccati solvers ran in.
    hinf_exact : float or None
        ``1/(alpha - lam)`` of the velocity loop at the stabilising alpha (s).
    hinf_python_control, hinf_lmi : float or None
        The same norm from ``control.norm`` and from the bounded-real LMI (s).
    position_hinf_exact, position_hinf_python_control : float or None
        Norm of the Theorem 2 position loop at the stabilising alpha and ``k1``, exact and from
        ``control.norm`` (s).
    checks : tuple of Check
        The comparisons.
    formulations : dict of str to str
        The formulation each numerical route used.
    """

    lam: float
    gamma: float
    n: int
    k1: float
    conditions: dict[str, Any]
    alpha_paper: float | None
    alpha_stabilizing: float | None
    alpha_minimal: float
    alpha_care: float | None
    alpha_scipy_care: float | None
    alpha_lmi: float | None
    alpha_lmi_minimal: float
    paper_flags: tuple[str, ...]
    riccati_regime: str | None
    hinf_exact: float | None
    hinf_python_control: float | None
    hinf_lmi: float | None
    position_hinf_exact: float | None
    position_hinf_python_control: float | None
    checks: tuple[Check, ...] = field(default_factory=tuple)
    formulations: dict[str, str] = field(default_factory=dict)

    @property
    def max_rel_diff(self) -> float:
        """Largest relative disagreement over all checks."""
        return max((c.rel_diff for c in self.checks), default=0.0)

    @property
    def ok(self) -> bool:
        """True when every check is inside its tolerance."""
        return all(c.ok for c in self.checks)

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe dictionary in the layout of ``auv-hinf design --json``."""
        return {
            "lambda": self.lam,
            "gamma": self.gamma,
            "n": self.n,
            "k1": self.k1,
            "conditions": self.conditions,
            "alpha": {
                "paper": self.alpha_paper,
                "stabilizing": self.alpha_stabilizing,
                "minimal": self.alpha_minimal,
                "care": self.alpha_care,
                "scipy_care": self.alpha_scipy_care,
                "lmi": self.alpha_lmi,
                "lmi_minimal": self.alpha_lmi_minimal,
            },
            "riccati_regime": self.riccati_regime,
            "paper_flags": list(self.paper_flags),
            "closed_loop_hinf": {
                "exact": self.hinf_exact,
                "python_control": self.hinf_python_control,
                "lmi": self.hinf_lmi,
            },
            "position_loop_hinf": self.position_hinf_exact,
            "position_loop_hinf_python_control": self.position_hinf_python_control,
            "checks": [dict(asdict(c), ok=c.ok) for c in self.checks],
            "formulations": dict(self.formulations),
            "max_rel_diff": self.max_rel_diff,
            "crosscheck_ok": self.ok,
        }


def crosscheck(lam: float, gamma: float, n: int = 3, k1: float = DEFAULT_K1) -> CrosscheckReport:
    """Compute every alpha and closed-loop norm four ways and compare them.

    Parameters
    ----------
    lam : float
        Nominal value lambda < 0 (1/s).
    gamma : float
        Requested bound (> 0).
    n : int
        Number of vehicles; Riccati and LMI problems are solved at full size ``2n``.
    k1 : float
        Theorem 2 position gain (> 0, 1/s^2).

    Returns
    -------
    CrosscheckReport
        With per-check relative tolerances :data:`ARE_RTOL`, :data:`STRUCTURE_RTOL`,
        :data:`LMI_RTOL`, :data:`LMI_STRUCTURE_RTOL` and :data:`NORM_RTOL` (the Riccati ones
        multiplied by :func:`auv_hinf.design.riccati.root_condition` near gamma_min).

    Raises
    ------
    DesignError
        For invalid inputs.
    SolverError
        If a numerical route fails in every formulation it has.
    """
    cond = theorem1_conditions(lam, gamma)
    if not cond.lam_negative:
        raise DesignError(
            f"lambda = {abs(lam) if lam == 0.0 else lam:.4g} 1/s must be < 0: Theorem 1 needs a dissipative nominal "
            "block, and this vehicle has no damping over the envelope (declare its [vehicle] linear or quadratic "
            "damping: d11_lin, d11_quad, ...)"
        )
    n = require_fleet_size(n)
    if require_finite("k1", k1) <= 0:
        raise DesignError(f"k1 must be > 0, got {k1!r}")
    checks: list[Check] = []
    formulations: dict[str, str] = {}

    def add(name: str, value: float, reference: float, tol: float, scale: float = 0.0) -> None:
        checks.append(Check(name, value, reference, _rel(value, reference, scale), tol, scale))

    minimal = alpha_minimal(lam, gamma)
    lmi_min = lmi_minimal_alpha(lam, gamma, n)
    formulations["lmi_minimal"] = lmi_min.formulation
    # The BRL bisection pins down beta = alpha - lam > 0 (the loop's pole), so compare on it,
    # relative to beta itself.
    add("BRL-synthesis alpha - lam vs closed form", lmi_min.value - lam, minimal.alpha - lam, LMI_RTOL)

    paper = stab = None
    care_r = scipy_r = None
    lmi_stab = None
    hinf_pc = hinf_lmi = pos_exact = pos_pc = None
    if cond.gamma_ok:
        paper = alpha_paper(lam, gamma)
        stab = alpha_stabilizing(lam, gamma)
        care_r = riccati_alpha(lam, gamma, n, solver="control")
        scipy_r = riccati_alpha(lam, gamma, n, solver="scipy")
        lmi_stab = lmi_stabilizing_alpha(lam, gamma, n)
        formulations["riccati"] = f"{care_r.regime}: {care_r.solver}, {scipy_r.solver}"
        formulations["lmi_stabilizing"] = lmi_stab.formulation
        cond_factor = root_condition(lam, gamma)
        are_tol = ARE_RTOL * cond_factor
        # alpha > 0 always (1/(|lam| + s)): compared relative to alpha itself.
        add("control.care alpha vs stabilizing", care_r.alpha, stab.alpha, are_tol)
        add("scipy care alpha vs stabilizing", scipy_r.alpha, stab.alpha, are_tol)
        add("control.care max |L - alpha I| / alpha", care_r.structure_error, 0.0, STRUCTURE_RTOL, stab.alpha)
        add("Riccati-inequality LMI alpha vs stabilizing", lmi_stab.value, stab.alpha, LMI_RTOL * cond_factor)
        add(
            "Riccati-inequality LMI max |L - alpha I| / alpha",
            lmi_stab.structure_error,
            0.0,
            LMI_STRUCTURE_RTOL * cond_factor,
            stab.alpha,
        )
        vel = velocity_block(lam, stab.alpha)
        hinf_pc = hinf_norm(vel)
        lmi_norm = lmi_hinf_norm(vel)
        hinf_lmi = lmi_norm.value
        formulations["lmi_hinf"] = lmi_norm.formulation
        add("python-control ||T|| vs 1/(alpha - lam)", hinf_pc, stab.closed_loop_hinf, NORM_RTOL)
        add("BRL LMI ||T|| vs 1/(alpha - lam)", hinf_lmi, stab.closed_loop_hinf, LMI_RTOL)
        pos = position_loop(lam, stab.alpha, k1)
        pos_exact = pos.hinf
        pos_pc = hinf_norm(position_block(lam, stab.alpha, k1))
        add("python-control position loop vs 1/(alpha - lam)", pos_pc, pos.hinf, NORM_RTOL)

    return CrosscheckReport(
        lam=float(lam),
        gamma=float(gamma),
        n=n,
        k1=float(k1),
        conditions=cond.to_dict(),
        alpha_paper=None if paper is None else paper.alpha,
        alpha_stabilizing=None if stab is None else stab.alpha,
        alpha_minimal=minimal.alpha,
        alpha_care=None if care_r is None else care_r.alpha,
        alpha_scipy_care=None if scipy_r is None else scipy_r.alpha,
        alpha_lmi=None if lmi_stab is None else lmi_stab.value,
        alpha_lmi_minimal=lmi_min.value,
        paper_flags=(
            (
                "infeasible: gamma below 1/sqrt(lambda^2+2); eq. (32) and the stabilising root do not exist, "
                "only the minimal gain",
            )
            if paper is None
            else paper.flags
        ),
        riccati_regime=None if care_r is None else care_r.regime,
        hinf_exact=None if stab is None else stab.closed_loop_hinf,
        hinf_python_control=hinf_pc,
        hinf_lmi=hinf_lmi,
        position_hinf_exact=pos_exact,
        position_hinf_python_control=pos_pc,
        checks=tuple(checks),
        formulations=formulations,
    )


__all__ = ["LMI_STRUCTURE_RTOL", "STRUCTURE_RTOL", "Check", "CrosscheckReport", "crosscheck"]
