"""`mapr diagnose` on a file of independent runs: one bad run is flagged, not fatal, and no
state carries from one run to the next (each run's event is the one it gets alone)."""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from mapr_daemon.cli import exitcodes
from mapr_daemon.cli.main import main
from mapr_daemon.ema import dataset
from mapr_daemon.ema.batch import RunSpec
from mapr_daemon.ema.faults import FaultSet
from mapr_daemon.ema.run import RunResult
from mapr_daemon.errors import RecordError
from mapr_daemon.reasoner.reasoner import Reasoner
from mapr_daemon.testbed.profiles import bit_profile
from tests.reasoner.conftest import HELD_OUT, Bench

Poison = Callable[[dict[str, np.ndarray]], None]


def _nan_stretch(name: str) -> Poison:
    def poison(ch: dict[str, np.ndarray]) -> None:
        ch[name][0, 1000:1100] = np.nan
    return poison


def _write(bench: Bench, rows: list[int], path: Path,
           poison: dict[int, Poison] | None = None) -> None:
    """Held-out runs (by HELD_OUT row) as a `mapr simulate` file; ``poison[k]`` spoils the
    k-th run of the file in place."""
    results = []
    own = bench.runs.n - len(HELD_OUT)
    prof = bit_profile(bench.runs.sample_rate_hz, "ground")
    for k, i in enumerate(rows):
        q = HELD_OUT[i][2]
        p = dataclasses.replace(prof, dynamic_pressure_pa=np.full(prof.n_samples, q))
        ch = {name: v[own + i][None, :].copy() for name, v in bench.runs.channels.items()}
        if poison and k in poison:
            poison[k](ch)
        results.append(RunResult((RunSpec(bench.params, FaultSet(), seed=k),), p, p.time_s,
                                 ch, {}))
    dataset.save(path, results, {"actuator": bench.params.name,
                                 "sample_rate_hz": bench.runs.sample_rate_hz})


def _diagnose(capsys: pytest.CaptureFixture[str], *args: str) -> tuple[int, list[dict[str, Any]]]:
    code = main(["diagnose", *args])
    return code, [json.loads(line) for line in capsys.readouterr().out.splitlines()]


ROWS = [0, 4, 1, 3, 2, 5, 6]
"""healthy, friction, healthy (poisoned below), esr, healthy, friction, short: seven runs, so
a reasoner shared across the file would have adapted its reference by the later ones."""


@pytest.mark.parametrize("channel", ["phase_a_current_a", "smps_input_voltage_v"])
def test_a_poisoned_run_is_flagged_and_the_others_match_their_single_run_events(
        bench: Bench, tmp_path: Path, capsys: pytest.CaptureFixture[str], channel: str) -> None:
    dpath, fpath = tmp_path / "d.npz", tmp_path / "runs.npz"
    bench.dictionary.save(dpath)
    _write(bench, ROWS, fpath, {2: _nan_stretch(channel)})
    code, events = _diagnose(capsys, str(fpath), "--dictionary", str(dpath))
    assert code == exitcodes.DATAERR  # every run diagnosed or flagged, one flagged
    assert len(events) == len(ROWS)
    bad = events[2]
    assert bad["anomaly"] is None and bad["confidence"] == 0.0 and bad["fault"] is None
    assert bad["evidence"]["error"]["type"] == "RecordError"
    assert channel in bad["evidence"]["error"]["message"]
    for i, event in enumerate(events):
        assert event["run"] == i
        code_i, alone = _diagnose(capsys, str(fpath), "--dictionary", str(dpath),
                                  "--index", str(i))
        assert alone == [event], i
        assert code_i == (exitcodes.DATAERR if i == 2 else exitcodes.OK)
    healthy, friction, _, esr, _, friction2, short = events
    assert healthy["anomaly"] is False and esr["fault"] == "esr"
    assert friction["fault"] == friction2["fault"] == "friction" and short["fault"] == "short"


def test_same_unit_chains_the_model_adaptation_across_the_file(
        bench: Bench, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    dpath, fpath = tmp_path / "d.npz", tmp_path / "runs.npz"
    bench.dictionary.save(dpath)
    _write(bench, [0, 1, 2, 0, 1], fpath)
    code, separate = _diagnose(capsys, str(fpath), "--dictionary", str(dpath))
    assert code == exitcodes.OK
    assert not any("model_adaptation" in e["evidence"] for e in separate)
    code, chained = _diagnose(capsys, str(fpath), "--dictionary", str(dpath), "--same-unit")
    assert code == exitcodes.OK
    # a new unit's bus proxies have no reference value: three BITs of one unit adapt them
    assert "model_adaptation" in chained[2]["evidence"]
    assert chained[:2] == separate[:2]
    assert chained[3]["parameters"]["bus0"]["reference"] != \
        separate[3]["parameters"]["bus0"]["reference"]


def test_a_bad_index_is_a_usage_error(bench: Bench, tmp_path: Path,
                                      capsys: pytest.CaptureFixture[str]) -> None:
    dpath, fpath = tmp_path / "d.npz", tmp_path / "runs.npz"
    bench.dictionary.save(dpath)
    _write(bench, [0], fpath)
    assert main(["diagnose", str(fpath), "--dictionary", str(dpath), "--index", "1"]) == \
        exitcodes.USAGE
    assert "no run 1" in capsys.readouterr().err


def _held(bench: Bench, i: int) -> dict[str, np.ndarray]:
    own = bench.runs.n - len(HELD_OUT)
    return {k: v[own + i].copy() for k, v in bench.runs.channels.items()}


def test_the_reasoner_flags_a_short_or_overflowing_record_and_keeps_its_state(
        bench: Bench) -> None:
    r = Reasoner(bench.dictionary, bench.params)
    cmd, q = bench.runs.command_deg, HELD_OUT[0][2]
    before = dict(r.reference.value)
    short = {k: v[:40] for k, v in _held(bench, 0).items()}
    event = r.diagnose_or_flag(short, cmd[:40], q)
    assert event.anomaly is None and event.confidence == 0.0
    assert event.evidence["error"]["type"] == "RecordError"
    assert "samples" in event.evidence["error"]["message"]
    huge = _held(bench, 0)
    huge["position_deg"][1000:1100] = 1e30  # finite, but the filter overflows on it
    event = r.diagnose_or_flag(huge, cmd, q)
    assert event.anomaly is None and "error" in event.evidence
    assert r.reference.value == before and r.confirmation.pending() == {}
    with pytest.raises(RecordError):
        r.diagnose(huge, cmd, q)
    assert r.diagnose_or_flag(_held(bench, 0), cmd, q) == \
        Reasoner(bench.dictionary, bench.params).diagnose(_held(bench, 0), cmd, q)
