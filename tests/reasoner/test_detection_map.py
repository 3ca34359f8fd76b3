"""Where each mode is seen: the detection map a dictionary carries, what a decision says of the
modes blind at its condition, and `mapr dictionary describe`."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

from mapr_daemon.reasoner.diagnosis.detection_map import BLIND_BELOW, DetectionMap
from mapr_daemon.reasoner.diagnosis.dictionary import Dictionary

BUS = (22.0, 24.0, 26.0, 28.0)
AMB = (-40.0, 0.0, 40.0, 70.0)


def _map() -> DetectionMap:
    runs = []
    for bus in (23.0, 25.0, 27.0):
        for amb in (-20.0, 20.0, 60.0):
            runs += [("esr", bus, amb, True)] * 4
            # the low side seen only above 26 V, and there in three of four runs
            runs += [("smps_ron_low", bus, amb, bus > 26.0 and k < 3) for k in range(4)]
    return DetectionMap.measure(BUS, AMB, runs)


def test_the_map_counts_each_cell_and_names_the_blind_modes() -> None:
    dm = _map()
    assert dm.runs_per_cell == 4
    assert dm.detected["esr"] == ((1.0,) * 3,) * 3
    assert dm.detected["smps_ron_low"][0] == (0.0, 0.0, 0.0)
    assert dm.detected["smps_ron_low"][2] == (0.75, 0.75, 0.75)
    assert dm.blind(23.5, 10.0) == ["smps_ron_low"]
    assert dm.blind(27.5, 10.0) == []
    # beyond the envelope the outer bands hold
    assert dm.blind(19.0, -60.0) == ["smps_ron_low"] and dm.blind(31.0, 90.0) == []
    assert DetectionMap.from_json(json.loads(json.dumps(dm.as_json()))) == dm
    # a cell no run landed in says nothing: not blind, "no runs" in the table
    sparse = DetectionMap.measure(BUS, AMB, [("esr", 23.0, -20.0, True)])
    assert sparse.blind(27.0, 60.0) == [] and sparse.runs_per_cell == 0
    assert "no runs" in "\n".join(sparse.table())
    assert json.loads(json.dumps(sparse.as_json()))["detected"]["esr"][2][2] is None
    text = "\n".join(dm.table())
    assert "smps_ron_low" in text and "0%*" in text and f"{BLIND_BELOW:.0%}" in text


def test_describe_prints_the_modes_thresholds_and_map(dictionary: Path) -> None:
    d = Dictionary.load(dictionary)
    assert d.detection is not None and set(d.detection.detected) == {"esr", "friction"}
    out = subprocess.run([sys.executable, "-m", "mapr_daemon.cli.main", "dictionary",
                          "describe", str(dictionary)], capture_output=True, text=True,
                         timeout=120)
    assert out.returncode == 0, out.stderr
    assert "parametric modes: esr, friction" in out.stdout
    assert "pair gain (two faults)" in out.stdout and "where each mode is seen" in out.stdout
    assert "switch temperatures: not read" in out.stdout
    doc = json.loads(subprocess.run(
        [sys.executable, "-m", "mapr_daemon.cli.main", "dictionary", "describe",
         str(dictionary), "--json"], capture_output=True, text=True, timeout=120,
        check=True).stdout)
    assert doc["detection_map"] == d.detection.as_json()
    assert doc["switch_temperatures"] == []
    assert doc["thresholds"]["anomaly (likelihood ratio)"] == d.threshold
