"""What to run before ``mapr run --check``, when an asset's fault dictionary is not built yet.

A daemon config names each actuator's fault dictionary (``assets[].dictionary``, and its
prognostic model, ``assets[].prognosis``). Those are built products (a simulation campaign,
minutes of CPU), not files the repository ships, so a shipped config can only pass
``mapr run --check`` once they are built; the honest check says exactly how. This module
turns the config's own words into that command line: the asset's actuator file, the output
paths, and the sample rate its sensors carry on this bus (the ICD group holding the signal
wired to the asset's DC-link current), all relative to where the user stands.

Light: the standard library and YAML at call time; only run when the check already failed.
"""

from __future__ import annotations

import os
import re
from pathlib import Path
from typing import Any

_MISSING = re.compile(r"assets\[(\d+)\]\.(dictionary|prognosis): .*: no such file")
DC_LINK = "dc_link_current_a"
"""The reasoner channel whose ICD group gives an asset's sensor sample rate."""


def build_command(config_path: str, problem: str) -> str | None:
    """``mapr dictionary build ...`` that makes the file ``problem`` (a config error) says
    is missing, or None when ``problem`` is not a missing dictionary or the config cannot
    say more."""
    found = _MISSING.search(problem)
    if not found:
        return None
    import yaml

    base = Path(config_path).parent
    try:
        raw = yaml.safe_load(Path(config_path).read_text(encoding="utf-8"))
        asset: dict[str, Any] = raw["assets"][int(found.group(1))]
    except (OSError, yaml.YAMLError, KeyError, IndexError, TypeError):
        return None
    words = ["mapr", "dictionary", "build"]
    if asset.get("actuator"):
        words += ["--actuator", _here(base, asset["actuator"])]
    rate = _sample_rate(base, raw.get("icd"), asset.get("signals"))
    if rate is not None:
        words += ["--sample-rate", f"{rate:g}"]
    if asset.get("dictionary"):
        words += ["-o", _here(base, asset["dictionary"])]
    if asset.get("prognosis"):
        words += ["--prognosis", _here(base, asset["prognosis"])]
    return " ".join(words)


def _here(base: Path, name: str) -> str:
    """A config-relative path as the user, where they stand, would type it."""
    path = Path(name) if Path(name).is_absolute() else base / name
    return os.path.relpath(path) if not Path(name).is_absolute() else str(path)


def _sample_rate(base: Path, icd: str | None, signals: dict[str, str] | None) -> float | None:
    """The rate of the ICD group carrying the asset's DC-link current (None if unknown)."""
    if not icd:
        return None
    from mapr_daemon.errors import IcdError
    from mapr_daemon.icd import load_icd
    from mapr_daemon.pipeline.wiring import DEFAULT_SIGNALS

    wired = DEFAULT_SIGNALS if signals is None else signals
    wanted = {name for name, channel in wired.items() if channel == DC_LINK}
    try:
        table = load_icd(Path(icd) if Path(icd).is_absolute() else base / icd)
    except (OSError, IcdError):
        return None
    for message in table.messages:
        group = message.group
        if group is not None and wanted & {c.name for c in group.channels}:
            return group.sample_rate_hz
    return None
