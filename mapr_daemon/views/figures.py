"""An actuator's health figures in words: one way of writing them, used by every view.

``mapr demo``, ``mapr health``, ``mapr catalog list/show/trend``, the daemon's log and the
report all write SoH, RUL and a fault's severity through these functions, so one actuator
shows the same figures, rounded the same way, wherever it is read (the issue this answers:
``catalog list`` said SoH 0.8 and ``0 flights [0-0]`` where ``health`` said 0.79 and
``0.0 (0.0-0.0)``). The rules:

* **SoH** with two decimals (``0.79``); in a sentence with what it measures: the share of the
  way from new to the leading mode's replace-at threshold that is left
  (``SoH 0.79 (esr: 21 % of the way to its replace-at threshold)``);
* **RUL** in flights (or flight hours) as the median and the 90 % interval,
  ``42 (30-61) flights``: a figure of 10 or more without decimals, a smaller one with one
  (``4.5 (2.1-8.0) flights``); ``0`` once the part is at its threshold. Where the trend
  states none, the reason (:attr:`~mapr_daemon.findings.Health.note`) stands in its place;
* **severity** as the value, as a multiple of nominal and against the replace-at threshold
  (``esr 0.31 ohm = 6.2x nominal; replace at 2x``) when the diagnosis stated its nominal
  value and threshold (``evidence["nominal"]``/``evidence["replace_at"]``), with the share
  of the fault's Table 1 range beside it where a table has room for it.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from mapr_daemon.findings import Health


def soh_text(soh: float | None) -> str:
    """``0.79``; ``-`` when there is no SoH (no trend)."""
    return "-" if soh is None else f"{soh:.2f}"


def number(value: float | None) -> str:
    """A RUL figure: ``42`` from 10 up, ``4.5`` below, ``-`` when unknown, ``beyond`` past
    the trend's horizon (``inf``)."""
    if value is None:
        return "-"
    if not math.isfinite(value):
        return "beyond"
    if abs(value) >= 10:
        return f"{value:.0f}"
    text = f"{value:.1f}"
    return "0" if text in ("0.0", "-0.0") else text


def rul_text(mid: float | None, low: float | None = None, high: float | None = None,
             unit: str = "flights") -> str:
    """``42 (30-61) flights``; ``-`` when there is no figure; the interval only when both
    bounds are known and differ from the median as written (``0 flights`` at the
    threshold, not ``0 (0-0)``)."""
    if mid is None:
        return "-"
    band = f" ({number(low)}-{number(high)})" if low is not None and high is not None else ""
    if band == f" ({number(mid)}-{number(mid)})":   # at the threshold: ``0 flights``
        band = ""
    return f"{number(mid)}{band} {unit}"


def health_rul(h: Health, hours: bool = False) -> str:
    """The health's RUL in flights (``hours``: in flight hours; empty when there is none in
    hours), or, without a figure in flights, the reason in words."""
    if hours:
        if h.rul_hours is None:
            return ""
        return rul_text(h.rul_hours, h.rul_hours_low, h.rul_hours_high, "h")
    if h.rul is None:
        return h.note or "unknown"
    return rul_text(h.rul, h.rul_low, h.rul_high)


def soh_meaning(h: Health) -> str:
    """What the SoH measures: ``esr: 21 % of the way to its replace-at threshold``, or why
    it is 1 or unknown."""
    if h.soh is None:
        return "no trend"
    if h.mode is None:
        return "no part wears measurably"
    if h.mode in ("short", "open"):
        return f"{h.mode}: the part has failed"
    return f"{h.mode}: {100 * (1.0 - h.soh):.0f} % of the way to its replace-at threshold"


def health_summary(h: Health) -> str:
    """One line: ``SoH 0.79 (esr: 21 % of the way to its replace-at threshold); RUL 42
    (30-61) flights``, or the reason where the trend states no RUL."""
    if h.mode is None and h.soh is not None:   # nothing wears: the note says it all
        return f"SoH {soh_text(h.soh)} ({h.note or soh_meaning(h)}); no RUL"
    rul = (f"RUL {rul_text(h.rul, h.rul_low, h.rul_high)}" if h.rul is not None
           else f"no RUL: {h.note}" if h.note else "no RUL")
    return f"SoH {soh_text(h.soh)} ({soh_meaning(h)}); {rul}"


