"""What a commissioned unit's own BITs can see of each fault mode: its detection floor.

The dictionary's detection map (:mod:`~mapr_daemon.reasoner.diagnosis.detection_map`) says where
the *model* sees a mode. A commissioned unit decides with a dictionary calibrated to it
(:mod:`~mapr_daemon.reasoner.commissioning.calibrate`): its thresholds rise with the unit's own
scatter about the model (two to five times on the mismatch bench), so the unit sees less than
the map says, and a maintainer reading "no anomaly" on that unit needs to know how much less.

Measured at commissioning, on the unit's own healthy BITs: each carries in turn every
parametric mode's departure at each of :data:`SEVERITIES` (fractions of the Table 1 range),
the identified model flown through the BIT's own command and condition (its ambient and bus
read from the record, its dynamic pressure) with and without the fault, noise-free
(:func:`~mapr_daemon.reasoner.commissioning.prior.quiet`), the difference added to the
recorded channels; the unit's calibrated dictionary decides. Per mode and severity, the share
detected: :class:`Visibility`. A mode's *floor* is the least severity from which every larger
one was detected on at least :data:`SEEN` of the BITs; a mode without one is not seen within
its range on this unit (the SMPS low-side Ron on most: the BIT's load leaves its switch nearly
idle). The unit's scatter stays in the BITs (they are the unit's own records) and the fault's
departure is the identified model's, not the unit's own: the floor is as right as that model
is near the unit (``bench/units.py`` prints detection on BITs above and below each unit's
floor).

Each BIT is decided by the dictionary calibrated without it when the caller hands those in
(``held_out``, :func:`~mapr_daemon.reasoner.commissioning.calibrate.without_each`, as
``mapr commission`` does from 4 BITs up), so the floor is measured as on BITs flown later.

Cost: one plant run per BIT, mode and severity, plus one healthy run per BIT (about 20 x
(6 x 4 + 1) runs at commissioning), one dictionary decision each and, held out, one
calibration per BIT: 15-22 s of CPU on 20 BITs.
"""

from __future__ import annotations

import dataclasses
import itertools
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from mapr_daemon.arrays import FloatArray
from mapr_daemon.ema.batch import RunSpec
from mapr_daemon.ema.faults import PARAMETRIC, FaultSet, at_severity
from mapr_daemon.ema.params import ActuatorParams
from mapr_daemon.errors import ConfigError, RecordError
from mapr_daemon.reasoner.commissioning import prior as ip
from mapr_daemon.reasoner.commissioning.bits import BitRecord, condition
from mapr_daemon.reasoner.commissioning.flight import flown_channels
from mapr_daemon.reasoner.diagnosis import classifier
from mapr_daemon.reasoner.diagnosis.dictionary import Dictionary

__all__ = ["SEEN", "SEVERITIES", "Visibility", "measure"]

SEVERITIES: tuple[float, ...] = (0.25, 0.5, 0.75, 1.0)
"""Severities each mode is added at (fractions of the Table 1 range), from a quarter, the
least a maintainer is promised detection at, to the range's end."""
SEEN = 0.9
"""A severity is seen on the unit when at least this share of its BITs detected it."""
HELD = frozenset(("commutation_sector",))
"""Channels whose departure is not added (a Hall sector is a count, not a level: the record's
own is kept)."""


