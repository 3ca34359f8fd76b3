"""Scoring stated RUL points against the truth: alpha-lambda (point criterion), interval
coverage, leading mode; per unit, and per kind with the worst unit beside the average.

Used by bench/fleet_rul.py for both the catalog's figures and the in-memory path's, so the
two are scored by the same rules.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence

import numpy as np


@dataclasses.dataclass(frozen=True)
class Point:
    """One BIT's stated RUL (in flights) against the truth; ``est`` None: no prediction."""

    flight: float
    """Trajectory flight index of the BIT (t0 = flight 0)."""
    true: float
    est: float | None
    low: float | None
    high: float | None
    lead: str | None
    """The leading mode stated at that BIT."""

    @property
    def within(self) -> bool:
        return self.est is not None and math.isfinite(self.est) and \
            abs(self.est - self.true) <= ALPHA_DEFAULT * self.true

    @property
    def covered(self) -> bool:
        return self.est is not None and self.low is not None and self.high is not None and \
            self.low <= self.true <= self.high


ALPHA_DEFAULT = 0.2


@dataclasses.dataclass(frozen=True)
class UnitScore:
    tail: str
    kind: str
    eol: float
    points: list[Point]
    alpha_lambda: dict[float, bool]
    at_last: Point | None
    """The point scored at the last lambda."""
    leads: bool = True
    """Whether the points state a leading mode (the in-memory path trends the true kind
    only: there is no leading mode to score)."""

    @property
    def coverage(self) -> float:
        return _share([p.covered for p in self.points])

    @property
    def in_band(self) -> float:
        return _share([p.within for p in self.points])

    @property
    def leading(self) -> float:
        return _share([p.lead == self.kind for p in self.points]) if self.leads else math.nan

    @property
    def missing(self) -> int:
        return sum(p.est is None for p in self.points)

    def line(self) -> str:
        al = [str(v) for v in self.alpha_lambda.values()]
        head = (f"{self.tail:>10} {self.kind:>14} {self.eol:6.1f} {len(self.points):4d} "
                f"{self.missing:4d} {al[0]:>7} {al[-1]:>7} {_pct(self.coverage):>6} "
                f"{_pct(self.in_band):>6} {_pct(self.leading):>5}  ")
        p = self.at_last
        if p is None:
            return head + "no point"
        if p.est is None:
            return head + f"{p.true:.1f} / no prediction (kind not evidenced)"
        return head + f"{p.true:.1f} / {_f(p.est)} [{_f(p.low)}, {_f(p.high)}]"


def score_points(tail: str, kind: str, eol: float, points: Sequence[Point],
                 lambdas: Sequence[float], alpha: float, leads: bool = True) -> UnitScore:
    """alpha-lambda at each lambda: at the point nearest ``lambda * eol``, the point estimate
    lies within +-``alpha`` of the true RUL (no point, or no prediction there: a miss)."""
    pts = list(points)
    al: dict[float, bool] = {}
    last: Point | None = None
    for lam in lambdas:
        if not pts:
            al[lam] = False
            continue
        k = int(np.argmin([abs(p.flight - lam * eol) for p in pts]))
        p = last = pts[k]
        al[lam] = p.est is not None and math.isfinite(p.est) and \
            abs(p.est - p.true) <= alpha * p.true
    return UnitScore(tail, kind, eol, pts, al, last, leads)


def kind_summary(name: str, scores: Sequence[UnitScore]) -> str:
    """One line: alpha-lambda pass rate, pooled coverage (per-unit mean and worst), the
    share of points within +-20 %, the leading mode's hit rate, points without prediction,
    and the median ratio of stated to true RUL (late above 1) with the coverage, before half
    life and from half life on."""
    if not scores:
        return f"{name:>14}: no units"
    al = [v for s in scores for v in s.alpha_lambda.values()]
    pts = [p for s in scores for p in s.points]
    covs = [s.coverage for s in scores if s.points]
    unit_al = [_share(list(s.alpha_lambda.values())) for s in scores]
    cover = _share([p.covered for p in pts])
    said = [p for p in pts if p.est is not None]
    worst = min(covs, default=math.nan)
    lead = _share([p.lead == s.kind for s in scores for p in s.points if s.leads])
    early = [p for s in scores for p in s.points if p.flight < 0.5 * s.eol]
    late = [p for s in scores for p in s.points if p.flight >= 0.5 * s.eol]
    return (f"{name:>14}: alpha-lambda {_pct(_share(al))} ({sum(al)}/{len(al)}, worst unit "
            f"{_pct(min(unit_al))}); coverage of the 90 % interval {_pct(cover)} of "
            f"{len(pts)} points (unit mean {_pct(_mean(covs))}, worst {_pct(worst)}); within "
            f"+-20 % {_pct(_share([p.within for p in pts]))}; leading mode = true kind "
            f"{_pct(lead)}; no prediction {sum(p.est is None for p in pts)} (coverage of "
            f"the points with one {_pct(_share([p.covered for p in said]))}, within +-20 % "
            f"{_pct(_share([p.within for p in said]))}); median stated/true RUL before half "
            f"life {_ratio(early)} (coverage {_pct(_share([p.covered for p in early]))}), from "
            f"half life on {_ratio(late)} ({_pct(_share([p.covered for p in late]))})")


def _ratio(points: Sequence[Point]) -> str:
    """The median of stated over true RUL (above 1: late), in the logarithm; a RUL beyond
    the horizon counts as late, a missing one is left out."""
    r = [math.log(max(p.est, 0.1) / p.true) if math.isfinite(p.est) else math.inf
         for p in points if p.est is not None and p.true > 0]
    return f"{math.exp(float(np.median(r))):.2f}x" if r else "n/a"


def _share(flags: Sequence[bool]) -> float:
    return sum(flags) / len(flags) if flags else math.nan


def _mean(xs: Sequence[float]) -> float:
    return float(np.mean(xs)) if xs else math.nan


def _pct(x: float) -> str:
    return "n/a" if math.isnan(x) else f"{100 * x:.0f}%"


def _f(x: float | None) -> str:
    return "none" if x is None else (f"{x:.1f}" if math.isfinite(x) else "inf")
