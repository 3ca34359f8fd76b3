"""The reasoner's face to the daemon and the CLI: signals of one BIT in, one diagnosis out.

>>> # r = Reasoner(Dictionary.load("dictionary.npz"), load_actuator(default_actuator_path()))
>>> # diagnosis = r.diagnose(channels, command_deg, dynamic_pressure_pa)

``channels`` maps the ICD's signal names (``phase_a_current_a``, ``position_deg``,
``dc_bus_voltage_v``, ...) to arrays of one BIT record at the dictionary's sample rate; the
answer is a :class:`~mapr_daemon.findings.Diagnosis` (anomaly, fault, severity in its physical
unit, confidence, the EKF's parameters, SoH, component, the replaceable part and its
ambiguity, evidence), whose :meth:`~mapr_daemon.findings.Diagnosis.to_json` is a line of
``mapr diagnose``.

A record that cannot be diagnosed (non-finite samples, too short, a numerical failure on its
data: :data:`RECORD_ERRORS`) raises from :meth:`Reasoner.diagnose`;
:meth:`Reasoner.diagnose_or_flag` turns that into
:meth:`~mapr_daemon.findings.Diagnosis.failed` (anomaly undecided, confidence 0,
``evidence.error`` naming the error) so a batch goes on with its other records.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from mapr_daemon.arrays import FloatArray
from mapr_daemon.ema.degradation import FAILURE
from mapr_daemon.ema.faults import nominal_value
from mapr_daemon.ema.params import ActuatorParams
from mapr_daemon.errors import RecordError
from mapr_daemon.findings import Diagnosis
from mapr_daemon.reasoner.diagnosis import classifier, parts
from mapr_daemon.reasoner.diagnosis.dictionary import Dictionary
from mapr_daemon.reasoner.ekf.estimator import (
    UNITS,
    Confirmation,
    Estimate,
    ParameterEstimator,
    Reference,
    severity_check,
)
from mapr_daemon.reasoner.ekf.model import NEEDED
from mapr_daemon.reasoner.prognosis import soh, wear_paths

if TYPE_CHECKING:
    from mapr_daemon.reasoner.commissioning.baseline import Baseline
    from mapr_daemon.reasoner.commissioning.severity import Reading
    from mapr_daemon.reasoner.prognosis.prognostic_model import PrognosticModel

RECORD_ERRORS: tuple[type[Exception], ...] = (RecordError, ValueError, ArithmeticError)
"""Errors that concern one record's data, not the dictionary or the configuration: our own
checks (:class:`~mapr_daemon.errors.RecordError`) and the numerical libraries' refusals
(numpy's ``LinAlgError`` and scipy's non-finite checks are ``ValueError``; ``ArithmeticError``
covers division and overflow). A configuration error stays fatal: it would fail every record."""
BASELINE_ERRORS: tuple[type[Exception], ...] = (*RECORD_ERRORS, IndexError, KeyError, TypeError)
"""What the unit's baseline reading may fail with on one record (a baseline whose arrays do not
fit it as well): the dictionary's decision stands, the reason in the evidence."""


def check_record(channels: Mapping[str, FloatArray]) -> None:
    """RecordError naming the channels with NaN or infinite samples (and how many).

    Why here: a NaN does not always raise downstream — in the supply voltage it made every
    statistic NaN, every comparison false, and the record "healthy" with confidence 1.
    """
    bad = {k: int(np.count_nonzero(~np.isfinite(np.asarray(v, dtype=np.float64))))
           for k, v in channels.items()}
    bad = {k: n for k, n in bad.items() if n}
    if bad:
        raise RecordError("non-finite samples in " + ", ".join(
            f"{k} ({n})" for k, n in sorted(bad.items())), field="channels")


