"""What decoding gives back: per-parameter :class:`Series` and one record's :class:`DecodedMessage`.

Every decoded parameter is a time series — a scalar in one record is a series of one sample, a
repeating-group channel has one sample per group entry — so one shape serves the single-record
API, the batch decoder and the signal stream the reasoner consumes. Values are ``float64``
(enumerations and discretes carry their code; :meth:`Series.text` gives the label); ``flags``
holds :mod:`~mapr_daemon.icd.flags` bits per sample.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from drivers.mil1553.record import MonitorRecord
from mapr_daemon.icd.flags import flag_names
from mapr_daemon.icd.model import Message, Parameter

I64 = npt.NDArray[np.int64]
F64 = npt.NDArray[np.float64]
U8 = npt.NDArray[np.uint8]


@dataclass(frozen=True, slots=True)
class Series:
    """Samples of one parameter: time (ns, the monitor's clock), value, raw bits, flags."""

    parameter: Parameter
    t_ns: I64
    value: F64
    raw: I64
    flags: U8

    @property
    def name(self) -> str:
        return self.parameter.name

    @property
    def unit(self) -> str:
        return self.parameter.unit

    def __len__(self) -> int:
        return len(self.t_ns)

    @property
    def flagged(self) -> npt.NDArray[np.bool_]:
        """True where a sample carries any flag."""
        flagged: npt.NDArray[np.bool_] = self.flags != 0
        return flagged

    def flag_names(self, index: int) -> tuple[str, ...]:
        return flag_names(int(self.flags[index]))

    def text(self, index: int) -> str:
        """One sample as text: enumeration label, or value with the digits its LSB justifies."""
        p = self.parameter
        label = p.label(int(self.raw[index])) if p.labels else None
        if label is not None:
            return label
        value = float(self.value[index])
        if np.isnan(value):
            return "nan"
        return f"{value:.{p.decimals()}f}"

    def take(self, mask: npt.NDArray[np.bool_]) -> Series:
        """The samples where ``mask`` is true."""
        return Series(self.parameter, self.t_ns[mask], self.value[mask], self.raw[mask],
                      self.flags[mask])

    @staticmethod
    def concat(parts: Sequence[Series]) -> Series:
        """Join pieces of the same parameter, in order."""
        if len(parts) == 1:
            return parts[0]
        return Series(parts[0].parameter,
                      np.concatenate([s.t_ns for s in parts]),
                      np.concatenate([s.value for s in parts]),
                      np.concatenate([s.raw for s in parts]),
                      np.concatenate([s.flags for s in parts]))


@dataclass(frozen=True, slots=True)
class DecodedMessage:
    """One record decoded with the table: its message and a :class:`Series` per parameter."""

    message: Message
    record: MonitorRecord
    values: dict[str, Series] = field(default_factory=dict)

    @property
    def t_ns(self) -> int:
        return self.record.t_ns

    def value(self, name: str, index: int = 0) -> float:
        """The engineering value of ``name`` (sample ``index`` for group channels)."""
        return float(self.values[name].value[index])

    def flags(self, name: str, index: int = 0) -> tuple[str, ...]:
        return self.values[name].flag_names(index)

    def as_dict(self) -> dict[str, Any]:
        """Names to values: a float (or label) for scalars, a list for group channels."""
        group = {c.name for c in self.message.group.channels} if self.message.group else set()
        out: dict[str, Any] = {}
        for name, s in self.values.items():
            items: list[Any] = [s.parameter.label(int(r)) or float(v) if s.parameter.labels
                                else float(v) for v, r in zip(s.value, s.raw, strict=True)]
            out[name] = items if name in group else items[0]
        return out
