"""`mapr diagnose` and `mapr dictionary plot` on the small dictionary and held-out runs."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from mapr_daemon.cli.main import main
from mapr_daemon.ema import dataset
from mapr_daemon.ema.batch import RunSpec
from mapr_daemon.ema.faults import Fault, FaultSet, at_severity
from mapr_daemon.ema.run import RunResult
from mapr_daemon.testbed.profiles import bit_profile
from tests.reasoner.conftest import HELD_OUT, Bench, commissioned_folder


def _write_runs(bench: Bench, rows: list[int], path: Path) -> None:
    """Held-out runs as a `mapr simulate` file (one RunResult per run: its own pressure)."""
    results = []
    own = bench.runs.n - len(HELD_OUT)
    for i in rows:
        kind, sev, q = HELD_OUT[i]
        faults = (FaultSet() if kind == "healthy" else
                  FaultSet.of([Fault(kind, switch="A_high")]) if kind in ("short", "open") else
                  FaultSet.of([at_severity(bench.params, kind, sev)]))
        prof = bit_profile(bench.runs.sample_rate_hz, "ground")
        prof = dataclasses.replace(prof, dynamic_pressure_pa=np.full(prof.n_samples, q))
        ch = {k: v[own + i][None, :] for k, v in bench.runs.channels.items()}
        results.append(RunResult((RunSpec(bench.params, faults, seed=i),), prof, prof.time_s,
                                 ch, {}))
    dataset.save(path, results, {"actuator": bench.params.name,
                                 "sample_rate_hz": bench.runs.sample_rate_hz})


def test_diagnose_prints_the_issue_json(bench: Bench, tmp_path: Path,
                                        capsys: pytest.CaptureFixture[str]) -> None:
    dpath = tmp_path / "d.npz"
    bench.dictionary.save(dpath)
    rows = [0, 4]  # healthy, friction@0.8
    _write_runs(bench, rows, tmp_path / "runs.npz")
    assert main(["diagnose", str(tmp_path / "runs.npz"), "--dictionary", str(dpath)]) == 0
    lines = capsys.readouterr().out.strip().splitlines()
    events = [json.loads(line) for line in lines]
    keys = {"anomaly", "fault", "severity", "unit", "confidence", "parameters", "soh", "rul"}
    assert all(keys <= set(e) for e in events)
    healthy, fric = events
    assert healthy["anomaly"] is False and healthy["fault"] is None and healthy["soh"] == 1.0
    assert fric["anomaly"] is True and fric["fault"] == "friction" and fric["unit"] == "x"
    assert abs(fric["severity"] - (1 + 0.8 * 4)) < 0.6  # factor 4.2 on a 1..5 range
    assert fric["soh"] == 0.0  # beyond 3x nominal: failed
    assert main(["diagnose", str(tmp_path / "runs.npz"), "--dictionary", str(dpath),
                 "--index", "1", "--paper"]) == 0
    paper = json.loads(capsys.readouterr().out)
    assert set(paper["evidence"]["curves"]) == {"esr", "friction"}


def test_diagnose_rejects_a_bad_dictionary(tmp_path: Path,
                                           capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "junk.npz").write_bytes(b"not a zip")
    assert main(["diagnose", str(tmp_path / "junk.npz"), "--dictionary",
                 str(tmp_path / "junk.npz")]) != 0
    assert "dictionary" in capsys.readouterr().err


def test_dictionary_plot_writes_the_curves(bench: Bench, tmp_path: Path) -> None:
    dpath = tmp_path / "d.npz"
    bench.dictionary.save(dpath)
    assert main(["dictionary", "plot", str(dpath), "-o", str(tmp_path / "plots")]) == 0
    pngs = sorted(p.name for p in (tmp_path / "plots").glob("*.png"))
    assert pngs == ["esr-all-curves.png", "esr-curve.png", "friction-all-curves.png",
                    "friction-curve.png"]
    assert all((tmp_path / "plots" / p).read_bytes()[:4] == b"\x89PNG" for p in pngs)


def test_prognose_scores_a_friction_unit(bench: Bench, tmp_path: Path,
                                         capsys: pytest.CaptureFixture[str]) -> None:
    dpath = tmp_path / "d.npz"
    bench.dictionary.save(dpath)
    assert main(["prognose", "friction:1", "--dictionary", str(dpath), "--bit-every", "25"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["kind"] == "friction" and np.all(np.diff(out["flights"]) == 25.0)
    assert out["flights"][0] == 0.0 and out["flights"][-1] <= out["eol_flight"]
    est, true = np.array(out["degradation_est"]), np.array(out["degradation_true"])
    assert np.all(np.abs(est - true)[1:] < 0.35)  # friction is strongly observable
    assert est[-1] > 0.6
    assert set(out["alpha_lambda"]) == {"0.5", "0.75"}
    for p in out["predictions"]:
        assert p["rul_true"] > 0


def test_diagnose_adds_the_reading_against_a_commissioned_baseline(
        bench: Bench, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # a commissioning folder made from six of the bench's healthy runs (the unit is the data
    # sheet's twin here: the discrepancy has little to learn, the reading is what is tested)
    folder = tmp_path / "unit"
    folder.mkdir()
    commissioned_folder(bench, folder)
    dpath = tmp_path / "d.npz"
    bench.dictionary.save(dpath)
    _write_runs(bench, [0, 4], tmp_path / "runs.npz")   # healthy, friction@0.8
    assert main(["diagnose", str(tmp_path / "runs.npz"), "--dictionary", str(dpath),
                 "--commissioned", str(folder)]) == 0
    healthy_line, fric_line = [json.loads(x) for x in capsys.readouterr().out.splitlines()]
    assert fric_line["fault"] == "friction"   # the dictionary's decision is still there
    base = fric_line["baseline"]
    assert base["mode"] == "friction" and abs(base["severity"] - 0.8) < 0.1, base
    assert base["value"] == pytest.approx(1 + 4 * base["severity"], rel=1e-3)
    assert base["explained"] > 10 * abs(healthy_line["baseline"]["explained"])
    # a record without a discrepancy cannot give the second reading: a config error (78)
    record = json.loads((folder / "commissioning.json").read_text())
    del record["discrepancy"]
    (folder / "commissioning.json").write_text(json.dumps(record))
    assert main(["diagnose", str(tmp_path / "runs.npz"), "--dictionary", str(dpath),
                 "--commissioned", str(folder)]) == 78


def test_diagnose_reports_a_baseline_that_cannot_read_a_run_instead_of_crashing(
        bench: Bench, tmp_path: Path, capsys: pytest.CaptureFixture[str],
        monkeypatch: pytest.MonkeyPatch) -> None:
    # the daemon keeps the dictionary's event when the second reading raises (a baseline
    # whose arrays do not fit the record); `mapr diagnose --commissioned` says the same
    from mapr_daemon.reasoner.commissioning.baseline import Baseline

    folder = tmp_path / "unit"
    folder.mkdir()
    commissioned_folder(bench, folder)
    dpath = tmp_path / "d.npz"
    bench.dictionary.save(dpath)
    _write_runs(bench, [0], tmp_path / "runs.npz")

    def refuse(*_: object, **__: object) -> None:
        raise IndexError("arrays do not fit")

    monkeypatch.setattr(Baseline, "read", refuse)
    assert main(["diagnose", str(tmp_path / "runs.npz"), "--dictionary", str(dpath),
                 "--commissioned", str(folder)]) == 0
    (line,) = [json.loads(x) for x in capsys.readouterr().out.splitlines()]
    assert line["baseline"] == {"unreadable": "IndexError: arrays do not fit"}
