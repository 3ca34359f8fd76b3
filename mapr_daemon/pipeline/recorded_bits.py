"""Healthy BITs for commissioning, cut from a Chapter 10 recording of the aircraft's bus.

``mapr commission`` fits a data sheet to a unit's own healthy BITs. On an aircraft those BITs
are in the traffic the daemon recorded (``mapr run`` with ``recording:``, or any IRIG 106
recorder): the recording is read as ``mapr replay`` reads it (the same Chapter 10 reader,
the ICD decoding the messages into signals), one actuator's signals (its wiring,
``assets[].signals``) go to the :class:`~mapr_daemon.pipeline.bitcut.BitCutter` the daemon's
BIT watcher uses, and each BIT cut becomes a
:class:`~mapr_daemon.reasoner.commissioning.bits.BitRecord` named ``recording#index`` (the
index counts the BITs found in the file, from 0), with the time the recording gives its
request (ISO 8601, when its time packets give a full date) and the asset's name as label.

Only cutting happens here, no diagnosis: commissioning needs no dictionary, and a unit being
commissioned has none of its own yet. Whether a BIT is usable (rate, length, motion, the
flight condition inside the envelope) is then decided by commissioning
(:func:`~mapr_daemon.reasoner.commissioning.bits.unusable`), as for ``.npz`` BITs.
"""

from __future__ import annotations

import dataclasses
import datetime as dt
from collections.abc import Sequence
from pathlib import Path

from mapr_daemon.ema.params import ActuatorParams
from mapr_daemon.errors import ConfigError
from mapr_daemon.icd import Icd, SignalStream
from mapr_daemon.pipeline import wiring
from mapr_daemon.pipeline.bitcut import BitCutter, CutBit
from mapr_daemon.pipeline.clock import BusClock, stamp
from mapr_daemon.pipeline.settings import AssetConfig
from mapr_daemon.reasoner.commissioning.bits import BitRecord

BATCH = 8192
"""Messages read and decoded at a time."""


@dataclasses.dataclass(frozen=True)
class RecordedBits:
    """The BITs of one actuator found in one recording, and what was read to find them."""

    path: Path
    asset: AssetConfig
    bits: list[BitRecord]
    """Every BIT recorded whole, in time order."""
    skipped: list[tuple[str, str]]
    """(``recording#index``, why) of each BIT found but not recorded whole."""
    messages: int
    """1553 messages read (on the channels read)."""
    actuator_seen: bool
    """Whether any of the actuator's sensor signals was in the traffic."""
    damaged: int
    """Damaged packets skipped by the reader."""

    @property
    def found(self) -> int:
        """BITs found, recorded whole or not."""
        return len(self.bits) + len(self.skipped)

    def why_none(self, icd: Icd) -> str:
        """Why no BIT could be taken from the recording (one line, for when :attr:`bits` is
        empty)."""
        who = f"{self.asset.name} (RT {self.asset.rt})"
        if not self.messages:
            return "no 1553 message in the recording (on the channels read)"
        if not self.actuator_seen:
            return (f"none of {who}'s signals of the ICD {icd.name} in its "
                    f"{self.messages} messages: another ICD, actuator or --c10-channel?")
        if self.skipped:
            return f"{self.found} BITs of {who}, none on the bus whole ({self.skipped[0][1]})"
        return f"no BIT of {who} in the recording (no initiated BIT request in its traffic)"


def iso_time(abs_ns: int | None) -> str | None:
    """Absolute ns since 1970 UTC as ISO 8601 (``2025-06-01T10:00:02.345Z``); None for None."""
    if abs_ns is None:
        return None
    when = dt.datetime.fromtimestamp(abs_ns // 1_000_000_000, tz=dt.UTC) + \
        dt.timedelta(microseconds=(abs_ns % 1_000_000_000) // 1000)
    return when.isoformat(timespec="milliseconds").replace("+00:00", "Z")


def bits_from_recording(path: Path, params: ActuatorParams, icd: Icd, asset: AssetConfig, *,
                        channels: Sequence[int] | None = None, year: int | None = None
                        ) -> RecordedBits:
    """Every BIT of ``asset`` (data sheet ``params``: its ``bit:`` motion and sample rate) in
    the Chapter 10 file ``path``, read on ``channels`` (default all 1553 channels; ``year``
    for day-of-year time packets) and decoded with ``icd``.

    Raises ConfigError when the asset's wiring names signals the ICD lacks, and
    :class:`~drivers.errors.CaptureFormatError` when the file is not Chapter 10.
    """
    from drivers.chapter10.reader import Chapter10Reader

    missing = wiring.not_in_icd(asset.signals, icd)
    if missing:
        raise ConfigError(f"not in the ICD {icd.name}: {', '.join(missing)}",
                          field=f"assets ({asset.name}).signals")
    cutter = BitCutter(params.bit, params.sensors.sample_rate_hz, signals=asset.signals)
    stream = SignalStream(icd, parameters=cutter.buffers)
    clock = BusClock("recording")
    source = str(path)
    bits: list[BitRecord] = []
    skipped: list[tuple[str, str]] = []
    messages, seen = 0, False

    def take(cut: CutBit) -> None:
        index = len(bits) + len(skipped)
        if cut.missing is not None:
            skipped.append((f"{source}#{index}",
                            f"{cut.missing} not on the bus for the whole test"))
            return
        bits.append(BitRecord(
            channels=cut.channels, command_deg=cutter.profile.command_deg,
            dynamic_pressure_pa=cut.dynamic_pressure_pa,
            sample_rate_hz=float(params.sensors.sample_rate_hz), source=source, index=index,
            time=iso_time(clock.absolute(stamp(cut.request_ns))), label=asset.name))

    reader = Chapter10Reader(path, channels=None if channels is None else set(channels),
                             arinc429=False, year=year)
    try:
        for batch in reader.batches(BATCH):
            columns = batch.ms1553
            if columns is None or not len(columns):
                continue
            messages += len(columns)
            clock.observe(columns)
            series = stream.feed(columns)
            seen |= cutter.seen(series)
            for cut in cutter.feed(series):
                take(cut)
        damaged = len(reader.issues)
    finally:
        reader.close()
    return RecordedBits(path, asset, bits, skipped, messages, seen, damaged)
