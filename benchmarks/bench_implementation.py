"""Table 9: the cost of the implementation (sampled-data) certificate.

Peers measured in the same run: the continuous closed-loop certificate of the same design
(what ``certify`` computed before ``[implementation]`` existed) and the exact discretisation scan
alone (python-control ``sample_system`` re-check included). The user's path is ``auv-hinf
certify`` on a TOML file with and without an ``[implementation]`` table (wall time of the whole
command, in a fresh process).

Run alone with ``python benchmarks/bench_implementation.py`` (rewrites only table 9 of RESULTS.md).
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

from pathlib import Path
from typing import Any

from common import REPEATS, cli_certify_seconds, median_seconds, table

from auv_hinf.certificate.design_point import design_point
from auv_hinf.certificate.parts.closed_loop import closed_loop_for
from auv_hinf.certificate.parts.implementation import implementation_problem, start_errors
from auv_hinf.config.presets import preset_config
from auv_hinf.config.settings import FormationConfig, config_from_dict
from auv_hinf.implementation.model import Implementation, MeasurementNoise
from auv_hinf.implementation.sampled_data import certify_implementation, lag_limits

#: A BlueROV2 Heavy line with gentle Theorem 1 gains: covered at 100 Hz with small noise.
BLUEROV_SLOW: dict[str, Any] = {
    "name": "bluerov2-slow",
    "vehicle": {"preset": "bluerov2-heavy"},
    "formation": {"n": 4, "shape": [[0.0, -4.0], [0.0, -6.0], [0.0, -8.0]]},
    "envelope": {"u": [-0.5, 1.0], "v": [-0.5, 0.5], "r": [-0.5, 0.5]},
    "design": {"method": "minimal", "gamma": 0.1, "k1": 0.5},
    "reference": {"kind": "sine", "speed": 0.4, "amplitude": 2.0, "omega": 0.05},
    "actuators": {"preset": "bluerov2-heavy"},
}
CASES = (
    (
        "paper-triangle",
        lambda: preset_config("paper-triangle").to_toml_dict(),
        Implementation(0.1, 0.1, noise=MeasurementNoise(0.05, 0.02, 0.01, 0.005)),
    ),
    (
        "bluerov2-slow",
        lambda: dict(BLUEROV_SLOW),
        Implementation(0.01, 0.0, noise=MeasurementNoise(1e-3, 1e-3, 1e-3, 1e-3)),
    ),
)


def implementation_cost() -> str:
    rows = []
    for name, make, impl in CASES:
        doc = make()
        cfg: FormationConfig = config_from_dict(doc)
        point = design_point(cfg)
        nominal = closed_loop_for(point)
        prob, start = implementation_problem(point, nominal), start_errors(point)
        t_cont = median_seconds(lambda point=point: closed_loop_for(point))
        t_exact = median_seconds(lambda prob=prob, impl=impl: lag_limits(prob.loops, prob.nominal_dampings, impl.delay))
        t_impl = median_seconds(lambda prob=prob, impl=impl, start=start: certify_implementation(prob, impl, start))
        cert = certify_implementation(prob, impl, start)
        t_cli0 = cli_certify_seconds(doc)
        t_cli1 = cli_certify_seconds({**doc, "implementation": impl.to_dict()})
        rows.append(
            [
                f"`{name}`",
                impl.describe().split(", noise")[0],
                f"{t_cont:.2f}",
                f"{t_exact:.2f}",
                f"{t_impl:.2f}",
                f"{t_impl / t_cont:.1f}",
                f"{t_cli0:.1f} / {t_cli1:.1f}",
                f"{cert.max_sample_time:.3g} / {cert.exact_max_sample_time:.3g}",
                "yes" if cert.covers else "no",
            ]
        )
    return _table(rows)


def _table(rows: list[list[str]]) -> str:
    header = [
        "design",
        "implementation",
        "continuous cert. [s]",
        "limits (LMI + c2d) [s]",
        "implementation cert. [s]",
        "ratio",
        "`certify` CLI without / with [s]",
        "max / exact sample time [s]",
        "covers",
    ]
    note = (
        "Medians of 3 runs, BLAS pinned to one thread. The implementation certificate includes the LMI "
        "limits (bisection on the Lyapunov-Krasovskii LMI), the exact nominal limit (closed-form scan, "
        "re-checked with python-control), two ISS certificates per route and the verified fixed point; "
        "the continuous certificate of the same design is the peer. The CLI column is the whole "
        "`certify` command; with an uncovered implementation it also searches the largest covered sample time."
    )
    return table(TITLE, header, rows, note)


TITLE = f"9. The implementation certificate: cost against the continuous certificate (medians of {REPEATS})"


def _rewrite_results(section: str) -> None:
    path = Path(__file__).with_name("RESULTS.md")
    text = path.read_text(encoding="utf-8")
    start = text.find("### 9.")
    if start < 0:
        text = text.rstrip("\n") + "\n\n" + section
    else:
        end = text.find("\n### ", start + 1)
        text = text[:start] + section + ("" if end < 0 else text[end + 1 :])
    path.write_text(text, encoding="utf-8")


if __name__ == "__main__":
    out = implementation_cost()
    print(out)
    _rewrite_results(out)
