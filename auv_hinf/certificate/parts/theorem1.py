"""The Theorem 1 part: the paper's small-gain certificate of the design point and its cross-checks.

It reports lambda, the certified sigma (vehicle coordinates, used; Jacobi coordinates, for the
record), gamma, the three Theorem 1 gains, the hypotheses of Theorem 1, the small-gain margin
``(alpha - lam) - sigma_upper``, the Theorem 2 loop norm and the four-way cross-check of the
gain. Its figures are top-level keys of ``certify --json`` (``lambda``, ``sigma``, ``alpha``,
``small_gain_margin``, ``crosscheck_ok``, ...).

With ``[design] robust = true`` the gains that run come from the robust design; the part then
holds unless the cross-check disagrees, and the robust part is the verdict on the gains.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import Any

from auv_hinf.certificate.part import FORMATION_LAW, ControlLaw, PartContext, RunCheck, RunContext, Verdict
from auv_hinf.certificate.reason import Reason, Setting
from auv_hinf.design.crosscheck import CrosscheckReport, crosscheck
from auv_hinf.design.jacobi_sigma import jacobi_sigma_bounds
from auv_hinf.design.sigma import SigmaBounds
from auv_hinf.design.theorem1 import GainDesign, Theorem1Conditions, position_loop, theorem1_conditions
from auv_hinf.law.gains import Gains
from auv_hinf.numerics.digits import ADVISED_DIGITS, significant

#: Fleet size at which the certificate runs its full-size cross-check. With
#: ``A_lam = lam I`` every 2x2 channel is identical, so a larger problem checks nothing
#: new; the LMI compile time grows quickly with N (25 s at N = 20), so larger fleets are
#: checked at this size. Full-size checks up to N = 20 are in the tests and benchmarks.
CROSSCHECK_MAX_N = 6

#: Above this fleet size the Jacobi-coordinate search (matrix-free, O(N) per sample, about
#: 15-30 us per vehicle and sample) is cut to ``JACOBI_SEARCH_WORK // N`` samples, at least
#: :data:`LARGE_FLEET_JACOBI_SAMPLES`: about one second whatever N. Its upper bound
#: (cond(Phi) * sigma, closed form) is unaffected, only the witnessed lower bound gets coarser.
JACOBI_SEARCH_MAX_N = 12
JACOBI_SEARCH_WORK = 40_000
LARGE_FLEET_JACOBI_SAMPLES = 4
#: Samples of the Jacobi-coordinate search of a small fleet (``certify(jacobi_samples=...)``).
DEFAULT_JACOBI_SAMPLES = 5000

#: The small-gain margin ``(alpha - lam) - sigma_upper`` (1/s) must exceed
#: ``MARGIN_RTOL * (|lam| + sigma_upper)`` to certify: the margin is a difference of
#: quantities of that size, each known to ~1e-15 relative, so 1e-9 of the scale is far above
#: round-off and far below any margin a design would rely on. A margin at or below it is
#: "not certified (marginal)", decided by this rule and never by rounding. In particular
#: method "minimal" with the default gamma = 1/sigma_upper and alpha = 1/gamma + lam > 0 has
#: margin 0 in exact arithmetic (alpha - lam = 1/gamma = sigma_upper) and is always reported
#: marginal; when the clamp alpha = 0 is active the margin is |lam| - sigma_upper, a real one.
MARGIN_RTOL = 1e-9
#: The ``[design] gamma`` suggested when the margin is marginal: this fraction of ``1/sigma_upper``
#: (the small-gain margin is then ``(1/0.99 - 1) sigma_upper``, far above the tolerance).
GAMMA_ADVICE_SHARE = 0.99


def advised_gamma(sigma_upper: float) -> float:
    """The ``[design] gamma`` (s) advised below ``1/sigma_upper``: :data:`GAMMA_ADVICE_SHARE` of it, rounded down.

    It keeps :data:`~auv_hinf.numerics.digits.ADVISED_DIGITS` significant digits, rounded further below, so its
    margin only grows.

    Parameters
    ----------
    sigma_upper : float
        The upper bound of sigma over the envelope (1/s).
    """
    return significant(GAMMA_ADVICE_SHARE / sigma_upper, ADVISED_DIGITS, up=False)


def _minimal_answer(reason: Reason, gamma: float, sigma_upper: float) -> Reason:
    """``reason`` (eq. (37) has no real root at ``gamma``) with the values that certify the small gain.

    The minimal gain ``alpha = max(0, 1/gamma + lam)`` has no Theorem 1 bound on ``gamma``, and for
    ``gamma < 1/sigma_upper`` its small-gain margin is positive: ``1/gamma - sigma_upper``, or
    ``|lam| - sigma_upper >= 1/gamma - sigma_upper`` when the clamp is active. A ``gamma`` that is not
    below :data:`GAMMA_ADVICE_SHARE` of ``1/sigma_upper`` is advised down to it (margin
    ``(1/0.99 - 1) sigma_upper``, far above :data:`MARGIN_RTOL`).
    """
    fix: tuple[Setting, ...] = (Setting("design", "method", "minimal"),)
    if gamma >= GAMMA_ADVICE_SHARE / sigma_upper:
        fix += (Setting("design", "gamma", advised_gamma(sigma_upper)),)
    words = ", ".join(f.toml() for f in fix)
    return replace(reason, message=f"{reason.message} ({words} certifies the small gain)", settings=fix)


@dataclass(frozen=True)
class Theorem1Result:
    """The typed result of the Theorem 1 part.

    Attributes
    ----------
    lam : float
        Constant lambda (1/s).
    sigma : SigmaBounds
        Vehicle-coordinate bounds, used by the small-gain test: the nominal loop
        ``(lam - alpha) I`` is the same in every coordinate system (``docs/derivations/sigma.md``).
    sigma_jacobi : SigmaBounds
        Jacobi-coordinate bounds, reported for comparison.
    gamma : float
        ``1/sigma.upper`` unless configured (s).
    theorem1 : Theorem1Conditions
        The hypotheses of Theorem 1 at ``(lam, gamma)``.
    designs : dict
        ``GainDesign`` per method, or ``None`` where the method is infeasible.
    alpha_used : float or None
        Gain of the configured method (1/s).
    small_gain_margin : float or None
        ``(alpha - lam) - sigma.upper`` (1/s): the small-gain margin, must be > 0. It is the
        decay rate of the velocity loop alone (``k1 = 0``), not of the full loop.
    position_loop_hinf : float or None
        Theorem 2 loop norm ``1/(alpha - lam)`` (s) for ``k1``.
    crosscheck : CrosscheckReport
    """

    lam: float
    sigma: SigmaBounds
    sigma_jacobi: SigmaBounds
    gamma: float
    theorem1: Theorem1Conditions
    designs: dict[str, GainDesign | None]
    alpha_used: float | None
    small_gain_margin: float | None
    position_loop_hinf: float | None
    crosscheck: CrosscheckReport


def figures(result: Theorem1Result, method: str, k1: float, jacobi: str, gamma_configured: bool) -> dict[str, Any]:
    """The part's top-level keys of ``certify --json``.

    Parameters
    ----------
    result : Theorem1Result
        The part's typed result.
    method : str
        The configured gain method.
    k1 : float
        Position gain (1/s^2).
    jacobi : str
        The Jacobi convention (``"paper"`` or ``"orthonormal"``).
    gamma_configured : bool
        Whether gamma was configured (else ``1/sigma``).
    """
    paper = result.designs.get("paper")
    return {
        "lambda": result.lam,
        "sigma": {
            "upper": result.sigma.upper,
            "lower": result.sigma.lower,
            "coords": "vehicle",
            "method": result.sigma.method,
            "witness": result.sigma.witness.to_dict(),
        },
        "sigma_jacobi": {
            "upper": result.sigma_jacobi.upper,
            "lower": result.sigma_jacobi.lower,
            "method": result.sigma_jacobi.method,
            "jacobi": jacobi,
        },
        "certificate_coords": "vehicle",
        "gamma": result.gamma,
        "gamma_configured": gamma_configured,
        "method": method,
        "alpha": {
            **{m: (None if d is None else d.alpha) for m, d in result.designs.items()},
            "used": result.alpha_used,
        },
        "alpha_flags": {m: [] if d is None else list(d.flags) for m, d in result.designs.items()},
        "paper_flags": [] if paper is None else list(paper.flags),
        # the paper's hypotheses on gamma and lambda; the minimal gain solves no eq. (37) and needs none of them
        "theorem1": {**result.theorem1.to_dict(), "required": method != "minimal"},
        "small_gain_margin": result.small_gain_margin,
        "k1": k1,
        "position_loop_hinf": result.position_loop_hinf,
        "crosscheck_ok": result.crosscheck.ok,
        "crosscheck_n": result.crosscheck.n,
        "crosscheck_max_rel_diff": result.crosscheck.max_rel_diff,
    }


@dataclass(frozen=True)
class Theorem1Part:
    """The paper's certificate: small gain over the envelope (see the module docstring).

    Attributes
    ----------
    name : str
        The registry name.
    key : str or None
        The JSON key of the figures (``None``: they are top-level keys).
    laws : tuple of str
        The laws it judges: the fully actuated formation law only.
    """

    name: str = "theorem1"
    key: str | None = None
    laws: tuple[ControlLaw, ...] = FORMATION_LAW

    def evaluate(self, ctx: PartContext) -> Verdict:
        """Lambda, sigma, the three gains, the small-gain margin and the cross-checks of ``ctx.point``.

        Parameters
        ----------
        ctx : PartContext
            The design point and the options (``jacobi_samples``, ``refine_jacobi``).
        """
        point = ctx.point
        config = point.config
        lam, sig, gamma = point.lam, point.sigma, point.gamma
        samples = int(ctx.options.get("jacobi_samples", DEFAULT_JACOBI_SAMPLES))
        if config.n > JACOBI_SEARCH_MAX_N:
            samples = min(samples, max(LARGE_FLEET_JACOBI_SAMPLES, JACOBI_SEARCH_WORK // config.n))
        sig_j = jacobi_sigma_bounds(
            config.vehicle,
            config.envelope,
            lam,
            config.transform,
            samples=samples,
            refine_jacobi=bool(ctx.options.get("refine_jacobi", False)),
            progress=True,  # the bar appears only after jacobi_sigma.PROGRESS_DELAY
        )
        cond = theorem1_conditions(lam, gamma)
        used = point.designs.get(config.method)
        alpha = None if used is None else used.alpha
        reasons = [] if used is not None else [r for r in point.reasons if r.part == self.name]
        if used is None and config.method != "minimal" and not cond.gamma_ok:
            reasons = [_minimal_answer(r, gamma, sig.upper) if r.kind == "design" else r for r in reasons]
        margin = pos = None
        if alpha is not None:
            margin = (alpha - lam) - sig.upper
            margin_tol = MARGIN_RTOL * (abs(lam) + sig.upper)
            advice = (Setting("design", "gamma", advised_gamma(sig.upper)),)
            if config.method == "minimal" and config.gamma is None and alpha > 0:
                reasons.append(
                    Reason(
                        self.name,
                        "marginal",
                        f"not certified (marginal): method 'minimal' with gamma = 1/sigma_upper has "
                        f"small-gain margin 0 by construction (computed {margin:.4g} 1/s); set "
                        f"design.gamma below 1/sigma ({advice[0].toml()} certifies it)",
                        channel="small_gain_margin",
                        value=margin,
                        limit=margin_tol,
                        settings=advice,
                    )
                )
            elif margin <= margin_tol:
                reasons.append(
                    Reason(
                        self.name,
                        "marginal",
                        f"not certified (marginal): small-gain margin (alpha - lambda) - sigma_upper = "
                        f"{margin:.4g} 1/s <= tolerance {margin_tol:.3g} 1/s: ||T||_inf * sigma must be < 1 "
                        "strictly (set design.gamma below 1/sigma)",
                        channel="small_gain_margin",
                        value=margin,
                        limit=margin_tol,
                        settings=advice,
                    )
                )
            if alpha > lam:
                pos = position_loop(lam, alpha, config.k1).hinf
        if config.method != "minimal" and not cond.all_ok:
            if cond.singular_case:
                reasons.append(Reason(self.name, "hypothesis", "Theorem 1 singular case |lambda| = 1/gamma - gamma"))
            if not cond.lam_negative:
                reasons.append(Reason(self.name, "hypothesis", f"lambda = {lam:.4g} is not negative", value=lam))
        report = crosscheck(lam, gamma, min(config.n, CROSSCHECK_MAX_N), config.k1)
        if not report.ok:
            reasons.append(
                Reason(
                    self.name,
                    "disagrees",
                    f"cross-check disagrees (max rel diff {report.max_rel_diff:.3g})",
                    value=report.max_rel_diff,
                )
            )
        if point.source != "theorem1":  # the robust design's gains run: only the cross-check is this part's verdict
            reasons = [r for r in reasons if r.kind == "disagrees"]
        result = Theorem1Result(lam, sig, sig_j, gamma, cond, point.designs, alpha, margin, pos, report)
        figs = figures(result, config.method, config.k1, config.jacobi, config.gamma is not None)
        return Verdict(self.name, not reasons, True, tuple(reasons), figs, detail=result)

    def lines(self, figures: Any, record: Mapping[str, Any]) -> list[str]:
        """Lambda, sigma, gamma, the gains of every method, the margin, the cross-check, the gains that run.

        Parameters
        ----------
        figures : Any
            The part's figures (:func:`figures`).
        record : mapping
            The whole certificate record (its ``gains``).
        """
        f = figures

        def fmt(x: float | None) -> str:
            return "n/a" if x is None else f"{x:.6g}"

        sig, sj = f["sigma"], f["sigma_jacobi"]
        gains = record.get("gains")
        robust = gains is not None and gains.get("source") == "robust"
        lines = [
            f"  lambda (envelope)         {fmt(f['lambda'])} 1/s",
            f"  sigma vehicle  [lo, up]   [{fmt(sig['lower'])}, {fmt(sig['upper'])}] 1/s  <- used",
            f"  sigma Jacobi   [lo, up]   [{fmt(sj['lower'])}, {fmt(sj['upper'])}] 1/s",
            f"  {'gamma (configured)' if f.get('gamma_configured') else 'gamma = 1/sigma':<26}"
            f"{fmt(f['gamma'])} s  (Theorem 1 minimum {fmt(f['theorem1']['gamma_min'])} s"
            + ("; the minimal gain does not need it)" if f["method"] == "minimal" else ")"),
        ]
        flags = f.get("alpha_flags") or {"paper": f.get("paper_flags", [])}
        for m, a in f["alpha"].items():
            if m == "used":
                continue
            mark = " <- used" if m == f["method"] and not robust else ""
            lines.append(f"  alpha[{m:<11}]        {fmt(a)}{'' if a is None else ' 1/s'}{mark}")
            if a is not None:
                lines.extend(f"      ! {flag}" for flag in flags.get(m, []))
        lines += [
            f"  small-gain margin         {fmt(f['small_gain_margin'])} 1/s",
            f"  position loop ||T||       {fmt(f['position_loop_hinf'])} s (Theorem 2, k1 = {f['k1']:g} 1/s^2)",
            f"  cross-check               {'ok' if f['crosscheck_ok'] else 'DISAGREES'} "
            f"(max rel {f['crosscheck_max_rel_diff']:.2g})",
            f"  gains that run            {'none' if gains is None else Gains.from_dict(gains).describe()}"
            f"{'  (robust design)' if robust else ''}",
        ]
        return lines

    def check_run(self, ctx: RunContext) -> RunCheck | None:
        """The paper's certificate says nothing about one run (the closed-loop part does).

        Parameters
        ----------
        ctx : RunContext
            The run (unused).
        """
        return None


__all__ = [
    "CROSSCHECK_MAX_N",
    "DEFAULT_JACOBI_SAMPLES",
    "GAMMA_ADVICE_SHARE",
    "JACOBI_SEARCH_MAX_N",
    "JACOBI_SEARCH_WORK",
    "LARGE_FLEET_JACOBI_SAMPLES",
    "MARGIN_RTOL",
    "Theorem1Part",
    "Theorem1Result",
    "advised_gamma",
    "figures",
]
