"""The unit's commissioned in-flight baseline, learned from its first flights in service.

The tracker (:mod:`.tracker`) filters every flight from the actuator file's data sheet; a
flight's *change* is only meaningful against what this unit read when it was new: a real
unit's friction, loop resistance and DC-bus proxy sit off the data sheet by its build
tolerances and its model mismatch, and so do its estimates. The baseline is therefore
learned in service, the way a BIT's commissioning is (``mapr commission``): the mean of the
values of the unit's first :data:`COMMISSIONING_FLIGHTS` flights that gave an estimate of
the parameter, assumed healthy (a unit is commissioned new or overhauled). Until then a
flight's row says ``baseline: pending`` and carries no change.

Nothing is stored apart from the rows: each stored row keeps the flight's value against the
data sheet, so the baseline is the same whenever it is rebuilt from the catalog
(:meth:`Baseline.resume`, in flight order) and a restart or the next replay continues it.

Change per parameter: ``friction`` is a factor over the data sheet, its change the ratio to
the baseline's factor minus one; the others (ohm, V/A, phase-A Ron already a change from the
data sheet's contrast) are differences.

**The change's sd** (:mod:`.scatter`) is its error against the unit's slow aging path, not
only the tracker's against that flight: ``sd_change`` adds the unit's flight-to-flight
scatter, learned from its own flights so far (every stored value, in flight order, this one
included), and the baseline's own uncertainty (its flights carried that scatter too), both
widened for how few flights measured them. The row also keeps the two parts apart:
``sd_flight`` (this flight's own) and ``sd_baseline`` (the baseline's, the same error on
every later flight of the unit), for the trend (:mod:`~mapr_daemon.reasoner.prognosis.fusion`).
Like the baseline, the scatter is rebuilt from the stored rows alone.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable, Mapping
from typing import Any

from mapr_daemon.reasoner.inflight.scatter import ChangeSd, change_sd, learn
from mapr_daemon.reasoner.inflight.tracker import UNITS
from mapr_daemon.reasoner.prognosis.fusion import RATIO

COMMISSIONING_FLIGHTS = 3
"""Flights whose mean value is the unit's baseline (each parameter its own first three)."""


@dataclasses.dataclass
class Baseline:
    """One actuator's baseline per trended parameter: its first flights' values."""

    flights: int = COMMISSIONING_FLIGHTS
    seen: dict[str, dict[int, float]] = dataclasses.field(default_factory=dict)
    """Per parameter, the commissioning flights' values by flight number (a flight stored
    again, after a restart within it, replaces its own value)."""
    history: dict[str, dict[int, tuple[float, float]]] = dataclasses.field(
        default_factory=dict)
    """Per parameter, every flight's ``(value, tracker sd)`` by flight number, in flight
    order: the scatter is learned from them (:mod:`.scatter`)."""

    def value(self, name: str) -> float | None:
        """The commissioned value of ``name`` (None: still pending)."""
        vals = list(self.seen.get(name, {}).values())
        return sum(vals) / len(vals) if len(vals) >= self.flights else None

    def learn(self, values: Mapping[str, float], flight: int | None = None,
              sds: Mapping[str, float] | None = None) -> None:
        """A flight's values (data-sheet terms) count towards a baseline still pending
        (``flight`` None: a flight of its own), and, with their tracker ``sds``, towards
        the parameter's scatter."""
        for name, v in values.items():
            vals = self.seen.setdefault(name, {})
            key = flight if flight is not None else -1 - len(vals)
            if (key in vals or len(vals) < self.flights) and math.isfinite(v):
                vals[key] = float(v)
            sd = (sds or {}).get(name)
            if sd is not None and math.isfinite(v) and math.isfinite(sd):
                hist = self.history.setdefault(name, {})
                hkey = flight if flight is not None else -1 - len(hist)
                hist[hkey] = (float(v), float(sd))

    def resume(self, rows: Iterable[tuple[int | None, Mapping[str, Mapping[str, Any]]]]
               ) -> None:
        """Rebuild from stored rows' flight and ``parameters`` (oldest flight first)."""
        for flight, params in rows:
            self.learn({k: float(p["value"]) for k, p in params.items()
                        if isinstance(p.get("value"), (int, float))}, flight,
                       {k: float(p["sd"]) for k, p in params.items()
                        if isinstance(p.get("sd"), (int, float))})

    def rebase(self, parameters: Mapping[str, Mapping[str, Any]], flight: int | None = None
               ) -> dict[str, dict[str, Any]]:
        """A flight's parameters (each with ``value`` against the data sheet and ``sd``:
        :meth:`FlightEstimate.as_event`, or a row stored without a baseline) as stored: per
        parameter ``value``, ``sd``, ``change`` and ``sd_change`` from the baseline (None
        while pending; ``sd_change`` against the unit's slow path, its parts
        ``sd_flight`` and ``sd_baseline`` beside it: see the module), ``baseline`` (its
        value, or ``"pending k/K"``) and ``unit``. A flight
        that completes a baseline is a commissioning flight (pending too); then it counts.
        Call once per flight (``flight``: its number), in flight order."""
        out: dict[str, dict[str, Any]] = {}
        for name, p in parameters.items():
            value, sd_v = float(p["value"]), float(p["sd"])
            commissioning = flight is not None and flight in self.seen.get(name, {})
            base = None if commissioning else self.value(name)
            change: float | None = None
            sd: ChangeSd | None = None
            if base is not None:
                change = value / base - 1.0 if name in RATIO else value - base
                sd = self._change_sd(name, value, sd_v, base, flight)
            keys = list(self.seen.get(name, {}))
            place = keys.index(flight) + 1 if flight is not None and commissioning \
                else len(keys) + 1
            out[name] = {
                "value": float(f"{value:.6g}"), "sd": float(f"{sd_v:.3g}"),
                "change": None if change is None else float(f"{change:.4g}"),
                "sd_change": None if sd is None else float(f"{sd.total:.3g}"),
                "sd_flight": None if sd is None else float(f"{sd.flight:.3g}"),
                "sd_baseline": None if sd is None else float(f"{sd.baseline:.3g}"),
                "baseline": (float(f"{base:.6g}") if base is not None
                             else f"pending {place}/{self.flights}"),
                "unit": p.get("unit", UNITS.get(name, ""))}
        self.learn({k: float(p["value"]) for k, p in parameters.items()}, flight,
                   {k: float(p["sd"]) for k, p in parameters.items()})
        return out

    def _change_sd(self, name: str, value: float, sd: float, base: float,
                   flight: int | None) -> ChangeSd:
        """This flight's change sd: the scatter learned from the unit's flights so far and
        this one (:mod:`.scatter`), the baseline's flights' tracker sds."""
        hist = dict(self.history.get(name, {}))
        hist[flight if flight is not None else -1 - len(hist)] = (value, sd)
        ratio = name in RATIO
        scatter = learn([v for v, _ in hist.values()], [s for _, s in hist.values()], ratio)
        commissioned = self.seen.get(name, {})
        base_sds = [self.history.get(name, {}).get(k, (v, sd))[1]
                    for k, v in commissioned.items()]
        return change_sd(scatter, sd, value, list(commissioned.values()), base_sds, base,
                         ratio)
