"""The unit's commissioned baseline, loaded from a ``mapr commission`` folder, and a BIT read
against it: the second reading ``mapr diagnose --commissioned DIR`` reports beside the
dictionary's decision.

A commissioning folder holds the identified actuator (``actuator.yaml``), the record
(``commissioning.json``) and, when enough BITs were used, the learned discrepancy
(``discrepancy.npz``). :meth:`Baseline.load` puts them together; the data sheet the fault
ranges are measured on is the identified actuator with each identified parameter set back to
its data sheet value (both are in the record), so the folder alone is enough.
:meth:`Baseline.read` is :func:`~mapr_daemon.reasoner.commissioning.severity.read` on one BIT,
pairs of two faults included (:mod:`~mapr_daemon.reasoner.commissioning.pairs`).
A record with a ``detector`` (commissioned since it existed) gives the baseline the unit's own
anomaly thresholds (:mod:`~mapr_daemon.reasoner.commissioning.detector`); an older one loads
without, and the dictionary keeps detecting alone. A record with ``wear`` (commissioned since
it existed) gives the measured noise of each aging kind's wear read against the baseline
(:mod:`~mapr_daemon.reasoner.commissioning.wear`): :meth:`Baseline.wear_estimates` is then
what the trend is fitted on instead of the prognostic model's estimators.
"""

from __future__ import annotations

import dataclasses
import hashlib
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from mapr_daemon.arrays import FloatArray
from mapr_daemon.ema.faults import PARAMETRIC, at_severity
from mapr_daemon.ema.params import ActuatorParams, load_actuator
from mapr_daemon.errors import ConfigError
from mapr_daemon.reasoner.commissioning import prior as ip
from mapr_daemon.reasoner.commissioning.bits import BitRecord, unusable
from mapr_daemon.reasoner.commissioning.detector import Detector
from mapr_daemon.reasoner.commissioning.discrepancy import Discrepancy
from mapr_daemon.reasoner.commissioning.pairs import TOP
from mapr_daemon.reasoner.commissioning.record import read_record
from mapr_daemon.reasoner.commissioning.severity import HEALTHY, Reading, read
from mapr_daemon.reasoner.commissioning.visibility import Visibility
from mapr_daemon.reasoner.commissioning.wear import BaselineWear, baseline_estimates

RECORD_FILE = "commissioning.json"