@dataclasses.dataclass(frozen=True)
class Visibility:
    """Per parametric mode, the share of the unit's BITs its calibrated dictionary detected the
    mode in, at each of :attr:`severities`."""

    severities: tuple[float, ...]
    detected: Mapping[str, tuple[float, ...]]
    bits: int
    """BITs each share is over."""
    seen: float = SEEN
    """The share a severity needs to count as seen (the record's own: a record keeps the rule
    it was measured with)."""
    held_out: bool = False
    """Whether each BIT was decided by the dictionary calibrated without it (from more than
    three BITs, as ``mapr commission`` does) rather than by the one calibrated on all."""
    alarmed: int = 0
    """Healthy BITs the dictionary flagged as they were recorded (held out: calibrated
    without them), left out of the shares."""

    def false_alarm_note(self) -> str | None:
        """One line when some of the unit's own healthy BITs alarmed, else None. It states
        what happened, not a rate to expect: on the mismatch bench the count did not tell
        which units would alarm in service (docs/reasoner-measured.md)."""
        if not self.alarmed:
            return None
        n = self.alarmed + self.bits
        how = ("the dictionary calibrated without each" if self.held_out
               else "its calibrated dictionary")
        return (f"{self.alarmed} of the unit's {n} healthy BITs were flagged by {how} "
                "(left out of what its BITs can see; check those BITs)")

    def floor(self, mode: str) -> float | None:
        """The least severity from which every larger one was seen (:attr:`seen`); None when
        the range's end is not seen (or the mode was not measured)."""
        shares = self.detected.get(mode)
        if shares is None:
            return None
        out = None
        for severity, share in reversed(list(zip(self.severities, shares, strict=True))):
            if share < self.seen:
                break
            out = severity
        return out

    def sees(self, mode: str, severity: float) -> bool:
        """Whether a ``mode`` fault at ``severity`` is at or above the unit's floor."""
        f = self.floor(mode)
        return f is not None and severity >= f - 1e-9

    def share_at(self, mode: str, severity: float) -> float:
        """The detected share expected at ``severity``: linear between the measured ones,
        held beyond them (NaN for a mode not measured)."""
        shares = self.detected.get(mode)
        if shares is None:
            return float("nan")
        return float(np.interp(severity, self.severities, shares))

    def lines(self) -> list[str]:
        """One line per mode, as ``mapr commission`` says them."""
        out = []
        for mode, shares in self.detected.items():
            f = self.floor(mode)
            said = ", ".join(f"{s:.0%} of range {v:.0%}" for s, v in
                             zip(self.severities, shares, strict=True))
            out.append(f"{mode}: " + (f"seen from {f:.0%} of range" if f is not None else
                                      "not seen within its range on this unit")
                       + f" (detected on the unit's {self.bits} BITs at {said})")
        return out

    def to_json(self) -> dict[str, Any]:
        return {"severities": list(self.severities), "seen": self.seen, "bits": self.bits,
                "held_out": self.held_out, "alarmed": self.alarmed,
                "detected": {k: [round(v, 4) for v in x] for k, x in self.detected.items()},
                "floor": {k: self.floor(k) for k in self.detected}}

    @classmethod
    def from_json(cls, doc: Any, path: str = "<record>") -> Visibility:
        """Parse :meth:`to_json`'s output; :class:`ConfigError` naming what is wrong."""
        try:
            sev = tuple(float(s) for s in doc["severities"])
            if not sev or not all(0.0 <= s <= 1.0 for s in sev) or \
                    any(b <= a for a, b in itertools.pairwise(sev)):
                # a decision reads the least and each larger one: fractions of range, rising
                raise ValueError("severities must be one or more increasing fractions of range")
            det = {str(k): tuple(float(v) for v in x) for k, x in doc["detected"].items()}
            if any(len(x) != len(sev) or not all(0.0 <= v <= 1.0 for v in x)
                   for x in det.values()):
                raise ValueError("each mode needs one share in [0, 1] per severity")
            bits = int(doc["bits"])
            if bits < 1:
                raise ValueError(f"{bits} BITs")
            seen = float(doc.get("seen", SEEN))
            if not 0.0 < seen <= 1.0:
                raise ValueError(f"seen {seen} (a share in (0, 1])")
            alarmed = int(doc.get("alarmed", 0))
            if alarmed < 0:
                raise ValueError(f"{alarmed} alarmed BITs")
            return cls(sev, det, bits, seen, bool(doc.get("held_out", False)), alarmed)
        except (KeyError, TypeError, ValueError, AttributeError) as error:
            raise ConfigError(f"malformed visibility ({type(error).__name__}: {error})",
                              path=path, field="visibility") from None


