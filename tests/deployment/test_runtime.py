"""The law as it runs: the runtime law, the discrete-time controller and the certificate's assumptions."""

from __future__ import annotations

from dataclasses import replace
from functools import cache

import control as ct
import numpy as np
import pytest

from auv_hinf.certificate.assembly import Certificate, certify
from auv_hinf.certificate.run_plan import plan_run
from auv_hinf.config.settings import config_from_dict
from auv_hinf.deployment.runtime import Assumptions, RuntimeLaw
from auv_hinf.implementation.sampled_loop import integrate_sampled
from auv_hinf.simulation.scenario import ScenarioBatch
from tests.helpers import BLUEROV_10HZ

#: Agreement asked of the runtime law and the simulation on the same measurements (N): both evaluate
#: the same expressions on the same numbers, so they differ by round-off (about 1e-14 N here).
AGREEMENT = 1e-9


def _config(**implementation: object) -> dict:
    impl = {**BLUEROV_10HZ["implementation"], **implementation}
    # off the slots by up to 0.3 m and 0.1 rad, so that the feedback works; the raw ("paper") start
    initial = [[0.3, -6.0, 0.1, 0.05, 0.0, 0.0], [0.0, -1.8, -0.05, 0.0, 0.0, 0.0], [-0.2, 2.0, 0.0, 0.1, 0.0, 0.0]]
    initial.append([0.1, 6.2, 0.08, 0.05, 0.02, 0.0])
    sim = {"horizon": 4.0, "start": "paper", "initial": initial, "seed": 3}
    return {**BLUEROV_10HZ, "simulation": sim, "implementation": impl}


@cache
def _certificate() -> Certificate:
    return certify(config_from_dict(BLUEROV_10HZ))


@cache
def _sampled_run_of(key: tuple[float, bool]) -> tuple[RuntimeLaw, np.ndarray, np.ndarray, object]:
    return _sampled_run(_config(delay=key[0], varying_delay=key[1]))


def _sampled_run(cfg_dict: dict) -> tuple[RuntimeLaw, np.ndarray, np.ndarray, object]:
    """A sampled run with its trace, and the measured states at the sample instants."""
    cfg = config_from_dict(cfg_dict)
    plan = plan_run(cfg, samples=81)  # output every 0.05 s: every measurement instant is an output time
    scn = plan.scenario
    sol = integrate_sampled(ScenarioBatch((scn,)), trace=True)
    assert sol.trace is not None and sol.y is not None
    at = sol.trace.measured_at[0]  # (K,)
    idx = np.array([int(np.argmin(np.abs(sol.t - s))) for s in at])
    assert np.allclose(sol.t[idx], at, atol=1e-12), "a measurement instant is not an output time"
    true = sol.y[idx, 0].reshape(len(at), cfg.n, 6)
    measured = true + sol.trace.noise[0]
    law = RuntimeLaw.from_certificate(replace(_certificate(), config=cfg), reference=scn.reference)
    return law, at, measured, sol.trace


@pytest.mark.slow
def test_runtime_law_and_simulate_agree_sample_by_sample():
    law, at, measured, trace = _sampled_run_of((0.05, False))
    assert np.ptp(trace.commanded[0]) > 1.0, "the run must exercise the feedback"
    commanded = np.stack([law.commanded(t, m) for t, m in zip(at, measured)])
    forces = np.stack([law.step(t, m) for t, m in zip(at, measured)])
    assert np.max(np.abs(commanded - trace.commanded[0])) <= AGREEMENT
    assert np.max(np.abs(forces - trace.forces[0])) <= AGREEMENT
    # the delay is the physical one: a measurement taken at t_k - 0.05 s is stepped at that instant
    assert np.allclose(at[1:], trace.times[1:] - 0.05)


@pytest.mark.slow
def test_each_vehicle_is_stepped_at_its_own_measurement_time():
    law, at, measured, trace = _sampled_run_of((0.05, False))
    n = measured.shape[1]
    # one time per vehicle, all equal: the simulation's forces again
    same = np.stack([law.step(np.full(n, t), m) for t, m in zip(at, measured)])
    assert np.max(np.abs(same - trace.forces[0])) <= AGREEMENT
    # different times: vehicle i's forces are those of its own time
    times, m = at[10] + 0.01 * np.arange(n), measured[10]
    mixed = law.step(times, m)
    for i in range(n):
        assert np.allclose(mixed[i], law.step(times[i], m)[i], rtol=0.0, atol=AGREEMENT)


@pytest.mark.slow
def test_controller_is_discrete_with_the_delay_as_a_shift():
    cert = _certificate()
    ctrl = cert.controller()
    assert ctrl.dt == pytest.approx(0.1) and ctrl.nstates == 0  # 50 ms < one sample: no whole-sample shift
    cfg = config_from_dict(_config(delay=0.2, varying_delay=True))
    delayed = replace(cert, config=cfg).controller()
    assert delayed.dt == pytest.approx(0.1) and delayed.nstates == 2 * 6 * cfg.n
    continuous = replace(cert, config=config_from_dict({**BLUEROV_10HZ, "implementation": {}})).controller()
    assert continuous.dt == 0


@pytest.mark.slow
def test_discrete_controller_matches_the_runtime_law():
    law, _, measured, _ = _sampled_run(_config(delay=0.2, varying_delay=False))
    cfg = config_from_dict(_config(delay=0.2, varying_delay=False))
    ctrl = replace(_certificate(), config=cfg).controller(reference=law.reference)
    k = measured.shape[0]
    # the inputs are the states at the sample instants; the system delays them by m = 2 samples
    inputs = measured.reshape(k, -1)
    x0 = np.tile(inputs[0], 2)
    resp = ct.input_output_response(ctrl, T=np.arange(k) * 0.1, U=inputs.T, X0=x0)
    outputs = np.asarray(resp.outputs).T.reshape(k, cfg.n, 3)
    want = np.stack([law.step(max((j - 2) * 0.1, 0.0), inputs[max(j - 2, 0)].reshape(cfg.n, 6)) for j in range(k)])
    assert np.max(np.abs(outputs - want)) <= AGREEMENT


@pytest.mark.slow
def test_assumptions_come_from_the_certificate():
    cert = _certificate()
    a = Assumptions.from_certificate(cert)
    # the deployed loop's certificate: the composed one when it covers, else the implementation one
    source = "composed" if cert.verdict("composed").applies else "implementation"
    fig = cert.verdict(source).figures
    assert cert.certified and a.certified
    assert (a.sample_time, a.delay, a.varying_delay) == (0.1, 0.05, True)
    assert a.invariant_source == source and a.error_bounds is not None
    assert a.error_bounds.to_dict() == fig["error_bounds"]
    assert a.force_limits == cert.config.actuators.limits()
    assert a.current_bound == 0.0 and a.noise.position == 0.01 and a.max_lag == pytest.approx(0.15)
    assert Assumptions.from_dict(a.to_dict()) == a
    # read back from its file, the certificate gives the same assumptions
    loaded = Certificate.from_record(cert.config, cert.to_dict())
    assert Assumptions.from_certificate(loaded) == a


@pytest.mark.slow
def test_without_an_implementation_the_invariant_is_the_closed_loop_region():
    cfg = config_from_dict({**BLUEROV_10HZ, "implementation": {}})
    cert = certify(cfg)
    a = Assumptions.from_certificate(cert)
    region = cert.verdict("closed_loop").figures["region_error_bounds"]
    assert a.sample_time == 0.0 and a.invariant_source == "closed_loop"
    assert a.error_bounds is not None and a.error_bounds.position == region["position_error"]
