"""What the reasoner finds: a :class:`Diagnosis` per BIT, an actuator's :class:`Health` after it.

Plain frozen records with no behaviour of the reasoner's, so that every reader (the pipeline,
the catalog, the CLI, the fleet) can use them without importing the reasoner. The JSON form
of a diagnosis (``mapr diagnose``'s lines, the catalog's stored evidence) is made in one
place, :meth:`Diagnosis.to_json`, and read back by :meth:`Diagnosis.from_json`.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import Any


@dataclasses.dataclass(frozen=True)
class Diagnosis:
    """The reasoner's verdict on one BIT record.

    ``anomaly`` is None when the record could not be diagnosed (:meth:`failed`; the reason
    is in ``evidence["error"]``). ``severity`` is the faulted parameter's value in ``unit``;
    ``soh`` the diagnosed component's state of health (1 healthy, 0 at its failure threshold);
    ``component`` the monitored item the fault degrades, ``part`` the replaceable part it
    belongs to, ``ambiguity`` that part's members with their probabilities and the group the
    data cannot separate (all three None without a decided fault). ``parameters`` are the
    EKF's estimates (value, sd, unit, reference). ``wear`` and ``conditions`` (with a
    prognostic model) are the BIT's degradation estimate per aging kind and the flight
    condition it was flown at: what the trend is fitted on; ``wear_source`` says per kind
    which path read it (the estimators, or the unit's commissioned baseline with the
    record's identity and measured noise:
    :mod:`~mapr_daemon.reasoner.prognosis.wear_paths`), so the trend weighs each reading by
    its own path's noise and offset.
    """

    anomaly: bool | None
    fault: str | None
    severity: float | None
    unit: str | None
    confidence: float
    parameters: Mapping[str, Any] = dataclasses.field(default_factory=dict)
    soh: float | None = None
    component: str | None = None
    part: str | None = None
    ambiguity: Mapping[str, Any] | None = None
    rul: Mapping[str, Any] | None = None
    """The RUL as its JSON form (``rul``/``low``/``high`` in flights); None from one BIT."""
    evidence: Mapping[str, Any] = dataclasses.field(default_factory=dict)
    """Why: score and threshold, the switch, the severity as a fraction of range, the
    EKF's severity check and parameter changes, model adaptation, or ``error``."""
    wear: Mapping[str, float] | None = None
    conditions: Mapping[str, float] | None = None
    wear_source: Mapping[str, Mapping[str, Any]] | None = None

    @classmethod
    def failed(cls, error: BaseException) -> Diagnosis:
        """A record that could not be diagnosed: anomaly undecided, confidence 0, and
        ``evidence["error"]`` = {type, message}."""
        return cls(anomaly=None, fault=None, severity=None, unit=None, confidence=0.0,
                   evidence={"error": {"type": type(error).__name__, "message": str(error)}})

    @property
    def faults(self) -> tuple[str, ...]:
        """Every fault the diagnosis names: the two of a compound diagnosis
        (``evidence["compound"]``, the more severe first), else ``fault`` alone, else none."""
        found = self.evidence.get("compound")
        if isinstance(found, Mapping):
            return tuple(str(m["fault"]) for m in found.get("faults", ()))
        return () if self.fault is None else (self.fault,)

    @property
    def unexplained(self) -> bool:
        """An anomaly no known fault mode (single or pair) explains."""
        return bool(self.anomaly) and self.fault is None and "unexplained" in self.evidence

    @property
    def error(self) -> Mapping[str, Any] | None:
        """``{type, message}`` when the record could not be diagnosed, else None."""
        found = self.evidence.get("error")
        return found if isinstance(found, Mapping) else None

    @property
    def severity_fraction(self) -> float | None:
        """The severity as a fraction of the fault's Table 1 range (None without one)."""
        value = self.evidence.get("severity_fraction_of_range")
        return None if value is None else float(value)

    @property
    def switch(self) -> str | None:
        """The switch of a short or open fault (``A_high`` ...), else None."""
        value = self.evidence.get("switch")
        return None if value is None else str(value)

    def with_evidence(self, **extra: Any) -> Diagnosis:
        """A copy whose evidence also holds ``extra`` (e.g. where on the bus the BIT was)."""
        return dataclasses.replace(self, evidence={**self.evidence, **extra})

    def to_json(self) -> dict[str, Any]:
        """The JSON-ready form (``mapr diagnose``'s line): anomaly, fault, severity, unit,
        confidence, parameters, soh, component, part, ambiguity, rul, evidence in that order,
        then ``wear``, ``conditions`` and ``wear_source`` when present."""
        out: dict[str, Any] = {
            "anomaly": self.anomaly, "fault": self.fault, "severity": self.severity,
            "unit": self.unit, "confidence": self.confidence,
            "parameters": dict(self.parameters), "soh": self.soh,
            "component": self.component, "part": self.part,
            "ambiguity": None if self.ambiguity is None else dict(self.ambiguity),
            "rul": None if self.rul is None else dict(self.rul),
            "evidence": dict(self.evidence),
        }
        if self.wear is not None:
            out["wear"] = dict(self.wear)
        if self.conditions is not None:
            out["conditions"] = dict(self.conditions)
        if self.wear_source is not None:
            out["wear_source"] = {k: dict(v) for k, v in self.wear_source.items()}
        return out

    @classmethod
    def from_json(cls, doc: Mapping[str, Any]) -> Diagnosis:
        """Read back :meth:`to_json`'s form (keys it lacks take their defaults)."""
        severity, soh = doc.get("severity"), doc.get("soh")
        return cls(anomaly=doc.get("anomaly"), fault=doc.get("fault"),
                   severity=None if severity is None else float(severity),
                   unit=doc.get("unit"), confidence=float(doc.get("confidence") or 0.0),
                   parameters=dict(doc.get("parameters") or {}),
                   soh=None if soh is None else float(soh),
                   component=doc.get("component"), part=doc.get("part"),
                   ambiguity=doc.get("ambiguity"), rul=doc.get("rul"),
                   evidence=dict(doc.get("evidence") or {}),
                   wear=doc.get("wear"), conditions=doc.get("conditions"),
                   wear_source=doc.get("wear_source"))