def departures(params: ActuatorParams, bit: BitRecord, faults: Sequence[FaultSet]
               ) -> list[dict[str, FloatArray]]:
    """Each of ``faults``'s departure on ``bit``: the noise-free model ``params`` flown through
    the BIT's command, dynamic pressure and recorded condition with the faults, minus the same
    without them, per channel the plant gives."""
    model = ip.quiet(params)
    ambient, bus = condition(params, bit)
    specs = [RunSpec(model, fs, seed=0, ambient_c=ambient, bus_v=bus)
             for fs in (FaultSet(), *faults)]
    command = np.asarray(bit.command_deg, dtype=np.float64)
    runs = flown_channels(specs, np.tile(command, (len(specs), 1)),
                          np.full(len(specs), bit.dynamic_pressure_pa))
    return [{k: v[j] - v[0] for k, v in runs.items()} for j in range(1, len(specs))]


def _with(bit: BitRecord, departure: Mapping[str, FloatArray]) -> dict[str, FloatArray]:
    """The record's channels plus ``departure`` (on the samples both have)."""
    out = {}
    for k, v in bit.channels.items():
        d = departure.get(k)
        if d is None or k in HELD:
            out[k] = v
            continue
        n = min(v.shape[-1], d.shape[-1])
        moved = np.array(v, dtype=np.float64)
        moved[..., :n] += d[..., :n]
        out[k] = moved
    return out


def measure(d: Dictionary, params: ActuatorParams, bits: Sequence[BitRecord],
            modes: Sequence[str] | None = None,
            severities: Sequence[float] = SEVERITIES,
            held_out: Sequence[Dictionary] | None = None) -> Visibility:
    """The unit's :class:`Visibility`: ``d`` (its calibrated dictionary) deciding ``bits``
    (its healthy commissioning BITs) with each mode's departure on the model ``params`` (the
    identified one) added at each severity. ``modes``: the parametric modes to measure
    (default every one the dictionary has a template of); ``held_out``: per BIT the
    dictionary calibrated without it (:func:`~.calibrate.without_each`), which then decides
    that BIT in place of ``d``, so no BIT is decided by a calibration that saw it. A BIT
    recorded at another rate than ``params``'s, one the dictionary cannot read
    (RecordError), calls inconclusive (a bus below the converter's headroom) or already flags
    as an anomaly (healthy as it is) is left out; ConfigError when none is left."""
    if held_out is not None and len(held_out) != len(bits):
        raise ValueError(f"{len(held_out)} held-out dictionaries for {len(bits)} BITs")
    kinds = [m for m in (modes or [t.kind for t in d.templates]) if m in PARAMETRIC]
    kinds = list(dict.fromkeys(kinds))
    faults = [FaultSet.of([at_severity(params, k, s)]) for k in kinds for s in severities]
    hits = np.zeros((len(kinds), len(severities)))
    used = alarmed = 0
    rate = params.sensors.sample_rate_hz
    for i, bit in enumerate(bits):
        if abs(bit.sample_rate_hz - rate) > 1e-9 * rate:
            continue   # the departure is flown at the model's rate: it would land off time
        judge = d if held_out is None else held_out[i]
        try:
            base = classifier.decide(judge, judge.record_matrix(bit.channels, bit.command_deg),
                                     bit.dynamic_pressure_pa)
        except RecordError:
            continue
        alarmed += bool(base.anomaly and not base.inconclusive)
        if base.inconclusive or base.anomaly:
            continue   # an alarm already on the healthy record says nothing of the fault
        used += 1
        for j, dep in enumerate(departures(params, bit, faults)):
            m = judge.record_matrix(_with(bit, dep), bit.command_deg)
            hits.flat[j] += classifier.decide(judge, m, bit.dynamic_pressure_pa).anomaly
    if used == 0:
        raise ConfigError(f"no BIT the dictionary could decide: no visibility ({alarmed} of "
                          f"{len(bits)} healthy BITs flagged as recorded)", field="visibility")
    shares = hits / used
    return Visibility(tuple(float(s) for s in severities),
                      {k: tuple(float(v) for v in shares[i]) for i, k in enumerate(kinds)},
                      used, held_out=held_out is not None, alarmed=alarmed)
