"""``mapr simulate`` end to end: a batch spec and a single run, read back with numpy alone."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from mapr_daemon.cli import exitcodes
from mapr_daemon.cli.main import main


def test_batch_spec_writes_truth_and_signals(tmp_path: Path) -> None:
    spec = tmp_path / "spec.yaml"
    spec.write_text(
        "profile: bit\nconditions: [ground, cruise]\nsample_rate_hz: 1000\nruns:\n"
        "  - healthy\n  - {fault: esr, severities: [1.0]}\n"
        "  - {faults: [short=A_high, smps_ron_low=1.0]}\n")
    out = tmp_path / "d.npz"
    assert main(["simulate", "--batch", str(spec), "-o", str(out)]) == 0
    with np.load(out, allow_pickle=False) as d:
        assert d["ch_position_deg"].shape == (6, d["time_s"].size)
        assert list(d["run_label"][:3]) == ["healthy", "esr=1", "short=A_high+smps_ron_low=1"]
        assert d["fault_kind"].shape == (6, 2) and d["fault_kind"][2, 1] == "smps_ron_low"
        assert d["fault_severity"][1, 0] == 1.0 and np.isnan(d["fault_value"][0, 0])
        assert json.loads(str(d["meta_json"]))["sample_rate_hz"] == 1000.0
        q = d["in_dynamic_pressure_pa"]
        assert q[0].max() == 0.0 and q[3].min() > 1000.0  # ground, then cruise
        esr_ripple = d["ch_ripple_rms_v"][1].mean()
        assert esr_ripple > 3 * d["ch_ripple_rms_v"][0].mean()


def test_bad_fault_is_a_one_line_config_error(tmp_path: Path, capsys: object) -> None:
    code = main(["simulate", "--fault", "esr=lots", "-o", str(tmp_path / "x.npz")])
    assert code == exitcodes.CONFIG
    assert not (tmp_path / "x.npz").exists()


def test_a_condition_anywhere_in_the_envelope_is_flown_as_given(tmp_path: Path) -> None:
    """--pressure, --ambient and --bus-voltage set the run's condition (a cold ground BIT on a
    low bus): the air data is 0 Pa, the power stage reads the ambient, the SMPS input the bus."""
    out = tmp_path / "cold.npz"
    assert main(["simulate", "--pressure", "0", "--ambient", "-35", "--bus-voltage", "23",
                 "-o", str(out)]) == 0
    data = np.load(out)
    assert np.all(data["in_dynamic_pressure_pa"] == 0.0)
    assert abs(data["ch_stage_temperature_c"][0, :20].mean() - (-35.0)) < 1.0
    assert abs(data["ch_smps_input_voltage_v"][0].mean() - 23.0) < 0.5


def test_a_condition_outside_its_range_is_refused_with_exit_2(tmp_path: Path,
                                                               capsys: Any) -> None:
    try:
        code = main(["simulate", "--pressure", "-5", "-o", str(tmp_path / "x.npz")])
    except SystemExit as stop:
        code = int(stop.code or 0)
    assert code == exitcodes.USAGE
    assert "--pressure" in capsys.readouterr().err and not (tmp_path / "x.npz").exists()
