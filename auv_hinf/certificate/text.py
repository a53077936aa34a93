"""The readable table of a certificate (``auv-hinf certify`` without ``--json``), from its record alone.

The table is written from the JSON record (:meth:`~auv_hinf.certificate.assembly.Certificate.to_dict`),
part by part: each registered part writes its own section from its figures, so a certificate
read back from its file prints the same table. A stored part that is not registered in this
session gets a generic line.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from auv_hinf.certificate.part import CertificatePart, figures_in


def certificate_text(record: Mapping[str, Any], registered: Mapping[str, CertificatePart] | None = None) -> str:
    """One line per quantity, with units; the verdict and its reasons last.

    Parameters
    ----------
    record : mapping
        The certificate record (:meth:`~auv_hinf.certificate.assembly.Certificate.to_dict`).
    registered : mapping of str to CertificatePart, optional
        The parts by name that write their sections (default: the registry of this session).
    """
    if registered is None:
        from auv_hinf.certificate.registry import parts

        registered = {p.name: p for p in parts()}
    vehicle = record["vehicle"]
    lines = [f"auv-hinf certificate: {record['preset']} (N={record['n']}, {vehicle.get('name', 'vehicle')})"]
    for name, entry in record["parts"].items():
        part = registered.get(name)
        if not entry["applies"] and not figures_in(entry, record) and entry.get("note"):
            lines.append(f"  {name:<26}not evaluated: {entry['note']}")
        elif part is not None:
            lines += part.lines(figures_in(entry, record), record)
        else:
            where = entry.get("note") or "a part not registered in this session"
            lines.append(f"  {name:<26}{'holds' if entry['ok'] else 'does NOT hold'} ({where})")
    lines.append(f"  CERTIFIED: {'yes' if record['certified'] else 'no'}")
    lines.extend(f"    - {r}" for r in record["reasons"])
    failing = [n for n, e in record["parts"].items() if e["applies"] and not e["ok"]]
    advised = [n for n in failing if any(r.get("settings") for r in record["parts"][n]["reasons"])]
    if len(failing) > 1 and advised:
        silent = [n for n in failing if n not in advised]
        if len(advised) > 1:
            what = (
                "the values advised for one part make that part hold, so write the advice of every part that gives "
                "values before re-running"
            )
        else:  # a part that supersedes others (composed: robust and implementation) may be all that is needed
            what = f"only {advised[0]} advises values: write them, re-run, and follow what still refuses"
        none = (
            f" ({', '.join(silent)} {'gives' if len(silent) == 1 else 'give'} none)"
            if silent and len(advised) > 1
            else ""
        )
        lines.append(f"    ({len(failing)} parts refuse: {', '.join(failing)}; {what}{none})")
    return "\n".join(lines)


__all__ = ["certificate_text"]
