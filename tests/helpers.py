"""Helpers shared by several test modules (not tests themselves)."""

from __future__ import annotations

import fcntl
import hashlib
import importlib
import inspect
import json
import pickle
import pkgutil
import tempfile
from dataclasses import replace
from functools import cache
from pathlib import Path
from typing import Any

import numpy as np

import auv_hinf
from auv_hinf.certificate.assembly import Certificate, certify
from auv_hinf.config.presets import annotated_toml, preset_config
from auv_hinf.config.settings import FormationConfig
from auv_hinf.mission.fleet import FleetReference

#: Four BlueROV2 Heavy on a gentle sine with Theorem 1 gains (gamma = 0.1, method minimal): a loop gentle
#: enough to be sampled, and a mission that keeps it inside its envelope.
BLUEROV_SLOW = {
    "vehicle": {"preset": "bluerov2-heavy"},
    "formation": {"n": 4, "shape": [[0.0, -4.0], [0.0, -6.0], [0.0, -8.0]]},
    "envelope": {"u": [-0.5, 1.0], "v": [-0.5, 0.5], "r": [-0.5, 0.5]},
    "design": {"method": "minimal", "gamma": 0.1, "k1": 0.5},
    "reference": {"kind": "sine", "speed": 0.4, "amplitude": 2.0, "omega": 0.05},
    "actuators": {"preset": "bluerov2-heavy"},
}

#: Four BlueROV2 Heavy in a line abreast 4 m apart, at 0.05 m/s along x, run at 10 Hz with a delay of up
#: to 50 ms and noise bounds of 1 cm and 0.01 rad (rad/s): certified (the implementation part gives
#: |e| <= 0.051 m, |e'| <= 0.076 m/s, |e_psi| <= 0.074 rad, |e_r| <= 0.080 rad/s). The preset
#: ``bluerov2-line`` is not certified (its robust box needs more force than the thrusters give), and
#: its gains' sampled certificate stops near 27 ms; these gentler Theorem 1 gains (gamma 0.15,
#: minimal, k1 = 2) on a narrower envelope certify at 10 Hz.
BLUEROV_10HZ = {
    "name": "bluerov2-10hz",
    "vehicle": {"preset": "bluerov2-heavy"},
    "formation": {"n": 4, "offsets": [[0.0, -6.0], [0.0, -2.0], [0.0, 2.0], [0.0, 6.0]]},
    "envelope": {"u": [-0.2, 0.4], "v": [-0.2, 0.2], "r": [-0.2, 0.2]},
    "design": {"method": "minimal", "gamma": 0.15, "k1": 2.0, "heading_poles": [-1.0, -1.5]},
    "reference": {"kind": "line", "speed": 0.05},
    "actuators": {"preset": "bluerov2-heavy"},
    "simulation": {"horizon": 60.0},
    "implementation": {
        "sample_time": 0.1,
        "delay": 0.05,
        "varying_delay": True,
        "noise": {"position": 0.01, "heading": 0.01, "yaw_rate": 0.01},
    },
}


#: The deployed fleet: four BlueROV2 Heavy on a line, 10 Hz, 0.1 s delay, small noise.
DEPLOYED = {
    "vehicle": {"preset": "bluerov2-heavy"},
    "formation": {"n": 4, "offsets": [[0.0, -6.0], [0.0, -2.0], [0.0, 2.0], [0.0, 6.0]], "min_separation": 2.0},
    "envelope": {"u": [-0.5, 1.0], "v": [-0.5, 0.5], "r": [-0.5, 0.5]},
    "design": {"robust": True, "synthesis": "deployed"},
    "reference": {"kind": "line", "speed": 0.4, "heading": 0.0},
    "simulation": {"horizon": 40.0},
    "actuators": {"preset": "bluerov2-heavy"},
    "implementation": {
        "sample_time": 0.1,
        "delay": 0.1,
        "noise": {"position": 0.01, "velocity": 0.002, "heading": 0.002, "yaw_rate": 0.001},
    },
}


