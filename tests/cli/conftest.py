"""Shared by the ``mapr commission`` tests: what keeps a commissioning fast."""

from __future__ import annotations

from pathlib import Path

import pytest

TINY_SPEC = """\
pressures_pa: [0, 1500]
nominal_per_pressure: 2
severities: [0.5, 1.0]
kinds: [esr]
shorts: [A_high]
opens: [A_high]
healthy_runs: 40
calibration_runs: 10
calibration_pressure_pa: [0, 1500]
subspace_dims: 4
knots: [0.0, 0.5, 1.0]
"""
TOLERANCES = """\
format: mapr-tolerances/1
parameters:
  motor.back_emf_v_s_per_rad: 5
  motor.inertia_kg_m2: 15
"""


@pytest.fixture(scope="session")
def commission_settings(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A folder with ``spec.yaml`` (a tiny dictionary spec: one kind, two severities, two
    pressures) and ``tolerances.yaml`` (two parameters to identify): a commissioning in
    seconds, for tests of the workflow rather than of its figures."""
    d = tmp_path_factory.mktemp("commission-settings")
    (d / "spec.yaml").write_text(TINY_SPEC)
    (d / "tolerances.yaml").write_text(TOLERANCES)
    return d
