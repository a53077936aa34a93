"""Gains designed for the deployed loop: a search over a verified certificate.

The composed certificate is not convex in the gains, so the synthesis is an outer search
(:func:`synthesise_deployed`): every candidate of a fixed grid (:data:`POSITION_GRID`,
:data:`HEADING_GRID`) is certified with :func:`~auv_hinf.composed.certificate.certify_deployed`
for the declared box, current, sample time, delay and noise, and the candidate kept is the one
with the smallest certified position bound whose certified force the actuators can deliver
(without limits: the smallest position bound). The grid does not depend on the configuration,
so the same inputs always give the same gains, and a setting shrunk by the advice
(:mod:`auv_hinf.composed.advice`) is searched over the same candidates.

The search is in two stages, as the loops are weakly coupled: the heading gains with the middle
position gains first (with the other position gains in turn when none covers), then the position
gains with the heading gains found. It states its
objective and what binds (:class:`DeployedDesign`). When no candidate covers a declared box or
current, the same search runs on the declared implementation alone (still water, the model as the
plant): its gains run, and the advice then asks for the box and current they cover with the
sample time, delay and noise as declared (the hardware's), rather than for all of them shrunk.

The grid spans gentle gains that tolerate 0.1-0.2 s of lag (velocity gain 1.5 1/s, heading
natural frequency 1 rad/s) to the bandwidth the sampled loops of a 10 Hz law still follow.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace

from auv_hinf.composed.certificate import DeployedCertificate, DeployedProblem, certify_deployed
from auv_hinf.law.gains import Gains

#: Candidate ``(alpha (1/s), k1 (1/s^2))`` of the position loops: critically damped
#: (``k1 = alpha^2/4``) and overdamped (``k1 = alpha^2/8``) at three velocity gains.
POSITION_GRID: tuple[tuple[float, float], ...] = tuple((a, a * a * f) for a in (1.5, 2.5, 4.0) for f in (0.125, 0.25))
#: Candidate heading gains ``(k1_psi (1/s^2), k2_psi (1/s))``: natural frequency ``w`` (rad/s),
#: damping ratio 0.75. The grid reaches 3 rad/s: a BlueROV2 whose surge and sway masses are each
#: known to 10 % (so ``m22 - m11`` to about +-4 kg) in a 0.1 m/s cross current is turned 0.5-0.76 rad by
#: the Munk moment with heading poles near -1 1/s and held within 0.05 rad with poles at -2 and
#: -3 1/s (docs/derivations/composed.md, "How much of it is real").
HEADING_GRID: tuple[tuple[float, float], ...] = tuple((w * w, 1.5 * w) for w in (1.0, 1.5, 2.0, 2.5, 3.0))
#: The position gains the heading stage is searched with (the middle of :data:`POSITION_GRID`).
HEADING_STAGE_POSITION: tuple[float, float] = (2.5, 2.5 * 2.5 * 0.25)
#: What the search minimises.
OBJECTIVE = "the certified position bound (m) of the deployed loop, within the actuator limits"


@dataclass(frozen=True)
class DeployedDesign:
    """The chosen gains, their certificate, and why.

    Attributes
    ----------
    gains : Gains
        The chosen gains: the best covering candidate; when none covers, the best for the declared
        implementation in still water on the model (when a box or a current is declared and one
        covers that), else the middle candidate.
    certificate : DeployedCertificate
        Their composed certificate.
    value : float or None
        The objective at the chosen gains: the certified position bound (m); ``None`` when no
        candidate covers.
    binding : str
        What decides the choice, one line.
    tried : int
        Candidates certified.
    covered : int
        Candidates whose certificate covers.
    """

    gains: Gains
    certificate: DeployedCertificate
    value: float | None
    binding: str
    tried: int
    covered: int


def _score(cert: DeployedCertificate, fits: Callable[[tuple[float, float, float]], bool]) -> tuple[int, float]:
    """``(0, |e|)`` for a covering certificate whose force fits, ``(1, |e|)`` for one that does not fit."""
    assert cert.errors is not None and cert.force is not None
    return (0 if fits(cert.force.as_tuple()) else 1, cert.errors.position)


def synthesise_deployed(
    problem: DeployedProblem,
    fits: Callable[[tuple[float, float, float]], bool] | None = None,
    *,
    integral: float = 0.0,
    certify: Callable[[DeployedProblem], DeployedCertificate] = certify_deployed,
    position_grid: Sequence[tuple[float, float]] = POSITION_GRID,
    heading_grid: Sequence[tuple[float, float]] = HEADING_GRID,
    fallback: bool = True,
) -> DeployedDesign:
    """The grid's best gains for ``problem`` (see the module docstring).

    Parameters
    ----------
    problem : DeployedProblem
        The deployed problem; its ``gains`` are replaced by each candidate's.
    fits : callable, optional
        ``fits(peak)`` is true when the actuators can deliver every force of the box
        ``|tau| <= peak`` (N, N, N m); ``None``: no limits.
    integral : float
        The integral gain's ratio ``ki / (alpha k1)`` (0: no integral action).
    certify : callable
        The certificate (default :func:`~auv_hinf.composed.certificate.certify_deployed`).
    position_grid, heading_grid : sequence of (float, float)
        The candidates (default the module's grids).
    fallback : bool
        When no candidate covers, search the gains that hold the declared implementation in still
        water on the model (they run, and the advice shrinks the box and current for them);
        ``False``: the middle candidate runs (the answer of a caller that only asks whether some
        candidate covers: the design is the same whenever one does).
    """
    accept = fits or (lambda _peak: True)
    tried = covered = 0

    def gains(position: tuple[float, float], heading: tuple[float, float]) -> Gains:
        a, k1 = position
        return Gains(a, k1, heading, integral * a * k1)

    middle = (
        HEADING_STAGE_POSITION if HEADING_STAGE_POSITION in position_grid else position_grid[len(position_grid) // 2]
    )
    plant = problem.plant
    worlds = {"declared": problem}
    calm = replace(plant, box=plant.box.scaled(0.0), current=0.0, current_rate=0.0)
    if calm != plant:  # the declared implementation alone: still water, the model as the plant
        worlds["calm"] = replace(problem, plant=calm)
    done: dict[tuple[str, tuple[float, float], tuple[float, float]], DeployedCertificate] = {}

    def cert_of(world: str, position: tuple[float, float], heading: tuple[float, float]) -> DeployedCertificate:
        nonlocal tried, covered
        key = (world, position, heading)
        if key not in done:
            done[key] = certify(replace(worlds[world], gains=gains(position, heading)))
            tried += 1
            covered += int(done[key].covers and world == "declared")  # the declared world's only
        return done[key]

    def search(world: str) -> tuple[tuple[float, float], tuple[Gains, DeployedCertificate] | None]:
        """The heading gains chosen and the best covering candidate in ``world`` (``None``: none covers)."""
        # stage 1: the heading gains, with the middle position gains, then (when none covers) with the others
        heading = heading_grid[0]
        for position in (middle, *(p for p in position_grid if p != middle)):
            good = [(h, c) for h in heading_grid if (c := cert_of(world, position, h)).covers]
            if good:
                heading = min(good, key=lambda hc: _score(hc[1], accept))[0]
                break
        # stage 2: the position gains with those heading gains
        best: tuple[Gains, DeployedCertificate] | None = None
        for position in position_grid:
            cert = cert_of(world, position, heading)
            if cert.covers and (best is None or _score(cert, accept) < _score(best[1], accept)):
                best = (gains(position, heading), cert)
        return heading, best

    heading, best = search("declared")
    if best is None:
        if fallback and "calm" in worlds:  # gains that hold the hardware, whose certificate then says how much of
            # the box and current they cover (the advice shrinks only those, the hardware kept)
            _, held = search("calm")
            if held is not None:
                g = held[0]
                cert = cert_of("declared", (g.alpha, g.k1), g.k_psi)
                why = (
                    f"none of the candidate gains is certified for the deployed loop with the declared box and "
                    f"current ({tried} certificates in all): the gains with the smallest position bound for the "
                    "declared implementation in still water on the model run (the composed certificate says how much "
                    "of the box and current they cover)"
                )
                return DeployedDesign(g, cert, None, why, tried, covered)
        g, cert = gains(middle, heading), cert_of("declared", middle, heading)
        why = (
            f"none of the {tried} candidate gains is certified for the deployed loop: the middle candidate runs "
            "(the composed certificate says which setting would certify it)"
        )
        return DeployedDesign(g, cert, None, why, tried, covered)
    g, cert = best
    assert cert.errors is not None and cert.force is not None
    fit = accept(cert.force.as_tuple())
    binding = (
        f"the smallest certified position bound, {cert.errors.position:.3g} m, of {covered} covering candidates"
        if fit
        else "no covering candidate's certified force fits the actuators: the gains with the smallest position bound"
    )
    return DeployedDesign(g, cert, cert.errors.position, binding, tried, covered)


__all__ = [
    "HEADING_GRID",
    "HEADING_STAGE_POSITION",
    "OBJECTIVE",
    "POSITION_GRID",
    "DeployedDesign",
    "synthesise_deployed",
]
