"""Warnings about input that validates but is probably not what the user meant.

The schema refuses what is wrong; these lines flag what is legal but suspicious, and the CLI
prints them on standard error before it runs:

* an angle (rad) beyond ``2 pi`` in magnitude, which usually means degrees typed by mistake
  (``envelope.psi``, ``reference.heading``, the heading column of ``simulation.initial``);
* a configuration file that sets nothing, so every default is certified without a word.
"""

from __future__ import annotations

import math
from typing import Any

#: Magnitude (rad) beyond which an angle looks like degrees: one full turn.
DEGREES_THRESHOLD = 2.0 * math.pi


def _angles(data: dict[str, Any]) -> list[tuple[str, float]]:
    """``(TOML path, value)`` of every angle (rad) the file sets."""
    out: list[tuple[str, float]] = []
    env = data.get("envelope", {})
    if isinstance(env, dict) and isinstance(env.get("psi"), list):
        out += [(f"envelope.psi[{k}]", v) for k, v in enumerate(env["psi"]) if isinstance(v, (int, float))]
    ref = data.get("reference", {})
    if isinstance(ref, dict) and isinstance(ref.get("heading"), (int, float)):
        out.append(("reference.heading", ref["heading"]))
    sim = data.get("simulation", {})
    rows = sim.get("initial") if isinstance(sim, dict) else None
    if isinstance(rows, list):
        for k, row in enumerate(rows):
            if isinstance(row, list) and len(row) > 2 and isinstance(row[2], (int, float)):
                out.append((f"simulation.initial[{k}][2] (heading)", row[2]))
    return out


def input_warnings(data: Any) -> list[str]:
    """One readable line per suspicious entry of a parsed TOML document (empty: nothing to say).

    Parameters
    ----------
    data : dict
        The parsed configuration file.
    """
    if not isinstance(data, dict):
        return []
    if not data:
        return ["the configuration file sets nothing: every table takes its defaults (see docs/config.md)"]
    return [
        f"{path} = {value:g} rad is more than a full turn: angles are in radians "
        f"(did you mean {math.radians(value):.4g}?)"
        for path, value in _angles(data)
        if not isinstance(value, bool) and abs(float(value)) > DEGREES_THRESHOLD
    ]


__all__ = ["DEGREES_THRESHOLD", "input_warnings"]
