"""The commissioning record: what was identified, how sure, from which BITs (one JSON file).

Written by ``mapr commission`` beside the identified actuator file and the dictionary built
on it. Format ``mapr-commissioning/1``::

    {"format": "mapr-commissioning/1", "created": "2025-01-01T00:00:00+00:00",
     "actuator": "aileron-uav", "datasheet": "configs/actuators/aileron-uav.yaml",
     "identified_actuator": "actuator.yaml", "dictionary": "dictionary.npz",
     "parameters": [{"path": "motor.resistance_ohm", "datasheet": 0.3, "value": 0.2868,
                     "fitted": 0.2868, "sd_rel": 0.005, "prior_sd_rel": 0.05,
                     "identifiable": true}, ...],
     "tolerances": [{"path": ..., "minus_pct": 10, "plus_pct": 10}, ...],
     "residual_rms": {"before": {"dc_link_current_a": 0.031, ...}, "after": {...}},
     "bits": [{"source": "bits.npz", "index": 0, "time": null, "label": "healthy",
               "dynamic_pressure_pa": 1500.0, "ambient_c": 12.3, "bus_v": 27.4,
               "friction_factor": 0.97, "residual": 0.3}, ...],
     "skipped": [{"bit": "bits.npz#3", "reason": "non-finite values in position_deg"}],
     "correlation": [[1.0, ...], ...], "fit": {"iterations": 15, "converged": true,
     "model_runs": 1188, "wall_s": 7.1},
     "unit_calibration": {...},
     "discrepancy": {"file": "discrepancy.npz", "criterion": ..., "bits": 12,
                     "features": [...], "signals": {"position_deg": {"rank": 2, ...,
                     "held_out_rms_model": 240.1, "held_out_rms_corrected": 30.2}, ...}},
     "detector": {"rule": ..., "alpha": 0.001, "statistics": {"no_fault": {"scale": ...,
                  "dof": ..., "threshold": 2.9, "largest_held_out": 1.8,
                  "held_out": [...]}, "explained": {...}}},
     "wear": {"rule": ..., "grid": [...], "kinds": {"esr": {"offset": 0.01, "sd0": 0.05,
              "sd1": 0.02, "held_out": [...]}, ...}}}

``discrepancy`` (None in records written before it existed, or with too few BITs) says
what the learned discrepancy
(:mod:`~mapr_daemon.reasoner.commissioning.discrepancy`) explains: per signal the held-out
residual without and with it, in noise units. ``detector`` (None in records written before
it existed: the dictionary then detects alone) holds the unit's own anomaly thresholds
(:mod:`~mapr_daemon.reasoner.commissioning.detector`). ``wear`` (None before it existed:
the prognostic model's estimators then read the unit's wear) holds each aging kind's wear
reading against the baseline measured on the held-out BITs
(:mod:`~mapr_daemon.reasoner.commissioning.wear`).

``value`` is what the identified actuator file holds (the fit where identifiable, else the
data sheet's); ``sd_rel`` the posterior sd of its logarithm (a relative sd).
"""

from __future__ import annotations

import dataclasses
import datetime
import json
from pathlib import Path
from typing import Any

from mapr_daemon.errors import ConfigError
from mapr_daemon.reasoner.commissioning.identify import Estimate, Identification, UsedBit
from mapr_daemon.reasoner.commissioning.prior import Tolerance

FORMAT = "mapr-commissioning/1"


