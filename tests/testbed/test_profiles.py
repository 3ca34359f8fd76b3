"""Profiles: the four-corner BIT command and a real JSBSim flight's command and air data."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mapr_daemon.errors import ConfigError
from mapr_daemon.testbed.profiles import CONDITIONS, bit_profile
from mapr_daemon.testbed.profiles_jsbsim import jsbsim_flight


def test_bit_profile_has_four_corners() -> None:
    prof = bit_profile(2000.0, "cruise")
    slope = np.diff(prof.command_deg)
    changes = np.flatnonzero(np.abs(np.diff(np.sign(np.round(slope, 9)))) > 0)
    assert len(prof.corners_s) == 4 and changes.size == 4
    assert prof.command_deg.max() == pytest.approx(20.0)
    q = CONDITIONS["cruise"].dynamic_pressure_pa
    assert prof.dynamic_pressure_pa[0] == pytest.approx(q) and 1400 < q < 1700


def test_unknown_condition_is_a_config_error() -> None:
    with pytest.raises(ConfigError, match="unknown flight condition"):
        bit_profile(2000.0, "hover")


def test_jsbsim_flight_is_trimmed_and_manoeuvres() -> None:
    prof = jsbsim_flight(1000.0, "climb", duration_s=12.0, seed=1)
    assert prof.n_samples == 12000
    # trimmed: holds altitude and speed within a light aircraft's margins while turning
    assert np.ptp(prof.altitude_m) < 60.0
    assert np.all(np.abs(prof.airspeed_mps - 40.0) < 4.0)
    # manoeuvres: the autopilot moves the aileron by several degrees both ways
    assert prof.command_deg.min() < -3.0 and prof.command_deg.max() > 0.5
    # air data is self-consistent: q = rho V^2 / 2
    q = 0.5 * prof.density_kg_m3 * prof.airspeed_mps**2
    np.testing.assert_allclose(prof.dynamic_pressure_pa, q, rtol=0.03)


def test_flight_conditions_change_the_air_load() -> None:
    slow = jsbsim_flight(500.0, "approach", duration_s=2.0)
    fast = jsbsim_flight(500.0, "dash", duration_s=2.0)
    assert fast.dynamic_pressure_pa.mean() > 2.5 * slow.dynamic_pressure_pa.mean()


def test_flight_leaves_no_log_file_behind(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    jsbsim_flight(200.0, "cruise", duration_s=0.5)
    assert list(tmp_path.iterdir()) == []
