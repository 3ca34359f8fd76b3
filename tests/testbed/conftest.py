"""Small fault dictionaries and prognostic models of the two testbed EMAs at their bus rates
(the aileron at 2 kHz, the elevator at 1 kHz): healthy and ESR only, ~20 s for both."""

from __future__ import annotations

from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def small_models(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A directory of ``{aileron,elevator}-{dictionary,prognosis}.npz``."""
    from mapr_daemon.ema.params import load_actuator, with_sample_rate
    from mapr_daemon.reasoner.diagnosis.dictionary import DictionarySpec
    from mapr_daemon.reasoner.training import dictionary_build
    from mapr_daemon.reasoner.training.prognosis_build import BuildSpec, build_prognostic_model

    spec = DictionarySpec(pressures_pa=(0.0, 1600.0), nominal_per_pressure=2,
                          severities=(0.5, 1.0), kinds=("esr",), shorts=(), opens=(),
                          healthy_runs=48, calibration_runs=12, envelope=True,
                          ground_share=0.2, threshold_margin=1.5)
    where = tmp_path_factory.mktemp("models")
    for surface, rate in (("aileron", 2000.0), ("elevator", 1000.0)):
        params = with_sample_rate(
            load_actuator(ROOT / "configs" / "actuators" / f"{surface}-uav.yaml"), rate)
        d = dictionary_build.build(params, spec)
        d.save(where / f"{surface}-dictionary.npz")
        build_prognostic_model(d, params, BuildSpec(training_bits=60, calibration_reps=2,
                                                    fleet_units=8),
                               kinds=("esr",)).save(where / f"{surface}-prognosis.npz")
    return where