@dataclasses.dataclass(frozen=True)
class CommissioningRecord:
    """A commissioning: the identification's outcome and where its files are."""

    created: str
    actuator: str
    datasheet: str
    identified_actuator: str
    dictionary: str | None
    parameters: tuple[Estimate, ...]
    tolerances: tuple[Tolerance, ...]
    residual_before: dict[str, float]
    residual_after: dict[str, float]
    bits: tuple[UsedBit, ...]
    skipped: tuple[tuple[str, str], ...]
    correlation: tuple[tuple[float, ...], ...]
    iterations: int
    converged: bool
    model_runs: int
    wall_s: float
    unit_calibration: dict[str, Any] | None = None
    """What calibrating the dictionary to the unit's own BITs did
    (:class:`~mapr_daemon.reasoner.commissioning.calibrate.UnitCalibration`); None without a
    dictionary."""
    discrepancy: dict[str, Any] | None = None
    """The learned discrepancy's file and summary
    (:meth:`~mapr_daemon.reasoner.commissioning.discrepancy.Discrepancy.summary`); None when
    none was learned."""
    detector: dict[str, Any] | None = None
    """The unit's anomaly detector on the baseline reading
    (:meth:`~mapr_daemon.reasoner.commissioning.detector.Detector.to_json`); None when none
    was calibrated (no discrepancy, or a record written before there was one)."""
    wear: dict[str, Any] | None = None
    """Each aging kind's wear reading against the baseline, measured held out
    (:meth:`~mapr_daemon.reasoner.commissioning.wear.BaselineWear.to_json`); None when none
    was measured."""

    @classmethod
    def of(cls, ident: Identification, tolerances: tuple[Tolerance, ...], datasheet: str,
           identified_actuator: str, dictionary: str | None,
           unit_calibration: dict[str, Any] | None = None,
           discrepancy: dict[str, Any] | None = None,
           detector: dict[str, Any] | None = None,
           wear: dict[str, Any] | None = None) -> CommissioningRecord:
        """The record of ``ident``, stamped now (UTC)."""
        return cls(
            created=datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
            actuator=ident.params.name, datasheet=datasheet,
            identified_actuator=identified_actuator, dictionary=dictionary,
            parameters=ident.estimates, tolerances=tuple(tolerances),
            residual_before=dict(ident.residual_before),
            residual_after=dict(ident.residual_after), bits=ident.bits, skipped=ident.skipped,
            correlation=ident.correlation, iterations=ident.iterations,
            converged=ident.converged, model_runs=ident.model_runs, wall_s=ident.wall_s,
            unit_calibration=unit_calibration, discrepancy=discrepancy, detector=detector,
            wear=wear)

    def to_json(self) -> dict[str, Any]:
        return {
            "format": FORMAT, "created": self.created, "actuator": self.actuator,
            "datasheet": self.datasheet, "identified_actuator": self.identified_actuator,
            "dictionary": self.dictionary,
            "parameters": [dataclasses.asdict(e) for e in self.parameters],
            "tolerances": [dataclasses.asdict(t) for t in self.tolerances],
            "residual_rms": {"before": self.residual_before, "after": self.residual_after},
            "bits": [dataclasses.asdict(b) for b in self.bits],
            "skipped": [{"bit": b, "reason": r} for b, r in self.skipped],
            "correlation": [list(row) for row in self.correlation],
            "fit": {"iterations": self.iterations, "converged": self.converged,
                    "model_runs": self.model_runs, "wall_s": self.wall_s},
            "unit_calibration": self.unit_calibration,
            "discrepancy": self.discrepancy,
            "detector": self.detector,
            "wear": self.wear,
        }

    @classmethod
    def from_json(cls, doc: Any, path: str = "<record>") -> CommissioningRecord:
        """Parse :meth:`to_json`'s output; :class:`ConfigError` naming what is wrong."""
        if not isinstance(doc, dict) or doc.get("format") != FORMAT:
            got = doc.get("format") if isinstance(doc, dict) else None
            raise ConfigError(f"expected format {FORMAT}, got {got!r}", path=path,
                              field="format")
        try:
            fit = doc["fit"]
            return cls(
                created=str(doc["created"]), actuator=str(doc["actuator"]),
                datasheet=str(doc["datasheet"]),
                identified_actuator=str(doc["identified_actuator"]),
                dictionary=None if doc["dictionary"] is None else str(doc["dictionary"]),
                parameters=tuple(Estimate(**e) for e in doc["parameters"]),
                tolerances=tuple(Tolerance(**t) for t in doc["tolerances"]),
                residual_before={str(k): float(v)
                                 for k, v in doc["residual_rms"]["before"].items()},
                residual_after={str(k): float(v)
                                for k, v in doc["residual_rms"]["after"].items()},
                bits=tuple(UsedBit(**b) for b in doc["bits"]),
                skipped=tuple((str(s["bit"]), str(s["reason"])) for s in doc["skipped"]),
                correlation=tuple(tuple(float(v) for v in row) for row in doc["correlation"]),
                iterations=int(fit["iterations"]), converged=bool(fit["converged"]),
                model_runs=int(fit["model_runs"]), wall_s=float(fit["wall_s"]),
                unit_calibration=doc.get("unit_calibration"),
                discrepancy=doc.get("discrepancy"), detector=doc.get("detector"),
                wear=doc.get("wear"))
        except (KeyError, TypeError, ValueError, AttributeError) as error:
            raise ConfigError(f"malformed commissioning record ({error})", path=path) from None


def write_record(path: str | Path, record: CommissioningRecord) -> None:
    """Write the record as indented JSON."""
    Path(path).write_text(json.dumps(record.to_json(), indent=1) + "\n", encoding="utf-8")


def read_record(path: str | Path) -> CommissioningRecord:
    """Read a record written by :func:`write_record`."""
    p = Path(path)
    try:
        doc = json.loads(p.read_text(encoding="utf-8"))
    except OSError as error:
        raise ConfigError(f"cannot read: {error.strerror}", path=str(p)) from None
    except json.JSONDecodeError as error:
        raise ConfigError(f"not JSON: {error.msg} at line {error.lineno}", path=str(p)) from None
    return CommissioningRecord.from_json(doc, str(p))
