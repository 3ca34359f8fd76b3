"""One actuator identity on the catalog command line: ``TAIL/ACTUATOR``; a bare name that
several aircraft carry is refused with the list (exit 2), an unknown one too; ``--asset``
everywhere (``episodes --actuator`` kept as a hidden alias); ``export --json`` is JSON."""

from __future__ import annotations

import contextlib
import dataclasses
import io
import json
from pathlib import Path

import pytest

from mapr_daemon.catalog import BitOutcome, CatalogWriter
from mapr_daemon.catalog.model import Flight
from mapr_daemon.cli.main import main

from .conftest import HOUR, T0


def fleet_catalog(path: Path) -> Path:
    """EMA1 on three tails (4 BITs each), EMA2 on N900 only."""
    with CatalogWriter(path) as writer:
        writer.open_session(backend="chapter10", config_hash="f1ee7", started_ns=T0)
        for tail in ("N900", "N901", "N902"):
            for k in range(4):
                t = T0 + k * 3 * HOUR
                outcomes = [BitOutcome("EMA1", t, tail=tail, flight=k, flight_hours=2.0 * k,
                                       wear={"esr": 0.01 * k})]
                if tail == "N900":
                    outcomes.append(dataclasses.replace(outcomes[0], asset="EMA2", t_ns=t + 1))
                writer.add_bits(outcomes, [Flight(tail, k, t, t + HOUR, 2.0, "declared")])
    return path


def mapr(*argv: str) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(list(argv))
    return code, out.getvalue(), err.getvalue()


@pytest.fixture
def catalog(tmp_path: Path) -> str:
    return str(fleet_catalog(tmp_path / "fleet.sqlite"))


def test_a_name_on_several_tails_is_refused_with_them(catalog: str) -> None:
    code, out, err = mapr("catalog", "trend", "EMA1", "--catalog", catalog)
    assert code == 2 and out == ""
    assert "EMA1 is on 3 aircraft: N900/EMA1, N901/EMA1, N902/EMA1" in err
    assert err.startswith("mapr catalog trend: error: ")


def test_tail_slash_actuator_picks_one_history(catalog: str) -> None:
    code, out, _ = mapr("catalog", "trend", "N901/EMA1", "--json", "--catalog", catalog)
    assert code == 0 and len(json.loads(out)) == 4
    code, out, _ = mapr("catalog", "trend", "EMA1", "--tail", "N902", "--json",
                        "--catalog", catalog)
    assert code == 0 and len(json.loads(out)) == 4
    code, out, _ = mapr("catalog", "trend", "EMA2", "--json", "--catalog", catalog)
    assert code == 0 and len(json.loads(out)) == 4   # only N900 has an EMA2


@pytest.mark.parametrize("argv", [["NOPE"], ["N999/EMA1"], ["EMA2", "--tail", "N901"]])
def test_an_unknown_actuator_is_exit_2_with_the_known_ones(argv: list[str],
                                                           catalog: str) -> None:
    code, out, err = mapr("catalog", "trend", *argv, "--catalog", catalog)
    assert code == 2 and out == ""
    assert "no actuator" in err and "N900/EMA2" in err


def test_episodes_take_asset_and_the_old_actuator_spelling(catalog: str) -> None:
    new = mapr("catalog", "episodes", "--asset", "EMA2", "--catalog", catalog)
    old = mapr("catalog", "episodes", "--actuator", "EMA2", "--catalog", catalog)
    assert new[0] == old[0] == 0 and new[1] == old[1]
    assert "for N900/EMA2" in new[1]   # the one aircraft with an EMA2


def test_episodes_of_a_name_on_several_tails_are_refused_with_them(catalog: str) -> None:
    code, out, err = mapr("catalog", "episodes", "--asset", "EMA1", "--catalog", catalog)
    assert code == 2 and out == ""
    assert err == ("mapr catalog episodes: error: EMA1 is on 3 aircraft: N900/EMA1, "
                   "N901/EMA1, N902/EMA1; name one as TAIL/ACTUATOR\n")
    code, out, _ = mapr("catalog", "episodes", "--asset", "N901/EMA1", "--catalog", catalog)
    assert code == 0 and "for N901/EMA1" in out
    code, _, err = mapr("catalog", "episodes", "--asset", "NOPE", "--catalog", catalog)
    assert code == 2 and "no actuator NOPE" in err


