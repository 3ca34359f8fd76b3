"""``mapr replay``: a recording through the daemon's pipeline into the catalog.

The end-to-end case records a BIT flight of the testbed aircraft (loopback bus) as Chapter
10, replays it with ``--diagnose`` and checks the catalog event against what the daemon's
own BIT watcher decides on the live records.
"""

from __future__ import annotations

from datetime import datetime
from pathlib import Path
from typing import Any

import pytest

from mapr_daemon.catalog import Event
from mapr_daemon.catalog.reader import CatalogReader
from mapr_daemon.cli import exitcodes
from mapr_daemon.cli.main import main

ICD = Path(__file__).resolve().parents[2] / "configs" / "icd" / "ema-testbed.yaml"
START = datetime(2025, 6, 1, 10, 0, 0)
START_NS = round((START - datetime(1970, 1, 1)).total_seconds()) * 10**9


def replay(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    code = main(["replay", *argv])
    out, err = capsys.readouterr()
    return code, out, err


def test_the_sample_replays_into_one_catalog_session(sample_c10: Path, tmp_path: Path,
                                                     capsys: pytest.CaptureFixture[str]
                                                     ) -> None:
    db = tmp_path / "catalog.db"
    code, out, err = replay(capsys, str(sample_c10), "--catalog", str(db), "--progress")
    assert code == exitcodes.OK
    assert out.splitlines() == [
        f"{sample_c10}: replay complete: 475 messages (bus A 306, bus B 169), 27 with errors, "
        "damaged packets skipped: 1",
        "ICD ema-testbed: 0 messages decoded, 475 not in the table",
        f"catalog {db}: session 1"]
    assert "] 100%  1.0 MiB / 1.0 MiB  475 messages" in err
    with CatalogReader(db) as catalog:
        (session,) = catalog.sessions()
        assert (session.backend, session.stop_reason) == ("chapter10", "replay complete")
        rows = {row.bus: row for row in catalog.stats()}
        assert (rows["A"].messages, rows["B"].messages) == (306, 169)
        assert rows["A"].errors_total + rows["B"].errors_total == 27
        (gap,) = catalog.gaps()
        assert "offset 1042864: truncated packet" in gap.reason


def test_no_progress_bar_when_stderr_is_not_a_terminal(sample_c10: Path, tmp_path: Path,
                                                       capsys: pytest.CaptureFixture[str]
                                                       ) -> None:
    code, _, err = replay(capsys, str(sample_c10), "--catalog", str(tmp_path / "c.db"),
                          "--c10-channel", "2")
    assert code == exitcodes.OK and "%" not in err


def test_bad_input_gives_one_line_and_its_exit_code(tmp_path: Path,
                                                    capsys: pytest.CaptureFixture[str]
                                                    ) -> None:
    noise = tmp_path / "noise.c10"
    noise.write_bytes(b"\x00" * 100)
    code, out, err = replay(capsys, str(noise), "--catalog", str(tmp_path / "c.db"))
    assert (code, out) == (exitcodes.USAGE, "")
    assert err.strip() == (f"mapr replay: {noise}: not a Chapter 10 recording (no packet "
                           "header at its start)")
    code, _, err = replay(capsys, str(tmp_path / "missing.c10"))
    assert code == exitcodes.USAGE and "no such file" in err


def test_diagnose_needs_a_dictionary(sample_c10: Path, tmp_path: Path,
                                     capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = replay(capsys, str(sample_c10), "--diagnose", "--catalog",
                          str(tmp_path / "c.db"))
    assert code == exitcodes.CONFIG
    assert "--diagnose needs a fault dictionary" in err
    code, _, err = replay(capsys, str(sample_c10), "--threshold", "0")
    assert code == exitcodes.USAGE and "--threshold must be above 0" in err


@pytest.fixture(scope="module")
def dictionary(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from mapr_daemon.ema.params import default_actuator_path, load_actuator
    from mapr_daemon.reasoner.diagnosis.dictionary import DictionarySpec
    from mapr_daemon.reasoner.training import dictionary_build

    spec = DictionarySpec(pressures_pa=(0.0, 1600.0), nominal_per_pressure=2,
                          severities=(0.5, 1.0), kinds=("esr", "friction"), shorts=(),
                          opens=(), calibration_runs=10, calibration_pressure_pa=(200.0, 1400.0),
                          threshold_margin=1.5)
    path = tmp_path_factory.mktemp("dictionary") / "dictionary.npz"
    dictionary_build.build(load_actuator(default_actuator_path()), spec).save(path)
    return path


@pytest.fixture(scope="module")
def bit_flight(dictionary: Path, tmp_path_factory: pytest.TempPathFactory
               ) -> tuple[Path, list[Event]]:
    """A recorded testbed BIT flight with a seeded friction fault, and the events the
    daemon's path (:class:`Pipeline`, a session clock anchored where the recording starts)
    makes of the live records, with a threshold so low that every BIT is reported."""
    from drivers.chapter10.writer import Chapter10Writer
    from mapr_daemon.icd import load_icd
    from mapr_daemon.pipeline.clock import BusClock
    from mapr_daemon.pipeline.pipeline import build_pipeline
    from mapr_daemon.pipeline.settings import ReasonerConfig
    from mapr_daemon.service.config import Config
    from mapr_daemon.service.source import monitor_factory

    config = Config(icd=str(ICD),
                    testbed=dict(seed=3, realtime=False, duration_s=1.7,
                                          fault="friction@0.8"),
                    reasoner=ReasonerConfig(dictionary=str(dictionary), threshold=1e-9))
    with monitor_factory(config, load_icd(ICD))() as monitor:
        records = list(monitor)
    path = tmp_path_factory.mktemp("flight") / "bit.c10"
    with Chapter10Writer(path, channel_id=1, start_time=START) as writer:
        writer.write(records)
    clock = BusClock(now_ns=lambda: START_NS + 3_456_789)   # truncated to START's 10 ms
    pipe = build_pipeline(config)
    events = [e for i in range(0, len(records), 1024)
              for e in pipe.process(records[i:i + 1024], clock).events]
    assert len(events) == 1
    return path, events


def test_diagnose_over_foreign_traffic_says_no_actuator_was_found(
        sample_c10: Path, dictionary: Path, tmp_path: Path,
        capsys: pytest.CaptureFixture[str]) -> None:
    db = tmp_path / "c.db"
    code, out, _ = replay(capsys, str(sample_c10), "--diagnose", "--dictionary",
                          str(dictionary), "--catalog", str(db))
    assert code == exitcodes.OK
    assert "diagnosis: no actuator of the ICD ema-testbed (RT 5, 6) found in the recording: " \
           "nothing to diagnose" in out.splitlines()
    with CatalogReader(db) as catalog:
        assert catalog.count() == 0


def test_a_recorded_bit_flight_is_diagnosed_as_the_daemon_would(
        bit_flight: tuple[Path, list[Event]], dictionary: Path, tmp_path: Path,
        capsys: pytest.CaptureFixture[str]) -> None:
    path, (live,) = bit_flight
    db = tmp_path / "c.db"
    code, out, _ = replay(capsys, str(path), "--diagnose", "--dictionary", str(dictionary),
                          "--threshold", "1e-9", "--catalog", str(db), "--icd", str(ICD))
    assert code == exitcodes.OK
    lines = out.splitlines()
    assert lines[1].startswith("ICD ema-testbed: ") and ", 0 not in the table" in lines[1]
    assert lines[2] == ("diagnosis: 1 built-in tests diagnosed, 1 anomaly events written, "
                        "0 in-flight estimates stored (one per actuator and flight)")
    with CatalogReader(db) as catalog:
        (event,) = catalog.events()
        (session,) = catalog.sessions()
    assert session.backend == "chapter10"
    assert event.evidence["recording"] == str(path)
    # the same stamps, to the nanosecond: bus time of the request record (to the 100 ns the
    # recording keeps), and the recording's absolute time = the live session clock's
    assert live.bus_ns is not None and live.abs_ns is not None
    assert (event.bus_ns, event.abs_ns, event.t_ns) == (live.bus_ns, live.abs_ns, live.t_ns)
    assert live.abs_ns == START_NS + live.bus_ns and live.bus_ns % 100 == 0
    # the same fields; the reasoner's numbers to float noise (the counter timebase re-times
    # the samples from time tags rounded to 100 ns)
    same = ("asset", "rt", "fault", "switch", "severity_unit", "rul", "rul_unit")
    assert [getattr(event, f) for f in same] == [getattr(live, f) for f in same]
    for name in ("confidence", "severity", "severity_value", "soh"):
        assert getattr(event, name) == pytest.approx(getattr(live, name), rel=1e-3), name
    evidence = {k: v for k, v in event.evidence.items() if k != "recording"}
    assert set(evidence) == set(live.evidence)
    assert evidence["score"] == pytest.approx(live.evidence["score"], rel=1e-3)
    assert set(event.params) == set(live.params)


def test_as_fast_as_the_file_reads_stores_what_the_paced_replay_stores(
        bit_flight: tuple[Path, list[Event]], sample_c10: Path, dictionary: Path,
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Unpaced, a replay hands the pipeline the reader's columns (no record per message);
    paced (``--speed``, here far faster than recorded time), one record at a time through
    the monitor: the same summary and the same catalog, BITs, events, bus statistics and
    damaged packets alike."""
    def both(path: Path, *extra: str) -> list[tuple[str, list[Any]]]:
        stored = []
        for speed in ("0", "1e6"):
            db = tmp_path / f"{path.stem}-{speed}.db"
            code, out, _ = replay(capsys, str(path), "--catalog", str(db), "--icd", str(ICD),
                                  "--speed", speed, *extra)
            assert code == exitcodes.OK
            with CatalogReader(db) as catalog:
                stored.append((out.replace(str(db), "DB"), [
                    [(e.asset, e.fault, e.bus_ns, e.abs_ns, e.evidence["score"])
                     for e in catalog.events()],
                    [(b.asset, b.bus_ns, b.flight, b.fault) for b in catalog.bits()],
                    [(s.bus, s.messages, s.words, dict(s.errors), s.load_percent)
                     for s in catalog.stats()],
                    [(s.start_ns, s.end_ns) for s in catalog.stats()],
                    [g.reason for g in catalog.gaps()]]))
        return stored

    flight, _ = bit_flight
    (fast, paced) = both(flight, "--diagnose", "--dictionary", str(dictionary),
                         "--threshold", "1e-9")
    assert fast == paced and len(fast[1][0]) == 1   # the recording's own time: same stamps
    (fast, paced) = both(sample_c10)
    # no full date in the sample's time packets: its statistics' interval is the replay's
    # own wall clock, so it is left out
    del fast[1][3], paced[1][3]
    assert fast == paced and fast[1][3] and len(fast[1][2]) == 2   # a damaged packet, 2 buses