@dataclasses.dataclass(frozen=True)
class Baseline:
    """A unit's commissioned healthy behaviour: identified model plus learned discrepancy."""

    params: ActuatorParams
    """The identified actuator."""
    datasheet: ActuatorParams
    """The data sheet (fault ranges are fractions of its Table 1 range)."""
    discrepancy: Discrepancy
    detector: Detector | None = None
    """The unit's anomaly thresholds on the reading; None: the dictionary detects alone."""
    wear: BaselineWear | None = None
    """The measured noise of each kind's wear read against the baseline; None: the
    prognostic model's estimators read the unit's wear."""
    record: str = ""
    """The record's identity: the first 16 hex digits of the SHA-256 of its
    ``commissioning.json`` (:func:`record_digest`). Each BIT's wear read against this baseline
    names it (:mod:`~mapr_daemon.reasoner.prognosis.wear_paths`), so readings against an
    older commissioning of the same unit are told apart."""
    visibility: Visibility | None = None
    """What the unit's BITs can see of each mode (the record's
    ``unit_calibration.visibility``); None in a record written before, or commissioned
    without a dictionary."""

    @classmethod
    def load(cls, folder: str | Path) -> Baseline:
        """The baseline of a ``mapr commission`` folder; :class:`ConfigError` when its record
        has no discrepancy (commissioned from fewer than 3 BITs, or before there was one)."""
        d = Path(folder)
        record = read_record(d / RECORD_FILE)
        if not record.discrepancy or "file" not in record.discrepancy:
            raise ConfigError("the commissioning record has no learned discrepancy "
                              "(commission again from 3 BITs or more)",
                              path=str(d / RECORD_FILE), field="discrepancy")
        params = load_actuator(d / record.identified_actuator)
        back = {e.path: e.datasheet / ip.get(params, e.path) for e in record.parameters}
        datasheet = ip.scaled(params, back)
        disc = Discrepancy.load(d / str(record.discrepancy["file"]))
        detector = None if record.detector is None else Detector.from_json(
            record.detector, str(d / RECORD_FILE))
        wear = None if record.wear is None else BaselineWear.from_json(
            record.wear, str(d / RECORD_FILE))
        calibration = record.unit_calibration or {}
        if not isinstance(calibration, dict):
            raise ConfigError(f"expected a mapping, got {type(calibration).__name__}",
                              path=str(d / RECORD_FILE), field="unit_calibration")
        seen = calibration.get("visibility")
        return cls(params, datasheet, disc, detector, wear, record_digest(d / RECORD_FILE),
                   None if seen is None else Visibility.from_json(seen, str(d / RECORD_FILE)))

    def read(self, channels: dict[str, FloatArray], command_deg: FloatArray,
             dynamic_pressure_pa: float, pairs: int = TOP) -> Reading | str:
        """The BIT's mode and severity against the baseline, or why it cannot be read;
        ``pairs``: how many of the best single modes' pairs are searched (0: singles only,
        about half the CPU)."""
        bit = BitRecord(channels, command_deg, dynamic_pressure_pa,
                        self.params.sensors.sample_rate_hz, "run", 0)
        why = unusable(self.params, bit)
        if why is not None:
            return why
        return read(self.params, self.datasheet, self.discrepancy, bit,
                    self.discrepancy.decimate, pairs=pairs)

    def wear_estimates(self, channels: dict[str, FloatArray], command_deg: FloatArray,
                       dynamic_pressure_pa: float, kinds: Sequence[str]) -> dict[str, float]:
        """The BIT's wear of each of ``kinds`` that :attr:`wear` measured, read against the
        baseline (:func:`~mapr_daemon.reasoner.commissioning.wear.read`, raw: the trend
        subtracts the measured offset); empty without :attr:`wear` or when the BIT cannot be
        read (a channel missing, a length the baseline does not fly)."""
        if self.wear is None:
            return {}
        bit = BitRecord(channels, command_deg, dynamic_pressure_pa,
                        self.params.sensors.sample_rate_hz, "run", 0)
        if unusable(self.params, bit) is not None:
            return {}
        return baseline_estimates(self.params, self.discrepancy, bit, self.wear, kinds)

    def to_json(self, reading: Reading | str) -> dict[str, Any]:
        """A reading as the JSON ``mapr diagnose`` prints under ``baseline``: the mode (null
        for healthy), the switch, the severity as a fraction of range and as the faulted
        parameter's value, and how much of the record the fault explains (``explained``: the
        mean square, in healthy spreads, of "no fault" minus that of the reading) and, when
        pairs were searched, the best pair (``pair``: both modes, their severities and its
        cost, named or not) and, when the phase currents showed an open switch, what showed it
        (``phase_currents``)."""
        if isinstance(reading, str):
            return {"unreadable": reading}
        value = None
        if reading.mode in PARAMETRIC:
            value = at_severity(self.datasheet, reading.mode,
                                min(max(reading.severity, 0.0), 1.0)).value
        out: dict[str, Any] = {"mode": None if reading.mode == HEALTHY else reading.mode,
                               "switch": reading.switch or None,
                               "severity": round(reading.severity, 4), "value": value,
                               "explained": round(reading.healthy_cost - reading.cost, 4),
                               "cost": round(reading.cost, 4)}
        if reading.open_seen is not None:
            out["phase_currents"] = reading.open_seen.to_json()
        if reading.pair is not None:
            p = reading.pair
            out["pair"] = {"modes": [p.first, p.second],
                           "severities": [round(p.severity_first, 4),
                                          round(p.severity_second, 4)],
                           "cost": round(p.cost, 4)}
        return out


def record_digest(path: str | Path) -> str:
    """A commissioning record's identity: the first 16 hex digits of its file's SHA-256
    (64 bits: two records of one unit never meet by chance)."""
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()[:16]