def _anomaly(tail: str, asset: str, t: int) -> BitOutcome:
    from mapr_daemon.catalog import Event

    event = Event(t_ns=t, asset=asset, fault="esr", confidence=0.9, severity=0.5,
                  evidence={"part": "smps_output_capacitor"})
    return BitOutcome(asset, t, event=event, tail=tail, flight=1, fault="esr")


def daemon_catalog(path: Path) -> Path:
    """What ``mapr run`` on aircraft N900 writes (its events and episodes keep the bare
    names of its config), and a fleet run's N901/EMA1 beside it."""
    with CatalogWriter(path) as writer:
        writer.open_session(backend="loopback", config_hash="d43", started_ns=T0)
        writer.add_bits([_anomaly("N900", "EMA1", T0)], [])
        writer.add_bits([_anomaly("N901", "N901/EMA1", T0 + HOUR)], [])
    return path


def test_every_catalog_row_names_tail_and_actuator(tmp_path: Path) -> None:
    catalog = str(daemon_catalog(tmp_path / "daemon.sqlite"))
    code, out, _ = mapr("catalog", "list", "--catalog", catalog)
    assert code == 0
    rows = out.splitlines()[1:]
    assert [row.split()[3] for row in rows] == ["N901/EMA1", "N900/EMA1"]
    code, out, _ = mapr("catalog", "show", "1", "--catalog", catalog)
    assert "asset       N900/EMA1" in out
    code, out, _ = mapr("catalog", "list", "--json", "--catalog", catalog)
    assert {(e["tail"], e["asset"]) for e in json.loads(out)} == {
        ("N900", "EMA1"), ("N901", "N901/EMA1")}
    code, out, _ = mapr("catalog", "episodes", "--catalog", catalog)
    assert code == 0 and {row.split()[1] for row in out.splitlines()[1:]} == {
        "N900/EMA1", "N901/EMA1"}
    code, out, _ = mapr("catalog", "episodes", "--asset", "N900/EMA1", "--json",
                        "--catalog", catalog)
    assert [(e["tail"], e["asset"]) for e in json.loads(out)] == [("N900", "EMA1")]
    code, out, _ = mapr("catalog", "export", "--catalog", catalog)
    header, *lines = out.splitlines()
    assert header.endswith(",tail") and sorted(line.rsplit(",", 1)[1] for line in lines) == [
        "N900", "N901"]


def test_export_json_writes_json(catalog: str, tmp_path: Path) -> None:
    out = tmp_path / "bits.json"
    code, _, _ = mapr("catalog", "export", "--what", "bits", "--json", "-o", str(out),
                      "--catalog", catalog)
    assert code == 0
    lines = out.read_text(encoding="utf-8").splitlines()
    assert len(lines) == 16 and all(json.loads(line)["asset"] in ("EMA1", "EMA2")
                                    for line in lines)
    code, _, err = mapr("catalog", "export", "--json", "--format", "csv", "--catalog", catalog)
    assert code == 2 and "--json and --format csv" in err


def test_list_asset_finds_a_fleet_run_s_events(tmp_path: Path) -> None:
    """A fleet run keeps events under ``TAIL/ASSET``: ``--asset EMA1`` finds them on every
    tail, ``--asset N901/EMA1`` on one."""
    from mapr_daemon.catalog import Event

    path = tmp_path / "events.sqlite"
    with CatalogWriter(path) as writer:
        writer.open_session(backend="chapter10", config_hash="f1ee7", started_ns=T0)
        writer.add_events(Event(t_ns=T0 + i, asset=name, fault="esr", confidence=0.9,
                                severity=0.5)
                          for i, name in enumerate(("N900/EMA1", "N901/EMA1", "N901/EMA2",
                                                    "EMA1")))
    code, out, _ = mapr("catalog", "list", "--asset", "EMA1", "--json", "--catalog", str(path))
    assert code == 0
    assert sorted(e["asset"] for e in json.loads(out)) == ["EMA1", "N900/EMA1", "N901/EMA1"]
    code, out, _ = mapr("catalog", "list", "--asset", "N901/EMA1", "--json",
                        "--catalog", str(path))
    assert [e["asset"] for e in json.loads(out)] == ["N901/EMA1"]