#: Four BlueROV2 Heavy on a 0.4 m/s line at 10 Hz with a 0.1 s delay, in a 0.005 m/s current,
#: surge mass and drag known to 1 % and 2 %, noise a quarter of bluerov2-deployed's.
DEPLOYED_BOXED = {
    **DEPLOYED,
    "simulation": {"horizon": 20.0, "noise_pattern": "mixed"},
    "uncertainty": {"m11": [0.99, 1.01], "d11_quad": [0.98, 1.02]},
    "disturbance": {"current_speed": 0.005},
    "implementation": {
        "sample_time": 0.1,
        "delay": 0.1,
        "noise": {"position": 0.0125, "velocity": 0.001, "heading": 0.001, "yaw_rate": 0.0005},
    },
}


#: A BlueROV2-sized vehicle written as a ``[vehicle]`` table (figures near the preset's, perturbed,
#: no linear sway or yaw drag): a vehicle no preset names, as a user's own file gives it.
ROV_LIKE_VEHICLE: dict[str, float] = {
    "m11": 23.8,
    "m22": 17.5,
    "m33": 0.74,
    "d11_lin": 10.96,
    "d11_quad": 162.0,
    "d22_lin": 0.0,
    "d22_quad": 163.0,
    "d33_lin": 0.0,
    "d33_quad": 1.95,
}
#: Four of them in a line (the paper's Jacobi shape coordinates, m): neighbouring slots 4 m apart.
ROV_LINE_SHAPE = [[0.0, -4.0], [0.0, -6.0], [0.0, -8.0]]


def starts_from_errors(fleet: FleetReference, errors: np.ndarray) -> np.ndarray:
    """Initial states ``(..., n, 6)`` whose errors against ``fleet`` at ``t = 0`` are ``errors``."""
    m = fleet.motion(0.0)
    e, de, ep, dep = errors[..., 0:2], errors[..., 2:4], errors[..., 4], errors[..., 5]
    psi = m.psi + ep
    vel = m.v + de
    c, s = np.cos(psi), np.sin(psi)
    u, v = c * vel[..., 0] + s * vel[..., 1], -s * vel[..., 0] + c * vel[..., 1]
    return np.concatenate([m.p + e, psi[..., None], u[..., None], v[..., None], (m.r + dep)[..., None]], axis=-1)