def _float(value: Any) -> float | None:
    return float(value) if isinstance(value, (int, float)) else None


MULTIPLIERS = ("x", "x nominal")
"""Units that already are a multiple of nominal (friction's factor)."""


def severity_text(mode: str | None, value: float | None, unit: str | None,
                  evidence: Mapping[str, Any]) -> str:
    """``esr 0.31 ohm = 6.2x nominal; replace at 2x``: the faulted parameter's value, as a
    multiple of its nominal and against the replace-at threshold (both from the
    diagnosis's evidence, ``nominal`` and ``replace_at`` in the value's unit); the value
    alone when the evidence states neither (catalogs written before they were stored);
    ``terminal`` for a shorted or open switch."""
    if value is None:
        return "terminal"
    name = f"{mode} " if mode else ""
    nominal, replace_at = _float(evidence.get("nominal")), _float(evidence.get("replace_at"))
    if unit in MULTIPLIERS:
        text = f"{name}{value:.2g}x nominal"
    elif nominal:
        text = f"{name}{value:.3g} {unit or ''} = {value / nominal:.2g}x nominal"
    else:
        return f"{name}{value:.3g}{' ' + unit if unit else ''}"
    if nominal and replace_at is not None:
        text += f"; replace at {replace_at / nominal:.2g}x"
    return text.replace("  ", " ")


__all__ = ["health_rul", "health_summary", "number", "rul_text", "severity_text",
           "soh_meaning", "soh_text"]


INFLIGHT_ORDER: tuple[str, ...] = ("friction", "loop_r", "phase_a_ron", "bus0")
"""The in-flight parameters in the order every view lists them."""


def inflight_change(name: str, parameter: Mapping[str, Any]) -> str:
    """One in-flight parameter's change from the unit's baseline with its sd, both to the
    sd's second significant digit: ``friction +0.500 +/- 0.020 x baseline``;
    ``friction baseline pending 2/3`` until the baseline is commissioned."""
    change, sd = _float(parameter.get("change")), _float(parameter.get("sd_change"))
    unit = str(parameter.get("unit", ""))
    if change is None:
        return f"{name} baseline {parameter.get('baseline', 'pending')}"
    if sd is None or not sd > 0.0:
        return f"{name} {change:+.3g} {unit}".rstrip()
    digits = max(0, 1 - math.floor(math.log10(sd)))
    text = f"{change:+.{digits}f}"
    if float(text) == 0.0:
        text = f"{0.0:+.{digits}f}"
    return f"{name} {text} +/- {sd:.{digits}f} {unit}".rstrip()


def inflight_lines(row: Any) -> list[str]:
    """A flight's in-flight estimate (:class:`~mapr_daemon.catalog.model.InflightEstimate`)
    as lines: the flight and how much of it qualified, then one line per parameter."""
    params: Mapping[str, Mapping[str, Any]] = row.parameters
    head = (f"flight {row.flight if row.flight is not None else '-'}: in-flight estimate "
            f"from {row.filtered_s:.0f} s of {row.flight_s:.0f} s")
    names = [n for n in INFLIGHT_ORDER if n in params] + \
        [n for n in params if n not in INFLIGHT_ORDER]
    return [head, *(f"  {inflight_change(n, params[n])}" for n in names)]


def inflight_json(row: Any) -> dict[str, Any]:
    """The same row for ``--json`` and the export: flight, seconds and per parameter its
    stored figures with the text the tables print."""
    params: Mapping[str, Mapping[str, Any]] = row.parameters
    return {"flight": row.flight, "t_ns": row.t_ns, "flight_s": row.flight_s,
            "filtered_s": row.filtered_s, "qualified_s": dict(row.qualified_s),
            "parameters": {n: {**dict(p), "text": inflight_change(n, p)}
                           for n, p in params.items()}}
