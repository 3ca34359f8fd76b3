"""Engineering values next to raw words, for ``decode --icd`` and ``monitor --icd``.

The message-table code (and its YAML parser) is imported only when a table is given, so a
plain ``mapr decode`` does not pay for it at start-up."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from drivers.mil1553.record import MonitorRecord
    from mapr_daemon.icd import Icd


class IcdView:
    """Decode records with a message table; records it does not describe give nothing."""

    def __init__(self, path: str | None) -> None:
        self.icd: Icd | None = None
        if path:
            from mapr_daemon.icd import load_icd

            self.icd = load_icd(path)

    def text(self, record: MonitorRecord) -> str:
        if self.icd is None or record.command is None:
            return ""
        from mapr_daemon.icd import format_decoded

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