@cache
def _source_digest() -> str:
    """SHA-256 of the package's sources: a cached certificate is only ever reused by the same code."""
    digest = hashlib.sha256()
    root = Path(auv_hinf.__file__).parent
    for path in sorted(root.rglob("*.py")):
        digest.update(path.relative_to(root).as_posix().encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()[:16]


def certificate_of(cfg: FormationConfig) -> Certificate:
    """``certify(cfg)``, computed once for the whole test run (every xdist worker shares it).

    The heavy presets take 10-30 s to certify and several test files need the same certificate:
    the first process to ask computes it under a file lock and pickles it into a folder keyed on
    the package's sources and on the configuration; the others wait for it and read it.
    """
    key = hashlib.sha256(json.dumps(cfg.to_toml_dict(), sort_keys=True, default=str).encode()).hexdigest()[:16]
    folder = Path(tempfile.gettempdir()) / f"auv-hinf-test-certificates-{_source_digest()}"
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{cfg.name}-{key}.pickle"
    with open(folder / f"{key}.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if path.exists():
            cert: Certificate = pickle.loads(path.read_bytes())
            return cert
        cert = certify(cfg)
        path.write_bytes(pickle.dumps(cert))
        return cert


def fully_actuated(name: str) -> FormationConfig:
    """Preset ``name`` with its ``[actuators]`` left undeclared: its hydrodynamics with a sway actuator.

    The REMUS presets declare the vehicle's propeller and rudder, on which the fully actuated law
    is refused; the tests of the robust, sampled and campaign machinery use the same fleet as if
    each vehicle had a sway actuator (no force limits), which is what those certificates are about.
    """
    return replace(preset_config(name), actuators=None)


def fully_actuated_file(name: str, folder: Path) -> Path:
    """:func:`fully_actuated` written as a TOML file in ``folder`` (for the command-line tests)."""
    path = folder / f"{name}.toml"  # the file name is the configuration name
    path.write_text(annotated_toml(fully_actuated(name)), encoding="utf-8")
    return path


@cache
def preset_certificate(name: str) -> Certificate:
    """The certificate of preset ``name``, computed once for the whole test run (:func:`certificate_of`)."""
    return certificate_of(preset_config(name))


@cache
def failed_certificate() -> Certificate:
    """Not certified: the paper's gain is infeasible below the Theorem 1 bound of gamma, so there is no closed loop."""
    cfg = replace(preset_config("paper-triangle"), gamma=0.2, method="paper")
    return certify(cfg)


def toml_value(v: Any) -> str:
    """``v`` as a TOML value (tables inline)."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, float)):
        return repr(v)  # nan, inf and -inf are TOML too
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, dict):
        return "{" + ", ".join(f"{json.dumps(k)} = {toml_value(x)}" for k, x in v.items()) + "}"
    return "[" + ", ".join(toml_value(x) for x in v) + "]"


def to_toml(data: dict[str, Any]) -> str:
    """A TOML document of ``data``: its top-level keys, then one ``[table]`` per dict (sub-tables inline)."""
    lines = [f"{json.dumps(k)} = {toml_value(v)}" for k, v in data.items() if not isinstance(v, dict)]
    for key, table in data.items():
        if isinstance(table, dict):
            lines.append(f"[{json.dumps(key)}]")
            lines += [f"{json.dumps(k)} = {toml_value(v)}" for k, v in table.items()]
    return "\n".join(lines) + "\n"


@cache
def package_class_names() -> frozenset[str]:
    """The names of every class defined in auv_hinf, found by importing each of its modules."""
    names = set()
    for info in pkgutil.walk_packages(auv_hinf.__path__, "auv_hinf."):
        module = importlib.import_module(info.name)
        for obj in vars(module).values():
            if inspect.isclass(obj) and obj.__module__.startswith("auv_hinf"):
                names.add(obj.__name__)
    return frozenset(names)


#: A review's fleet: four REMUS-like vehicles on a line, a box and a 0.15 m/s current, which only cells
#: of the box and of the current certify; declared to start on their slots heading along the track
#: (not crabbed into the current, which a heading error in the other currents would be).
CELLS_LINE = {
    "vehicle": {
        "m11": 34.0,
        "m22": 72.0,
        "m33": 9.1,
        "d11_lin": 0.0,
        "d11_quad": 1.8,
        "d22_lin": 47.0,
        "d22_quad": 1150.0,
        "d33_lin": 3.4,
        "d33_quad": 85.0,
    },
    "formation": {"n": 4, "frame": "inertial", "offsets": [[0.0, -22.5], [0.0, -7.5], [0.0, 7.5], [0.0, 22.5]]},
    "envelope": {"u": [0.5, 2.5], "v": [-0.3, 0.3], "r": [-0.3, 0.3]},
    "reference": {"kind": "line", "speed": 1.5, "heading": 0.3},
    "actuators": {"kind": "underactuated", "tau_x": 60.0, "rudder_max": 0.26, "rudder_sway": 10.5, "rudder_yaw": -6.8},
    "guidance": {"kind": "ilos", "lookahead": 16.0, "heading_bandwidth": 3.2},
    "uncertainty": {
        "m11": [0.95, 1.05],
        "m22": [0.95, 1.05],
        "m33": [0.95, 1.05],
        "d11_quad": [0.8, 1.2],
        "d22_lin": [0.8, 1.2],
        "d22_quad": [0.8, 1.2],
        "d33_lin": [0.8, 1.2],
        "d33_quad": [0.8, 1.2],
    },
    "disturbance": {"current_speed": 0.15},
    "simulation": {"initial": [[0.0, y, 0.3, 1.5, 0.0, 0.0] for y in (-22.5, -7.5, 7.5, 22.5)]},
}
