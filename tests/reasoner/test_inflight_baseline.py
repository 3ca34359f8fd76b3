"""The unit's in-flight baseline: its first three flights, pending until then, and a flight
stored again (the daemon restarted within it) counted once."""

from __future__ import annotations

import pytest

from mapr_daemon.reasoner.inflight.baseline import Baseline


def _p(friction: float) -> dict[str, dict[str, float | str]]:
    return {"friction": {"value": friction, "sd": 0.02, "unit": "x baseline"},
            "loop_r": {"value": 0.70, "sd": 0.05, "unit": "ohm"}}


def test_the_first_three_flights_commission_and_later_ones_change_from_them() -> None:
    base = Baseline()
    rows = [base.rebase(_p(v), flight) for flight, v in ((1, 1.1), (2, 1.2), (3, 1.3))]
    assert [r["friction"]["baseline"] for r in rows] == ["pending 1/3", "pending 2/3",
                                                         "pending 3/3"]
    assert all(r["friction"]["change"] is None for r in rows)
    worn = base.rebase(_p(1.8), 4)["friction"]
    assert worn["baseline"] == pytest.approx(1.2)
    assert worn["change"] == pytest.approx(1.8 / 1.2 - 1.0, abs=1e-3)   # a ratio
    # against the unit's slow path, not only the tracker's 0.02: the flights' own scatter
    # (1.1, 1.2, 1.3, 1.8 in four flights) and the baseline's, split and recombined
    assert worn["sd_change"] > 3 * 0.02 / 1.2
    assert worn["sd_change"] == pytest.approx(
        (worn["sd_flight"] ** 2 + worn["sd_baseline"] ** 2) ** 0.5, rel=0.01)


def test_a_flight_stored_again_replaces_its_own_value_and_a_restart_rebuilds_it() -> None:
    base = Baseline()
    rows = [(f, base.rebase(_p(v), f)) for f, v in ((1, 1.0), (2, 1.0))]
    again = base.rebase(_p(1.6), 2)["friction"]   # flight 2 after a restart within it
    assert again["baseline"] == "pending 2/3" and base.value("friction") is None
    rows[1] = (2, {"friction": {**again, "value": 1.6}})
    restarted = Baseline()
    restarted.resume(rows)
    assert restarted.seen["friction"] == {1: 1.0, 2: 1.6}
