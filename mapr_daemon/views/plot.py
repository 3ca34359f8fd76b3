"""``mapr catalog trend --plot`` and the report's plots: an actuator's SoH and RUL, as a PNG.

Two stacked panels over the actuator's BIT history (one point per BIT), x in flights (or in
flight hours): its state of health on 0..1 with the failure threshold (SoH 0) drawn and
labelled, and its remaining useful life, the median with the 90 % interval shaded. A panel
with nothing to show says so in words. The title carries the figures a maintainer wants first
(SoH now, leading mode, RUL now), so the plot is read in seconds.

matplotlib is optional (not needed by the service); it is imported here only, with the Agg
backend, so the plot works on a headless laptop over SSH.
"""

from __future__ import annotations

import io
import os
import textwrap
from collections.abc import Sequence
from typing import Any

from mapr_daemon.catalog.model import BitRecord

NO_DATA = "no data yet"


def _x(r: BitRecord, hours: bool) -> float | None:
    if hours:
        return r.flight_hours
    return None if r.flight is None else float(r.flight)


def _title(name: str, records: Sequence[BitRecord]) -> str:
    if not records:
        return f"{name}: no BIT history"
    h = records[-1].health
    soh = "SoH ?" if h.soh is None else f"SoH {h.soh:.2f}"
    mode = f", {h.mode} leading" if h.mode else ""
    if h.rul is not None:
        band = ("" if h.rul_low is None or h.rul_high is None
                else f" ({h.rul_low:.0f}-{h.rul_high:.0f}, 90 %)")
        rul = f"; RUL {h.rul:.0f} flights{band}"
    else:
        rul = "; no RUL yet" if h.soh is None or h.soh > 0 else ""
    return f"{name}: {soh}{mode}{rul}"


def _empty(ax: Any, words: str) -> None:
    ax.text(0.5, 0.5, textwrap.fill(words, 60), transform=ax.transAxes, ha="center",
            va="center", fontsize=12, color="0.3", multialignment="center")


def draw(records: Sequence[BitRecord], name: str, out: str | os.PathLike[str] | io.BytesIO,
         *, hours: bool = False) -> None:
    """Draw ``records`` (one actuator's BITs, oldest first) into a PNG file or buffer;
    ``hours``: x in flight hours instead of flights. Raises ImportError without matplotlib."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax_soh, ax_rul) = plt.subplots(2, 1, sharex=True, figsize=(9, 6))
    try:
        points = [(x, r) for r in records if (x := _x(r, hours)) is not None]
        soh = [(x, r.health.soh) for x, r in points if r.health.soh is not None]
        ax_soh.axhline(0.0, color="tab:red", lw=1.5, ls="--")
        ax_soh.text(0.01, 0.015, "failure threshold (SoH 0)", color="tab:red", fontsize=9,
                    va="bottom", transform=ax_soh.get_yaxis_transform())
        if soh:
            ax_soh.plot([x for x, _ in soh], [v for _, v in soh], "o-", ms=3,
                        color="tab:blue", label="state of health")
            faulted = [(x, r.health.soh) for x, r in points
                       if r.fault is not None and r.health.soh is not None]
            if faulted:
                ax_soh.plot([x for x, _ in faulted], [v for _, v in faulted], "s", ms=6,
                            mfc="none", color="tab:orange", label="BIT found a fault")
            ax_soh.legend(loc="upper right", fontsize=9)
        else:
            _empty(ax_soh, f"{NO_DATA}: no BIT with a state of health")
        ax_soh.set_ylim(-0.08, 1.3)
        ax_soh.set_yticks([0.0, 0.2, 0.4, 0.6, 0.8, 1.0])
        ax_soh.set_ylabel("state of health (1 = new)")
        ax_soh.set_title(_title(name, records), fontsize=11)
        ax_soh.grid(True, alpha=0.3)

        unit = "flight hours" if hours else "flights"
        rul = [(x, r.health) for x, r in points if r.health.rul is not None]
        if rul:
            mid = [(h.rul_hours if hours else h.rul) for _, h in rul]
            xs = [x for x, _ in rul]
            ax_rul.plot([x for x, m in zip(xs, mid, strict=True) if m is not None],
                        [m for m in mid if m is not None], "o-", ms=3, color="tab:green",
                        label="RUL (median)")
            band = [(x, lo, hi) for x, h in rul
                    if (lo := h.rul_hours_low if hours else h.rul_low) is not None
                    and (hi := h.rul_hours_high if hours else h.rul_high) is not None]
            if band:
                ax_rul.fill_between([b[0] for b in band], [b[1] for b in band],
                                    [b[2] for b in band], color="tab:green", alpha=0.2,
                                    label="90 % interval")
            ax_rul.set_ylim(0, 1.25 * max(b[2] for b in band) if band else None)
            ax_rul.legend(loc="upper right", fontsize=9)
        else:
            last = records[-1].health.note if records else None
            _empty(ax_rul, f"{NO_DATA}: {last}" if last else f"{NO_DATA}: no RUL estimate")
        ax_rul.set_ylabel(f"RUL ({unit})")
        ax_rul.set_xlabel("flight hours" if hours else "flight number")
        ax_rul.grid(True, alpha=0.3)
        fig.tight_layout()
        fig.savefig(out if isinstance(out, io.BytesIO) else os.fspath(out), dpi=100,
                    format="png")
    finally:
        plt.close(fig)


def png_bytes(records: Sequence[BitRecord], name: str, *, hours: bool = False) -> bytes:
    """The same plot as PNG bytes (for the HTML report)."""
    buffer = io.BytesIO()
    draw(records, name, buffer, hours=hours)
    return buffer.getvalue()