class Reasoner:
    """Decides on BIT records against one fault dictionary, for one actuator.

    It keeps the EKF's reference model across records and adapts it by itself (the paper's
    model adaptation): a parameter changed from the reference in the same direction on
    ``confirm_after`` consecutive BITs (:class:`~mapr_daemon.reasoner.ekf.estimator.Confirmation`)
    is confirmed, the
    reference moves to the mean of those estimates, and that record's event says so in
    ``evidence.model_adaptation`` (which parameters, from what to what). Later records'
    ``evidence.parameter_changes`` are measured from the adapted model.

    With the unit's commissioned ``baseline`` (a ``mapr commission`` folder,
    :class:`~mapr_daemon.reasoner.commissioning.baseline.Baseline`), BITs are also read
    against it, and the event's mode, part and severity are the baseline reading's when it
    explains the BIT (:func:`~mapr_daemon.reasoner.commissioning.unit_decision.combine`); both
    readings are in the evidence. When the baseline carries the unit's own detector (a record
    commissioned since there is one), **every** BIT is read, pairs included (about 1.1-1.7 s
    CPU per BIT) and the anomaly decision is
    :func:`~mapr_daemon.reasoner.commissioning.detection.decide`'s (``evidence.detection``
    says which detector fired); without it only the BITs the dictionary flags are read and
    detection is the dictionary's. Either way a nominal BIT of a unit whose record measured
    what its BITs can see names the modes they do not
    (:func:`~mapr_daemon.reasoner.commissioning.detection.unseen`). When the baseline's
    record measured the wear reading's noise
    (:mod:`~mapr_daemon.reasoner.commissioning.wear`) and a prognostic model is set, every
    BIT's wear of the kinds it resolves is read against the baseline too (about 0.36 s CPU
    per BIT), in place of the estimators' (:meth:`baseline_wear`). Without a baseline nothing
    is read and a nominal BIT costs the dictionary's decision alone.
    """

    def __init__(self, dictionary: Dictionary, params: ActuatorParams,
                 confirm_after: int = 3, prognostic: PrognosticModel | None = None,
                 baseline: Baseline | None = None) -> None:
        self.dictionary = dictionary
        self.params = params
        self.baseline = baseline
        self.prognostic = prognostic
        """With it, each event carries ``wear``: the BIT's degradation estimate per aging
        kind, what the actuator's trend is fitted on
        (:mod:`~mapr_daemon.reasoner.prognosis.assessment`)."""
        self.reference = Reference.nominal(params)
        self.confirmation = Confirmation(confirm_after)

    def matrix(self, channels: Mapping[str, FloatArray], command_deg: FloatArray) -> FloatArray:
        """M of one BIT record (:meth:`Dictionary.record_matrix`)."""
        return self.dictionary.record_matrix(channels, command_deg)

    def decide(self, m: FloatArray, dynamic_pressure_pa: float,
               paper: bool = False) -> classifier.Decision:
        """Ours by default, the paper's chosen-curve classifier with ``paper=True``."""
        f = classifier.paper_decide if paper else classifier.decide
        return f(self.dictionary, m, float(dynamic_pressure_pa))

    def diagnose(self, channels: Mapping[str, FloatArray], command_deg: FloatArray,
                 dynamic_pressure_pa: float, paper: bool = False) -> Diagnosis:
        """The diagnosis of one BIT record; one of :data:`RECORD_ERRORS` if it cannot be
        diagnosed, in which case the adaptation state is left as it was."""
        check_record(channels)
        if not math.isfinite(dynamic_pressure_pa):
            raise RecordError("not finite", field="dynamic_pressure_pa")
        m = self.matrix(channels, command_deg)
        est = None  # the EKF needs its channels at the actuator file's sample rate
        if all(k in channels for k in NEEDED) and \
                self.dictionary.sample_rate_hz == self.params.sensors.sample_rate_hz:
            est = ParameterEstimator(self.params, self.reference).run(channels,
                                                                      dynamic_pressure_pa)
        dec = self.decide(m, dynamic_pressure_pa, paper)
        if not (math.isfinite(dec.score) and math.isfinite(dec.confidence)):
            raise RecordError(f"the classifier's statistic is not finite (score {dec.score}, "
                              f"confidence {dec.confidence})", field="classifier")
        if self.baseline is not None and not dec.inconclusive:
            if dec.anomaly or self.baseline.detector is not None:
                dec = self.against_baseline(dec, channels, command_deg, dynamic_pressure_pa)
            else:
                # no detector to weigh a nominal BIT: only what the unit does not see
                from mapr_daemon.reasoner.commissioning.detection import unseen
                dec = unseen(dec, self.baseline)
        diagnosis = self.event(dec, est)
        if est is not None:
            diagnosis = diagnosis.with_evidence(**self._adapt(est))
        if self.prognostic is not None:
            wear = self.prognostic.estimates(self.dictionary, m, dynamic_pressure_pa)
            ours: list[str] = []   # the kinds read against the baseline
            if self.baseline is not None and self.baseline.wear is not None:
                wear, why = self.baseline_wear(wear, channels, command_deg,
                                               dynamic_pressure_pa)
                ours = sorted(k for k in wear if k in self.baseline.wear.read_kinds)
                diagnosis = diagnosis.with_evidence(wear_against_baseline=why or ours)
            diagnosis = dataclasses.replace(
                diagnosis, wear=wear, wear_source=self.wear_source(wear, ours),
                conditions=self.prognostic.bit_conditions(self.dictionary, m,
                                                          dynamic_pressure_pa))
        return diagnosis

    def wear_source(self, wear: Mapping[str, float], ours: Sequence[str]
                    ) -> dict[str, dict[str, Any]]:
        """Per kind of ``wear``, which path read it (:mod:`~mapr_daemon.reasoner.prognosis.
        wear_paths`): the baseline (its record and measured noise) for ``ours``, else the
        estimators."""
        noise = {} if self.baseline is None or self.baseline.wear is None else \
            self.baseline.wear.noise()
        return {k: wear_paths.baseline(self.baseline.record, noise[k])
                if k in ours and self.baseline is not None else wear_paths.estimator()
                for k in wear}

    def baseline_wear(self, wear: Mapping[str, float], channels: Mapping[str, FloatArray],
                      command_deg: FloatArray, dynamic_pressure_pa: float
                      ) -> tuple[dict[str, float], str | None]:
        """The estimators' ``wear`` with every kind the baseline's wear reading resolves
        (:attr:`~mapr_daemon.reasoner.commissioning.wear.BaselineWear.read_kinds`) read
        against :attr:`baseline` instead (on every BIT: the trend needs the healthy-looking
        early ones); the trend weighs those by the baseline's noise
        (:meth:`~mapr_daemon.reasoner.prognosis.prognostic_model.PrognosticModel.against_baseline`).
        A BIT the baseline cannot read drops those kinds (never an estimator's reading under
        the baseline's noise), and why is returned."""
        assert self.baseline is not None and self.baseline.wear is not None
        mine = [k for k in wear if k in self.baseline.wear.read_kinds]
        if not mine:
            return dict(wear), None
        out = {k: v for k, v in wear.items() if k not in mine}
        rate = self.baseline.params.sensors.sample_rate_hz
        if abs(rate - self.dictionary.sample_rate_hz) > 1e-9:
            return out, f"the baseline is at {rate:g} Hz, the record at " \
                        f"{self.dictionary.sample_rate_hz:g} Hz"
        try:
            read = self.baseline.wear_estimates(dict(channels), command_deg,
                                                dynamic_pressure_pa, mine)
        except BASELINE_ERRORS as error:
            return out, f"{type(error).__name__}: {error}"
        if not read:
            return out, "the baseline cannot read this record"
        return {**out, **read}, None

    def against_baseline(self, dec: classifier.Decision, channels: Mapping[str, FloatArray],
                         command_deg: FloatArray, dynamic_pressure_pa: float
                         ) -> classifier.Decision:
        """``dec`` weighed with the BIT's reading against :attr:`baseline` (which must be
        set): :func:`~mapr_daemon.reasoner.commissioning.detection.decide`. A BIT the baseline
        cannot read (a channel it needs missing, a numerical refusal) keeps the dictionary's
        decision, the reason in ``evidence.baseline.unreadable`` when the dictionary flagged
        it."""
        from mapr_daemon.reasoner.commissioning.detection import decide, unseen
        from mapr_daemon.reasoner.commissioning.unit_decision import combine

        assert self.baseline is not None
        reading = self.baseline_reading(channels, command_deg, dynamic_pressure_pa)
        try:
            return decide(dec, reading, self.baseline)
        except BASELINE_ERRORS as error:
            # the detector or the decision on the reading (a record's thresholds, a mode it
            # has no range for) raised: the dictionary's decision stands, never lost
            why = f"{type(error).__name__}: {error}"
            if dec.anomaly:
                return combine(dec, why, self.baseline)
            return unseen(dec, self.baseline)   # what its "no anomaly" does not clear

    def baseline_reading(self, channels: Mapping[str, FloatArray], command_deg: FloatArray,
                         dynamic_pressure_pa: float) -> Reading | str:
        """The BIT read against :attr:`baseline` (which must be set), or why it cannot be."""
        assert self.baseline is not None
        rate = self.baseline.params.sensors.sample_rate_hz
        if abs(rate - self.dictionary.sample_rate_hz) > 1e-9:
            return (f"the baseline is at {rate:g} Hz, the record at "
                    f"{self.dictionary.sample_rate_hz:g} Hz")
        try:
            return self.baseline.read(dict(channels), command_deg, dynamic_pressure_pa)
        except BASELINE_ERRORS as error:
            # a second reading: whatever it cannot read (a record, or a baseline whose
            # arrays do not fit it) leaves the dictionary's decision, never loses it
            return f"{type(error).__name__}: {error}"

    def diagnose_or_flag(self, channels: Mapping[str, FloatArray], command_deg: FloatArray,
                         dynamic_pressure_pa: float, paper: bool = False) -> Diagnosis:
        """:meth:`diagnose`, or :meth:`Diagnosis.failed` when the record cannot be
        diagnosed."""
        try:
            return self.diagnose(channels, command_deg, dynamic_pressure_pa, paper)
        except RECORD_ERRORS as error:
            return Diagnosis.failed(error)

    def _adapt(self, est: Estimate) -> dict[str, Any]:
        """Adapt the reference to what is now confirmed; the evidence that says so (the
        changes from the reference, and the adaptation if there was one)."""
        changes = self.reference.changed(est)
        evidence: dict[str, Any] = {
            "parameter_changes": {k: float(f"{v:.4g}") for k, v in changes.items()}}
        confirmed = self.confirmation.observe(changes, est)
        if not confirmed:
            return evidence
        before = {k: self.reference.value[k] for k in confirmed}
        self.reference.adapt(confirmed)
        evidence["model_adaptation"] = {
            "rule": f"changed the same way on {self.confirmation.consecutive} consecutive "
                    f"BITs beyond {self.reference.k_sd:g} sd and the tolerance",
            "parameters": {k: {"from": float(f"{before[k]:.6g}"),
                               "to": float(f"{v:.6g}"), "unit": UNITS[k]}
                           for k, v in confirmed.items()}}
        return evidence

    def event(self, dec: classifier.Decision,
              estimate: Estimate | None = None) -> Diagnosis:
        """A classifier's decision as a diagnosis.

        ``parameters`` holds the EKF's estimates (value, sd, unit, reference value), and
        ``evidence.severity_check`` compares the classifier's severity with the EKF where the
        fault moves an estimated parameter (friction). ``component`` is the monitored item the
        fault degrades, ``part`` the replaceable part it belongs to, ``ambiguity`` that part's
        members with their probabilities and the group the data cannot separate
        (:func:`~mapr_daemon.reasoner.diagnosis.parts.ambiguity`); all three null without a decided
        fault. A parametric fault's ``evidence`` states what its severity is measured
        against: ``nominal`` (the healthy value) and ``replace_at`` (the failure threshold,
        :func:`~mapr_daemon.reasoner.prognosis.soh.failure_value`), in the severity's unit.
        """
        health = 1.0
        component: str | None = None
        part: str | None = None
        ambiguity: dict[str, Any] | None = None
        if dec.anomaly and dec.pair is not None:
            # the member nearer its replace-at threshold leads: the event's fault, part and SoH
            # are then the same member's
            lead, other = sorted(dec.pair, key=lambda m: soh.soh(self.params, m.fault,
                                                                  m.value))
            dec = dataclasses.replace(dec, fault=lead.fault, severity=lead.severity,
                                      value=lead.value, unit=lead.unit, pair=(lead, other))
        evidence = dict(dec.evidence)
        if dec.anomaly and dec.fault is not None:
            health = soh.soh(self.params, dec.fault, dec.value)
            component = parts.COMPONENTS[dec.fault]
            part = parts.PART_OF[dec.fault]
            # a correct template's residual is wider than the noise by its model error: the
            # member probabilities are weighed on that scale, not on the noise's alone
            ambiguity = parts.ambiguity(
                dec.fault, dec.kind_residuals,
                self.dictionary.calibration.get("chi2_scale", 1.0) * dec.tolerance)
        if dec.anomaly and dec.pair is not None:
            members = [{"fault": m.fault, "severity": float(f"{m.value:.6g}"), "unit": m.unit,
                        "severity_fraction_of_range": round(m.severity, 4),
                        "soh": round(soh.soh(self.params, m.fault, m.value), 4),
                        "component": parts.COMPONENTS[m.fault], "part": parts.PART_OF[m.fault]}
                       for m in dec.pair]
            health = min(soh.soh(self.params, m.fault, m.value) for m in dec.pair)
            evidence["compound"] = {
                "faults": members,
                "rule": "two faults in different parts fit the record better than any single "
                        "fault by more than a single fault's model error allows"}
        evidence.update(score=round(dec.score, 3), threshold=round(dec.threshold, 3))
        if dec.switch:
            evidence["switch"] = dec.switch
        if dec.severity is not None:
            evidence["severity_fraction_of_range"] = round(dec.severity, 4)
        if dec.anomaly and dec.fault in FAILURE and dec.value is not None:
            # what the severity is measured against, for every view to say so
            evidence["nominal"] = float(f"{nominal_value(self.params, dec.fault):.6g}")
            evidence["replace_at"] = float(f"{soh.failure_value(self.params, dec.fault):.6g}")
        check = None if estimate is None or not dec.anomaly else severity_check(
            dec.fault, dec.value, estimate)
        if check is not None:
            evidence["severity_check"] = check
        return Diagnosis(
            anomaly=dec.anomaly, fault=dec.fault,
            severity=None if dec.value is None else float(f"{dec.value:.6g}"),
            unit=dec.unit, confidence=round(dec.confidence, 4),
            parameters={} if estimate is None else estimate.as_event(self.reference),
            soh=round(health, 4), component=component, part=part, ambiguity=ambiguity,
            evidence=evidence)
