"""certify judges the start in the mode simulate runs it: ``[simulation] start = "paper"`` is not the shaped start."""

from __future__ import annotations

import json
from dataclasses import replace

from auv_hinf.certificate.assembly import certify
from auv_hinf.cli.main import main
from auv_hinf.config.settings import config_from_dict
from tests.helpers import ROV_LIKE_VEHICLE, ROV_LINE_SHAPE, to_toml

# four BlueROV2-sized vehicles on a 0.4 m/s line; vehicle 1 starts 1 m ahead of its slot: from there
# the raw mission asks for more sway speed than the envelope allows, the blended one does not
TABLES = {
    "vehicle": ROV_LIKE_VEHICLE,
    "formation": {"n": 4, "shape": ROV_LINE_SHAPE},
    "envelope": {"u": [-0.5, 1.0], "v": [-0.5, 0.5], "r": [-0.5, 0.5]},
    "reference": {"kind": "line", "speed": 0.4},
    "simulation": {
        "horizon": 40.0,
        "start": "paper",
        "initial": [
            [1.0, -6.0, 0.0, 0.4, 0.0, 0.0],
            [0.0, -2.0, 0.0, 0.4, 0.0, 0.0],
            [0.0, 2.0, 0.0, 0.4, 0.0, 0.0],
            [0.0, 6.0, 0.0, 0.4, 0.0, 0.0],
        ],
    },
}


def test_a_raw_start_is_judged_raw_agrees_with_simulate_and_is_answered_with_the_shaped_start(tmp_path, capsys):
    cfg = config_from_dict(TABLES)
    cert = certify(cfg)
    loop = cert.to_dict()["closed_loop"]
    assert loop["start_mode"] == "paper"
    assert not cert.certified and not loop["covers_shaped_start"]
    start = [r for r in cert.findings if r.kind == "start"]
    assert len(start) == 1 and [s.to_dict() for s in start[0].settings] == [
        {"table": "simulation", "key": "start", "value": "shaped", "unit": ""}
    ]
    # simulate runs the same start in the same mode, and its certificate does not cover it either
    path = tmp_path / "raw.toml"
    path.write_text(to_toml(TABLES), encoding="utf-8")
    assert main(["simulate", "--config", str(path), "--json"]) == 1
    assert json.loads(capsys.readouterr().out)["certificate_covers_run"] is False
    # the advice, written back, certifies
    shaped = certify(replace(cfg, simulation=replace(cfg.simulation, start="shaped")))
    assert shaped.certified and shaped.to_dict()["closed_loop"]["start_mode"] == "shaped"
