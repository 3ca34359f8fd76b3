"""Where on the envelope the bus data can see each fault mode: a detection map per mode over
aircraft-bus voltage and ambient temperature, measured at the dictionary build.

What a BIT can see depends on the flight condition: below ``Vout / max_duty`` the SMPS sits at
its duty limit and its low-side switch conducts a few per cent of the period, so that switch's
Ron moves nothing the bus carries; a saturated voltage loop makes no transient for the
capacitance to show in (docs/reasoner-measured.md). A maintainer must know which "no anomaly"
means "healthy" and which means "not observable here". The build flies, per parametric mode,
:attr:`DictionarySpec.detection_map_runs` runs at random severities (25-100 % of range) in
each cell of a :data:`BANDS` x :data:`BANDS` grid over the actuator's bus-voltage and
ambient-temperature envelope (pressures over the envelope too), decides them with the built
dictionary and keeps the detected share per cell: :class:`DetectionMap`. A decision then names
the modes *blind* at its own condition (detected in under :data:`BLIND_BELOW` of the map's
runs there), and ``mapr dictionary describe`` prints the map.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from mapr_daemon.arrays import FloatArray

__all__ = ["BANDS", "BLIND_BELOW", "DetectionMap", "band_edges"]

BANDS = 3
"""Bands per axis (bus voltage, ambient temperature)."""
BLIND_BELOW = 0.5
"""A mode detected in fewer than this share of the map's runs in a cell is blind there."""


def band_edges(lo: float, hi: float, bands: int = BANDS) -> FloatArray:
    """``bands + 1`` equally spaced edges from ``lo`` to ``hi``."""
    out: FloatArray = np.linspace(lo, hi, bands + 1)
    return out


def _band(edges: Sequence[float], value: float) -> int:
    """The band holding ``value`` (the outer bands extend beyond the envelope)."""
    return int(np.clip(np.searchsorted(np.asarray(edges), value, side="right") - 1, 0,
                       len(edges) - 2))


@dataclasses.dataclass(frozen=True)
class DetectionMap:
    """Per parametric mode, the detected share of its map runs per (bus band, ambient band)."""

    bus_v_edges: tuple[float, ...]
    ambient_c_edges: tuple[float, ...]
    detected: Mapping[str, tuple[tuple[float, ...], ...]]
    """mode -> rows over the bus bands, columns over the ambient bands."""
    runs_per_cell: int

    @classmethod
    def measure(cls, bus_v_edges: Sequence[float], ambient_c_edges: Sequence[float],
                runs: Sequence[tuple[str, float, float, bool]]) -> DetectionMap:
        """From ``(mode, bus V, ambient C, detected)`` per map run."""
        nb, na = len(bus_v_edges) - 1, len(ambient_c_edges) - 1
        hits: dict[str, np.ndarray] = {}
        counts: dict[str, np.ndarray] = {}
        for mode, bus, amb, detected in runs:
            i, j = _band(bus_v_edges, bus), _band(ambient_c_edges, amb)
            hits.setdefault(mode, np.zeros((nb, na)))[i, j] += detected
            counts.setdefault(mode, np.zeros((nb, na)))[i, j] += 1
        # a cell none of a mode's runs landed in says nothing: NaN, never "blind"
        share = {m: tuple(tuple(round(float(h / n), 3) if n else math.nan
                                for h, n in zip(hrow, nrow, strict=True))
                          for hrow, nrow in zip(hits[m], counts[m], strict=True))
                 for m in hits}
        per_cell = int(min(c.min() for c in counts.values())) if counts else 0
        return cls(tuple(float(e) for e in bus_v_edges),
                   tuple(float(e) for e in ambient_c_edges), share, per_cell)

    def blind(self, bus_v: float, ambient_c: float) -> list[str]:
        """The modes the map's runs at this condition's cell detected too rarely to trust a
        "no anomaly" about them."""
        i, j = _band(self.bus_v_edges, bus_v), _band(self.ambient_c_edges, ambient_c)
        return sorted(m for m, rows in self.detected.items() if rows[i][j] < BLIND_BELOW)
        # (NaN < BLIND_BELOW is False: an empty cell names nothing blind)

    def as_json(self) -> dict[str, Any]:
        return {"bus_v_edges": list(self.bus_v_edges),
                "ambient_c_edges": list(self.ambient_c_edges),
                "detected": {m: [[None if math.isnan(v) else v for v in r] for r in rows]
                             for m, rows in self.detected.items()},
                "runs_per_cell": self.runs_per_cell}

    @classmethod
    def from_json(cls, doc: Mapping[str, Any]) -> DetectionMap:
        return cls(tuple(doc["bus_v_edges"]), tuple(doc["ambient_c_edges"]),
                   {m: tuple(tuple(math.nan if v is None else float(v) for v in r)
                             for r in rows)
                    for m, rows in doc["detected"].items()}, int(doc["runs_per_cell"]))

    def table(self) -> list[str]:
        """The map as text: one block per mode, bus bands down, ambient bands across."""
        amb = self.ambient_c_edges
        head = " " * 16 + "".join(f"{f'{amb[j]:.0f}..{amb[j + 1]:.0f} C':>14}"
                                  for j in range(len(amb) - 1))
        out = [f"detected share of the map's conclusive runs per cell (at least "
               f"{self.runs_per_cell} each) at 25-100 % of range, binned by the bus voltage and "
               f"the power-stage temperature read from their records (* blind: below "
               f"{BLIND_BELOW:.0%})"]
        bus = self.bus_v_edges
        for mode, rows in self.detected.items():
            out += [f"{mode}", head]
            for i, row in enumerate(rows):
                out.append(f"{f'{bus[i]:.1f}..{bus[i + 1]:.1f} V':>16}"
                           + "".join(f"{'no runs':>13} " if math.isnan(v) else
                                     f"{v:>13.0%}{'*' if v < BLIND_BELOW else ' '}"
                                     for v in row))
        return out
