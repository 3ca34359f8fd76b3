"""``mapr catalog trend --plot``: SoH and RUL of one asset over time, as a PNG.

matplotlib is optional (not needed by the service); it is imported here only, with the Agg
backend, so the plot works on a headless laptop over SSH.
"""

from __future__ import annotations

import datetime as dt
import os
from collections.abc import Sequence

from mapr_daemon.catalog.model import Event


def plot_trend(events: Sequence[Event], asset: str, out: str | os.PathLike[str]) -> None:
    """Two stacked panels, SoH (0..1) and RUL with its bounds shaded; raises ImportError
    when matplotlib is not installed."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    when = [dt.datetime.fromtimestamp(e.t_ns / 1e9, tz=dt.UTC) for e in events]
    fig, (ax_soh, ax_rul) = plt.subplots(2, 1, sharex=True, figsize=(9, 6))
    try:
        soh = [(t, e.soh) for t, e in zip(when, events, strict=True) if e.soh is not None]
        if soh:
            ax_soh.plot([t for t, _ in soh], [v for _, v in soh], "o-", ms=3)
        ax_soh.set_ylim(0, 1.05)
        ax_soh.set_ylabel("state of health")
        ax_soh.set_title(f"{asset}: state of health and remaining useful life")
        ax_soh.grid(True, alpha=0.3)
        rul = [(t, e) for t, e in zip(when, events, strict=True) if e.rul is not None]
        if rul:
            ts = [t for t, _ in rul]
            ax_rul.plot(ts, [e.rul for _, e in rul], "o-", ms=3, label="RUL")
            bounded = [(t, e) for t, e in rul if e.rul_low is not None and e.rul_high is not None]
            if bounded:
                ax_rul.fill_between([t for t, _ in bounded], [e.rul_low for _, e in bounded],
                                    [e.rul_high for _, e in bounded], alpha=0.25,
                                    label="bounds")
            unit = next((e.rul_unit for _, e in rul if e.rul_unit), None)
            ax_rul.set_ylabel(f"RUL ({unit})" if unit else "RUL")
            ax_rul.legend(loc="upper right")
        ax_rul.set_xlabel("time (UTC)")
        ax_rul.grid(True, alpha=0.3)
        fig.autofmt_xdate()
        fig.tight_layout()
        fig.savefig(os.fspath(out), dpi=100)
    finally:
        plt.close(fig)
