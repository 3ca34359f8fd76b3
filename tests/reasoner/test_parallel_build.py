"""The batched, threaded build is today's one-batch sequential build, bit for bit.

A run does not depend on the batch it shares, so cutting the runs into small batches flown on
two threads must change nothing: not the channels, not M, not the saved dictionary. The runs
differ (faults, pressures, seeds, flight conditions), so a batch handed back in the wrong
place, or batches sharing a noise generator or a plant state, shows as a difference.
"""

from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np
import pytest

from mapr_daemon.cli import exitcodes
from mapr_daemon.cli.main import main
from mapr_daemon.ema.faults import Fault, FaultSet, at_severity
from mapr_daemon.ema.params import default_actuator_path, load_actuator
from mapr_daemon.errors import ConfigError
from mapr_daemon.reasoner.diagnosis.dictionary import DictionarySpec
from mapr_daemon.reasoner.training import dictionary_build
from mapr_daemon.reasoner.training.corpus import BitRuns, simulate_bit
from mapr_daemon.reasoner.training.workers import resolve, usable_cores

SMALL = DictionarySpec(
    pressures_pa=(0.0, 1500.0), nominal_per_pressure=3, severities=(0.5, 1.0),
    kinds=("esr", "friction"), shorts=("A_high",), opens=("B_low",), seeds_per_point=1,
    healthy_runs=40, calibration_runs=10, record_pool=6, calibration_pressure_pa=(0.0, 2000.0),
    threshold_margin=1.5, subspace_dims=4, knots=(0.0, 0.5, 1.0), seed_base=900)


def test_simulate_bit_in_threaded_batches_equals_one_batch() -> None:
    params = load_actuator(default_actuator_path())
    faults = [FaultSet(), FaultSet.of([at_severity(params, "esr", 0.7)]),
              FaultSet.of([Fault("short", switch="A_high")]), FaultSet(),
              FaultSet.of([at_severity(params, "friction", 0.9)]),
              FaultSet.of([Fault("open", switch="C_low")]), FaultSet()]
    qs = [0.0, 600.0, 1200.0, 1800.0, 2400.0, 300.0, 900.0]
    seeds = [31, 32, 33, 34, 35, 36, 37]
    ambient = [None, -20.0, 45.0, None, 10.0, 60.0, -35.0]
    bus = [26.0, None, 29.5, 27.0, None, 25.5, 28.0]
    one = simulate_bit(params, faults, qs, seeds, ambient_c=ambient, bus_v=bus,
                       workers=1, runs_per_batch=len(faults))
    seen: list[float] = []
    many = simulate_bit(params, faults, qs, seeds, ambient_c=ambient, bus_v=bus,
                        workers=2, runs_per_batch=3, progress=seen.append)
    assert set(many.channels) == set(one.channels)
    for name, values in one.channels.items():
        np.testing.assert_array_equal(many.channels[name], values, err_msg=name)
    assert many.labels == one.labels
    np.testing.assert_array_equal(many.dynamic_pressure_pa, one.dynamic_pressure_pa)
    # the runs really differ, so a batch in the wrong place could not pass the above
    pos = one.channels["position_deg"]
    assert all(not np.array_equal(pos[i], pos[i + 1]) for i in range(len(faults) - 1))
    assert len(seen) > 3 and seen[-1] == 1.0
    assert all(b >= a for a, b in itertools.pairwise(seen))
    # the streaming path (each batch reduced to M in its worker) gives the same M
    starts = dictionary_build.windows(SMALL, one.corners, one.command_deg.size)
    streamed = dictionary_build.stream_matrices(
        params, BitRuns.of(faults, qs, seeds, ambient, bus), starts, SMALL.window_samples,
        workers=2, runs_per_batch=2)
    np.testing.assert_array_equal(
        streamed, dictionary_build.run_matrices(one, starts, SMALL.window_samples))


def test_threaded_build_saves_the_same_dictionary(tmp_path: Path) -> None:
    params = load_actuator(default_actuator_path())
    seen: list[float] = []
    one = dictionary_build.build(params, SMALL, workers=1, runs_per_batch=10_000)
    many = dictionary_build.build(params, SMALL, progress=seen.append, workers=2, runs_per_batch=5)
    one.save(tmp_path / "one.npz")
    many.save(tmp_path / "many.npz")
    assert (tmp_path / "one.npz").read_bytes() == (tmp_path / "many.npz").read_bytes()
    assert seen[-1] == 1.0 and all(b >= a for a, b in itertools.pairwise(seen))


def test_worker_count() -> None:
    assert resolve(None) == usable_cores() >= 1
    assert resolve(3) == 3
    for bad in (0, -1):
        with pytest.raises(ConfigError):
            resolve(bad)


def test_dictionary_build_refuses_a_bad_job_count(tmp_path: Path,
                                                  capsys: pytest.CaptureFixture[str]) -> None:
    try:
        code = main(["dictionary", "build", "-o", str(tmp_path / "d.npz"), "--jobs", "0"])
    except SystemExit as stop:   # argparse's usage error
        code = int(stop.code or 0)
    assert code == exitcodes.USAGE
    assert "--jobs" in capsys.readouterr().err
    assert not (tmp_path / "d.npz").exists()
