"""Engineering values next to raw words, for ``decode --icd`` and ``monitor --icd``."""

from __future__ import annotations

from typing import Any

from drivers.mil1553.record import MonitorRecord
from mapr_daemon.icd import Icd, format_decoded, load_icd


class IcdView:
    """Decode records with a message table; records it does not describe give nothing."""

    def __init__(self, path: str | None) -> None:
        self.icd: Icd | None = load_icd(path) if path else None

    def text(self, record: MonitorRecord) -> str:
        if self.icd is None or record.command is None:
            return ""
        decoded = self.icd.decode(record)
        return "" if decoded is None else format_decoded(decoded)

    def values(self, record: MonitorRecord) -> dict[str, Any] | None:
        if self.icd is None or record.command is None:
            return None
        decoded = self.icd.decode(record)
        if decoded is None:
            return None
        out: dict[str, Any] = {"message": decoded.message.name, **decoded.as_dict()}
        flagged = {}
        for name, series in decoded.values.items():
            names = sorted({f for i in range(len(series)) for f in series.flag_names(i)})
            if names:
                flagged[name] = names
        if flagged:
            out["flags"] = flagged
        return out
