"""Aging trajectories: monotone trends along their shapes and a recorded true end of life."""

from __future__ import annotations

import numpy as np
import pytest

from mapr_daemon.ema.degradation import FAILURE, trajectory
from mapr_daemon.ema.params import default_actuator_path, load_actuator
from mapr_daemon.errors import ConfigError


@pytest.mark.parametrize("kind", sorted(FAILURE))
def test_trajectory_reaches_failure_at_recorded_eol(kind: str) -> None:
    p = load_actuator(default_actuator_path())
    tr = trajectory(p, kind, 400, seed=5, scatter=0.0)
    assert tr.values[0] == pytest.approx(tr.nominal)
    assert 100 < tr.eol_flight < 300
    k = int(tr.eol_flight)
    falling = kind == "capacitance"
    before, after = tr.values[k - 1], tr.values[k + 2]
    if falling:
        assert before > tr.threshold >= after
        assert np.all(np.diff(tr.values) <= 0)
    else:
        assert before < tr.threshold <= after
        assert np.all(np.diff(tr.values) >= 0)
    assert tr.rul(0) == pytest.approx(tr.eol_flight) and tr.rul(k + 5) == 0.0


def test_units_differ_and_are_reproducible() -> None:
    p = load_actuator(default_actuator_path())
    a = trajectory(p, "smps_ron_high", 300, seed=1)
    b = trajectory(p, "smps_ron_high", 300, seed=2)
    assert a.eol_flight != b.eol_flight
    np.testing.assert_array_equal(a.values, trajectory(p, "smps_ron_high", 300, seed=1).values)
    with pytest.raises(ConfigError):
        trajectory(p, "short", 10, seed=1)
