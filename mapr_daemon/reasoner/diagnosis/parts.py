"""The EMA's replaceable parts, and which fault modes the bus data cannot tell apart within one.

A maintainer replaces the SMPS power stage's switch pair, not one of its MOSFETs; so isolation
is scored to the replaceable part (:data:`PARTS`, the one table of them: the event's ``part``,
:data:`COMPONENTS` for SoH, ``bench/accuracy.py``'s part-level figure), and where the data
leave the member open the event says so with each member's probability
(:func:`ambiguity`).

Member probabilities come from the classifier's own fit: each fault mode's best template
residual ``r_k = |y - y_k(s)|^2`` (``classifier.Decision.kind_residuals``, the compressed
whitened coordinates) is a ``-2 log`` likelihood, so ``p_k`` is proportional to
``exp(-(r_k - r_min) / (2 s))``. ``s`` is the scale the dictionary's healthy calibration
measured on the likelihood-ratio statistic (``calibration["chi2_scale"]``: the statistic runs
``s`` times wider than a unit-variance model predicts, so its differences are deflated by it).
The part's members are then conditioned on the decided part (they sum to 1), and the
**ambiguity group** is the members with probability >= :data:`NEGLIGIBLE` given the part.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable, Mapping
from typing import Any

NEGLIGIBLE = 0.05
"""A member below this probability (given its part) is left out of the ambiguity group."""


@dataclasses.dataclass(frozen=True)
class Part:
    """One replaceable part: its name, its fault modes, and each mode's monitored component."""

    name: str
    members: tuple[str, ...]
    components: Mapping[str, str]


PARTS: tuple[Part, ...] = (
    Part("SMPS output capacitor", ("capacitance", "esr"),
         {"capacitance": "smps_output_capacitor", "esr": "smps_output_capacitor"}),
    Part("SMPS switches", ("smps_ron_high", "smps_ron_low"),
         {"smps_ron_high": "smps_high_side_mosfet", "smps_ron_low": "smps_low_side_mosfet"}),
    Part("inverter bridge", ("inverter_ron_a_high", "short", "open"),
         {"inverter_ron_a_high": "inverter_phase_a_high_mosfet", "short": "inverter_bridge",
          "open": "inverter_bridge"}),
    Part("motor and gear", ("friction",), {"friction": "motor_and_gear"}),
)
"""The EMA's replaceable parts and the fault modes (Table 1's, plus short and open) of each."""

PART_OF: dict[str, str] = {m: p.name for p in PARTS for m in p.members}
"""Fault mode -> the replaceable part a maintainer changes for it."""

COMPONENTS: dict[str, str] = {m: c for p in PARTS for m, c in p.components.items()}
"""Fault mode -> the monitored component it degrades (the event's ``component``)."""

_BY_NAME = {p.name: p for p in PARTS}


def mode_probabilities(kind_residuals: Mapping[str, float], scale: float) -> dict[str, float]:
    """Each fault mode's probability from its best residual (see the module doc)."""
    if not kind_residuals:
        return {}
    s = scale if math.isfinite(scale) and scale > 0 else 1.0
    best = min(kind_residuals.values())
    w = {k: math.exp(-(r - best) / (2.0 * s)) for k, r in kind_residuals.items()}
    total = sum(w.values())
    return {k: v / total for k, v in w.items()}


def ambiguity(fault: str | None, kind_residuals: Mapping[str, float],
              scale: float) -> dict[str, Any] | None:
    """The event's ``ambiguity`` for a decided ``fault``; None without one.

    ``{"part", "part_probability", "members": [{"fault", "probability"}, ...] (the part's
    modes the dictionary has, most probable first, probabilities given the part, summing to
    1), "group": [modes with probability >= NEGLIGIBLE], "ambiguous": len(group) > 1,
    "rule"}``. The decided fault is the most probable member: it is the best fit overall.
    """
    if fault is None or fault not in PART_OF:
        return None
    part = _BY_NAME[PART_OF[fault]]
    p = mode_probabilities(kind_residuals, scale)
    if fault not in p:  # no residual for the decided mode: nothing to weigh it against
        p = {fault: 1.0}
    inside = {m: p[m] for m in part.members if m in p}
    mass = sum(inside.values())
    given = {m: v / mass for m, v in inside.items()}
    members = sorted(given.items(), key=lambda kv: (-kv[1], kv[0] != fault))
    group = [m for m, v in members if v >= NEGLIGIBLE]
    return {
        "part": part.name, "part_probability": round(mass, 4),
        "members": [{"fault": m, "probability": round(v, 4)} for m, v in members],
        "group": group, "ambiguous": len(group) > 1,
        "rule": f"members with probability >= {NEGLIGIBLE:g} given the part",
    }


def same_part(true: str, decided: str | None) -> bool:
    """Whether a decided fault mode isolates the true one to its replaceable part."""
    return decided is not None and true in PART_OF and PART_OF.get(decided) == PART_OF[true]


@dataclasses.dataclass
class Isolation:
    """Isolation tallies over faulted runs (the accuracy bench's): to the part, to the member,
    the true member inside the stated ambiguity group, the probability given to it."""

    runs: int = 0
    part: int = 0
    member: int = 0
    in_group: int = 0
    p_true: list[float] = dataclasses.field(default_factory=list)
    """Per run the probability the event gave the true member (0 when it named another part
    or no fault)."""
    p_in_part: list[float] = dataclasses.field(default_factory=list)
    """The same, over the runs isolated to the right part only."""

    @classmethod
    def total(cls, tallies: Iterable[Isolation]) -> Isolation:
        """Tallies added up (e.g. over the fault modes)."""
        out = cls()
        for t in tallies:
            out.runs, out.part, out.member = out.runs + t.runs, out.part + t.part, \
                out.member + t.member
            out.in_group += t.in_group
            out.p_true += t.p_true
            out.p_in_part += t.p_in_part
        return out

    def add(self, true: str, decided: str | None, ambiguity_: Mapping[str, Any] | None) -> None:
        """One faulted run: its true mode, the decided mode (None: none) and the event's
        ``ambiguity``."""
        self.runs += 1
        self.member += decided == true
        p = 0.0
        if same_part(true, decided):
            self.part += 1
            if ambiguity_ is not None:
                self.in_group += true in ambiguity_["group"]
                p = next((float(m["probability"]) for m in ambiguity_["members"]
                          if m["fault"] == true), 0.0)
            else:  # nothing weighed: the decided member alone
                self.in_group += decided == true
                p = float(decided == true)
            self.p_in_part.append(p)
        self.p_true.append(p)