@dataclasses.dataclass(frozen=True)
class Health:
    """One actuator's health after one BIT, as its trend states it.

    RUL figures are ``inf`` where the trend does not reach the failure threshold within its
    horizon (the catalog stores NULL and ``note`` says so), None where unknown.
    """

    soh: float | None
    """1.0 as commissioned, 0.0 at the leading mode's failure threshold; None with no trend
    (no prognostic model, no estimates)."""
    mode: str | None = None
    """The leading fault mode (the part the RUL is of); None when nothing wears measurably."""
    rul: float | None = None
    rul_low: float | None = None
    rul_high: float | None = None
    """RUL in flights: median and the bounds of an :attr:`interval` interval."""
    rul_hours: float | None = None
    rul_hours_low: float | None = None
    rul_hours_high: float | None = None
    """The same in flight hours (:meth:`with_hours`)."""
    note: str | None = None
    """Why a figure is missing, in words."""
    modes: Mapping[str, Any] = dataclasses.field(default_factory=dict)
    """Per trended kind: current degradation ``h``, its z, evidenced, and its RUL (``rul``,
    ``low``, ``high`` in flights, None beyond the horizon; absent with BITs on fewer than
    three flights), stated whether or not the kind is evidenced."""
    interval: float = 0.9

    def with_hours(self, hours_per_flight: float | None, interval: float) -> Health:
        """A copy with the RUL also in flight hours (None where unknown, or with no mean
        flight length yet), at the assessment's interval."""
        rh = rhl = rhh = None
        if hours_per_flight is not None and math.isfinite(hours_per_flight):
            rh, rhl, rhh = (None if v is None else v * hours_per_flight
                            for v in (self.rul, self.rul_low, self.rul_high))
        return dataclasses.replace(self, rul_hours=rh, rul_hours_low=rhl, rul_hours_high=rhh,
                                   modes=dict(self.modes), interval=interval)


__all__ = ["Diagnosis", "Health"]
