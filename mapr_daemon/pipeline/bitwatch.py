"""From bus signals to the reasoner: find each built-in test in the traffic, diagnose it.

The reasoner decides on one BIT record (the four-corner motion of the actuator's ``bit:``
section) sampled at the dictionary's rate and aligned on the profile's time axis. Which ICD
signal is which reasoner channel is the asset's wiring (:mod:`.wiring`, ``assets[].signals``
in the daemon config). Where a BIT starts on the bus and what its record holds is decided by
:class:`~mapr_daemon.pipeline.bitcut.BitCutter` (shared with commissioning from a recording);
:class:`BitWatch` hands each cut record to :meth:`Reasoner.diagnose` with the dynamic pressure
the air-data computer reported meanwhile.
"""

from __future__ import annotations

import dataclasses
import logging
from collections.abc import Mapping

from mapr_daemon.arrays import FloatArray
from mapr_daemon.ema.params import BitParams
from mapr_daemon.ema.profile import Profile
from mapr_daemon.findings import Diagnosis
from mapr_daemon.icd import Series
from mapr_daemon.pipeline.bitcut import BitCutter, CutBit
from mapr_daemon.reasoner.reasoner import Reasoner

log = logging.getLogger("mapr.reasoner")


@dataclasses.dataclass(frozen=True)
class BitFound:
    """One BIT found on the bus and diagnosed."""

    request_ns: int
    """Time tag of the record that carried the request (the event's bus time)."""
    onset_ns: int
    """Time tag of the BIT record's first sample."""
    decision: Diagnosis
    """The reasoner's diagnosis, its evidence saying where on the bus the BIT was."""


class BitWatch:
    """Cuts each BIT out of the signals (:class:`BitCutter`) and yields the reasoner's event
    for it.

    ``signals`` is the asset's wiring (ICD signal -> reasoner channel or role; default the
    shipped testbed ICD's), ``bit`` its BIT motion (default the reasoner's actuator's).
    """

    def __init__(self, reasoner: Reasoner, *, signals: Mapping[str, str] | None = None,
                 bit: BitParams | None = None, threshold: float | None = None,
                 paper: bool = False) -> None:
        self.reasoner = reasoner
        self.paper = paper
        if threshold is not None:
            reasoner.dictionary.threshold = float(threshold)
        self.cutter = BitCutter(reasoner.params.bit if bit is None else bit,
                                reasoner.dictionary.sample_rate_hz, signals=signals)
        self.bits_seen = 0
        self.last_onset: int | None = None
        """First-sample time tag of the last BIT diagnosed."""
        self.failures: list[tuple[int, str]] = []
        """(first-sample time tag, error) of each BIT the reasoner failed on in the last
        :meth:`feed` call."""
        self.failure_count = 0

    @property
    def profile(self) -> Profile:
        """The BIT motion the records are cut on."""
        return self.cutter.profile

    def seen(self, series: Mapping[str, Series]) -> bool:
        """Whether a batch carries any of this actuator's sensor channels."""
        return self.cutter.seen(series)

    def feed(self, series: Mapping[str, Series]) -> list[BitFound]:
        """Take a batch of decoded series; returns the BITs completed by it, diagnosed."""
        self.failures = []
        events: list[BitFound] = []
        for cut in self.cutter.feed(series):
            self.bits_seen += 1
            self.last_onset = cut.onset_ns
            if cut.missing is not None:
                log.warning("BIT at bus time %.3f s: %s not on the bus for the whole test; "
                            "skipped", cut.onset_ns / 1e9, cut.missing)
                continue
            try:
                decision = self._diagnose(cut)
            except Exception as error:  # a reasoner fault costs this BIT, not the daemon
                log.exception("BIT at bus time %.3f s: the reasoner failed; BIT skipped",
                              cut.onset_ns / 1e9)
                self.failures.append((cut.onset_ns, f"{type(error).__name__}: {error}"))
                self.failure_count += 1
                continue
            events.append(BitFound(cut.request_ns, cut.onset_ns, decision))
        return events

    def record(self, onset: int) -> tuple[dict[str, FloatArray], float] | None:
        """The BIT record whose first sample is time-tagged ``onset`` (reasoner channel ->
        samples on the profile's grid) and the median dynamic pressure during it, from what
        the buffers still hold; None when a channel was not on the bus for the whole test."""
        cut = self.cutter.cut(onset, onset)
        return None if cut.missing is not None else (cut.channels, cut.dynamic_pressure_pa)

    def _diagnose(self, cut: CutBit) -> Diagnosis:
        q = cut.dynamic_pressure_pa
        diagnosis = self.reasoner.diagnose(cut.channels, self.profile.command_deg, q,
                                           paper=self.paper).with_evidence(
            bit_bus_time_s=round(cut.onset_ns / 1e9, 6), dynamic_pressure_pa=round(q, 1))
        log.info("BIT at bus time %.3f s: %s (score %.0f, threshold %.0f)", cut.onset_ns / 1e9,
                 f"{diagnosis.fault} anomaly" if diagnosis.anomaly else "nominal",
                 diagnosis.evidence.get("score", 0.0), diagnosis.evidence.get("threshold", 0.0))
        return diagnosis
