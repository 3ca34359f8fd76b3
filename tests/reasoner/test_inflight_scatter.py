"""A per-flight change's stated sd holds the unit's slow path: the flight-to-flight scatter
learned from the unit's own flights and the baseline's uncertainty (issue 29).

Synthetic units: friction along the aging model's shape, a unit offset off the data sheet,
each flight's value multiplied by its own scatter (lognormal) and read by a tracker with a
small sd of its own; the truth is the path's change from new. Through the stored rows'
:class:`Baseline`, as the daemon stores them.
"""

from __future__ import annotations

import numpy as np
import pytest

from mapr_daemon.reasoner.inflight.baseline import Baseline
from mapr_daemon.reasoner.inflight.scatter import learn

Z90 = 1.645


def _unit(rng: np.random.Generator, tau: float, tracker: float = 0.01,
          wild: int | None = None) -> list[tuple[float, float, float, float, float]]:
    """One unit's stored friction rows: (change, true change, sd_change, sd_flight,
    sd_baseline) for every flight with a change."""
    life = rng.uniform(40.0, 80.0)
    n = np.arange(int(life))
    path = 1.0 + 2.0 * (n / life) ** 1.5
    offset = rng.lognormal(0.0, 0.2)
    base = Baseline()
    out = []
    for k in n:
        v = offset * path[k] * np.exp(tau * rng.standard_normal()) \
            * (1.0 + tracker * rng.standard_normal())
        if wild is not None and k == wild:
            v *= 3.0
        r = base.rebase({"friction": {"value": v, "sd": tracker * v}}, int(k) + 1)["friction"]
        if r["change"] is not None:
            out.append((r["change"], path[k] - 1.0, r["sd_change"], r["sd_flight"],
                        r["sd_baseline"]))
    return out


@pytest.mark.parametrize("tau", [0.05, 0.1, 0.2])
def test_the_stated_90_percent_band_holds_the_path_on_about_90_percent_of_flights(
        tau: float) -> None:
    rng = np.random.default_rng(int(tau * 1000))
    rows = np.array([r for _ in range(60) for r in _unit(rng, tau)])
    covered = np.abs(rows[:, 0] - rows[:, 1]) <= Z90 * rows[:, 2]
    assert 0.86 <= covered.mean() <= 0.94, f"scatter {tau}: covers {covered.mean():.3f}"
    # the tracker's own sd (a tenth of the scatter or less) would hold it far less often
    tracker_only = np.abs(rows[:, 0] - rows[:, 1]) <= Z90 * 0.01 * (1.0 + rows[:, 0])
    assert tracker_only.mean() < 0.5


def test_the_band_is_learned_per_unit_wider_on_a_unit_that_scatters_more() -> None:
    rng = np.random.default_rng(3)
    calm = np.array(_unit(rng, 0.04))
    wild = np.array(_unit(rng, 0.2))
    # the flights' own sd relative to 1 + change: the scatter itself, learned
    calm_rel = np.median(calm[:, 3] / (1.0 + calm[:, 0]))
    wild_rel = np.median(wild[:, 3] / (1.0 + wild[:, 0]))
    assert 0.03 < calm_rel < 0.07 and 0.14 < wild_rel < 0.3, (calm_rel, wild_rel)


def test_the_first_flights_after_the_baseline_are_covered_too() -> None:
    """Flights 4-8: two to seven differences measured the scatter; the t widening keeps
    their band honest (and their baseline part is most of it)."""
    rng = np.random.default_rng(11)
    early = np.array([r for _ in range(400) for r in _unit(rng, 0.1)[:5]])
    covered = np.abs(early[:, 0] - early[:, 1]) <= Z90 * early[:, 2]
    assert 0.86 <= covered.mean() <= 0.98, covered.mean()


def test_one_wild_flight_does_not_widen_the_later_flights_much() -> None:
    plain = _unit(np.random.default_rng(5), 0.1)
    spoiled = _unit(np.random.default_rng(5), 0.1, wild=20)
    later = slice(40, None)
    ratio = np.median(np.array(spoiled)[later, 3] / np.array(plain)[later, 3])
    assert ratio < 1.25, f"a flight read 3x moved the later flights' sd by {ratio:.2f}x"


def test_fewer_than_three_flights_state_no_scatter() -> None:
    assert learn([1.0, 1.1], [0.01, 0.01], ratio=True) is None
    s = learn([1.0, 1.1, 0.95], [0.01, 0.01, 0.01], ratio=True)
    assert s is not None and s.tau2 > 0.0 and s.widen > 2.0   # one degree of freedom
