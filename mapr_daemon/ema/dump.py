"""Write an actuator YAML that :func:`~mapr_daemon.ema.params.load_actuator` reads back.

Commissioning writes the identified actuator this way: every section and key of the data
sheet, in its order, each float written exactly (``repr``, so a load gives the same bits),
with a header of comment lines saying where the values came from.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

from mapr_daemon.ema.params import (
    CHANNELS,
    OPTIONAL_SECTIONS,
    SECTION_NAMES,
    ActuatorParams,
)

SECTIONS = SECTION_NAMES
"""Every section the loader requires (one list: a section added there is written here)."""


_DEFAULTS = {f.name: f.default for f in dataclasses.fields(ActuatorParams)
             if f.name in OPTIONAL_SECTIONS}
"""The optional sections' defaults: a section at its default is not written (the file then
reads as one written before the section existed)."""


def _num(value: float) -> str:
    return repr(float(value))


def dump_actuator(params: ActuatorParams, header: str = "",
                  notes: dict[str, str] | None = None) -> str:
    """The actuator file's text; ``header`` becomes comment lines on top, ``notes`` a comment
    after a ``section.key`` line (e.g. "identified, sd 0.8 %")."""
    notes = notes or {}
    lines = [f"# {line}".rstrip() for line in header.splitlines()]
    lines.append(f"name: {json.dumps(params.name)}")
    optional = [name for name in OPTIONAL_SECTIONS
                if getattr(params, name) != _DEFAULTS[name]]
    for section in (*SECTIONS, *optional):
        block = getattr(params, section)
        lines.append("")
        lines.append(f"{section}:")
        for f in dataclasses.fields(block):
            if f.default is not dataclasses.MISSING and getattr(block, f.name) == f.default:
                continue  # an optional key at its default: as a data sheet leaves it out
            text = f"  {f.name}: {_num(getattr(block, f.name))}"
            note = notes.get(f"{section}.{f.name}")
            lines.append(f"{text:<48}# {note}" if note else text)
    s = params.sensors
    lines += ["", "sensors:", f"  sample_rate_hz: {_num(s.sample_rate_hz)}",
              f"  step_s: {_num(s.step_s)}", "  channels:"]
    for name in CHANNELS:
        c = s.channels[name]
        lines.append(f"    {name}: {{full_scale: {_num(c.full_scale)}, bits: {_num(c.bits)}, "
                     f"noise_rms: {_num(c.noise_rms)}}}")
    return "\n".join(lines) + "\n"


def write_actuator(path: str | Path, params: ActuatorParams, header: str = "",
                   notes: dict[str, str] | None = None) -> None:
    """Write :func:`dump_actuator`'s text to ``path``."""
    Path(path).write_text(dump_actuator(params, header, notes), encoding="utf-8")
