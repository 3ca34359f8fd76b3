"""Fault-curve plots in the manner of the paper's Figures 13-15 (chosen curve per fault type)
and 17 (all possible curves, one per row of V). matplotlib with the Agg backend: files only,
no display needed (a service host has none)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from mapr_daemon.reasoner.diagnosis.dictionary import Dictionary


def plot_dictionary(d: Dictionary, out_dir: str | Path) -> list[Path]:
    """Write ``<kind>-curve.png`` and ``<kind>-all-curves.png`` per parametric kind."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    written: list[Path] = []
    for kind, c in d.paper.items():
        t = next(t for t in d.templates if t.kind == kind and not t.switch)
        x = np.array([_nominal(t.severities, t.values), *t.values])
        fig, ax = plt.subplots(figsize=(6, 4))
        for k, q in enumerate(d.pressures_pa):
            ax.plot(x, c.curve[k], marker="o", ms=3, label=f"q = {q:g} Pa")
        ax.set_xlabel(f"seeded {kind} ({t.unit})")
        ax.set_ylabel(f"distance from nominal N, cell {c.reference}")
        ax.set_title(f"{kind} fault curve ({d.columns[c.col]}, window {c.row + 1})")
        ax.legend(fontsize=7)
        fig.tight_layout()
        path = out / f"{kind}-curve.png"
        fig.savefig(path, dpi=100)
        plt.close(fig)
        written.append(path)
        fig, ax = plt.subplots(figsize=(6, 4))
        vals = c.v[:, :-1]
        scale = np.where(vals[:, -1] > 0, vals[:, -1], 1.0)
        for row in vals / scale[:, None]:
            ax.plot(x[1:], row, lw=0.5, alpha=0.5)
        ax.set_xlabel(f"seeded {kind} ({t.unit})")
        ax.set_ylabel("N / N at the highest degradation")
        ax.set_title(f"all {vals.shape[0]} possible {kind} curves (ones of G)")
        fig.tight_layout()
        path = out / f"{kind}-all-curves.png"
        fig.savefig(path, dpi=100)
        plt.close(fig)
        written.append(path)
    return written


def _nominal(severities: tuple[float, ...], values: tuple[float, ...]) -> float:
    s0, s1, v0, v1 = severities[0], severities[1], values[0], values[1]
    return float(v0 - s0 * (v1 - v0) / (s1 - s0))
