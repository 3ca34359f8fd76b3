"""`mapr decode` filters and text mode: the batch masks keep exactly the messages a plain
per-record test keeps, impossible filters are one line and exit 2, the text lines up."""

from __future__ import annotations

import contextlib
import io
from datetime import datetime
from pathlib import Path

import pytest

from drivers.chapter10.reader import Chapter10Reader
from drivers.chapter10.writer import Chapter10Writer
from drivers.mil1553.record import MonitorRecord
from mapr_daemon.cli import exitcodes
from mapr_daemon.cli.main import main

from .conftest import SAMPLE
from .test_reader_batch import SEED, varied_records


@pytest.fixture(scope="module")
def varied(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("filters") / "varied.c10"
    with Chapter10Writer(path, start_time=datetime(2026, 4, 1, 9)) as writer:
        writer.write(varied_records(2000, SEED + 3))
    return path


def run(*argv: str) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(["decode", *argv])
    return code, out.getvalue(), err.getvalue()


def _records(path: Path) -> list[MonitorRecord]:
    return [r for b in Chapter10Reader(path, batched=False) for r in b.records]


def _sides(r: MonitorRecord) -> list[tuple[int, str, int]]:
    """A record's sides: (terminal, T/R, subaddress) of each command word."""
    return [(w >> 11 & 31, "T" if w >> 10 & 1 else "R", w >> 5 & 31)
            for w in (r.command, r.command2) if w is not None]


def _side(r: MonitorRecord, rts: set[int] | None = None, tr: str | None = None,
          sas: set[int] | None = None) -> bool:
    return any((rts is None or rt in rts) and (tr is None or t == tr)
               and (sas is None or sa in sas) for rt, t, sa in _sides(r))


CASES = [
    (["--rt", "5"], lambda r: _side(r, {5})),
    (["--rt", "1-4,30"], lambda r: _side(r, {1, 2, 3, 4, 30})),
    (["--sa", "0,31"], lambda r: _side(r, sas={0, 31})),
    (["--tr", "t"], lambda r: _side(r, tr="T")),
    (["--rt", "5", "--tr", "T"], lambda r: _side(r, {5}, "T")),
    (["--rt", "5", "--tr", "R", "--sa", "1-10"], lambda r: _side(r, {5}, "R", set(range(1, 11)))),
    (["--format", "RT_RT,bcast_mode"], lambda r: str(r.format) in ("RT_RT", "BCAST_MODE")),
    (["--errors"], lambda r: bool(r.errors)),
    (["--error", "no_response,wrong_rt_address"],
     lambda r: bool({"no_response", "wrong_rt_address"} & set(r.errors))),
    (["--from", "0.5", "--to", "1.5"], lambda r: 500_000_000 <= r.t_ns < 1_500_000_000),
    (["--rt", "0-15", "--tr", "R", "--errors"],
     lambda r: _side(r, set(range(16)), "R") and bool(r.errors)),
]


@pytest.mark.parametrize(("flags", "keep"), CASES)
def test_filters_keep_what_a_per_record_test_keeps(flags: list[str], keep: object,
                                                   varied: Path) -> None:
    expected = [r.t_ns for r in _records(varied) if keep(r)]  # type: ignore[operator]
    code, out, _ = run(*flags, str(varied))
    assert code == exitcodes.OK
    got = [int(line.split(",")[0].split(":")[1]) for line in out.splitlines()]
    assert got == expected
    assert 0 < len(got) < 2000


@pytest.mark.parametrize(("flags", "named"), [
    (["--rt", "40"], "--rt 40: allowed 0-31"),
    (["--sa", "-1"], "--sa -1: allowed"),
    (["--sa", "7-3"], "--sa 7-3: allowed 0-31"),
    (["--tr", "X"], "--tr X: allowed T or R"),
    (["--format", "XYZ"], "--format XYZ: allowed BC_RT"),
    (["--error", "nosucherr"], "--error nosucherr: allowed no_response"),
    (["--from", "2", "--to", "1"], "--to 1: must be later than --from 2"),
    (["--from", "soon"], "--from soon: allowed a number of seconds"),
    (["--format", "MODE", "--sa", "5"], "--sa 5 can never match"),
    (["--format", "RT_BC,BC_RT", "--sa", "0"], "carries mode codes only"),
])
def test_a_filter_that_cannot_match_is_one_line_and_exit_2(flags: list[str], named: str,
                                                            tmp_path: Path) -> None:
    missing = tmp_path / "not-read.c10"   # validated before the file is opened
    code, out, err = run(*flags, str(missing))
    assert code == exitcodes.USAGE
    assert out == "" and err.count("\n") == 1 and named in err


def test_text_mode_is_aligned_columns_with_hex_words(varied: Path) -> None:
    code, out, _ = run("--text", str(varied))
    assert code == exitcodes.OK
    header, *lines = out.splitlines()
    records = _records(varied)
    assert len(lines) == len(records)
    column = header.index("RT-SA")
    data_at = header.index("data")
    for line, record in zip(lines, records, strict=True):
        assert float(line[:12]) == pytest.approx(record.t_ns / 1e9, abs=1e-6)
        assert line[column:column + 5] == f"{record.rt:02d}-{record.sa:02d}"
        words = line[data_at:].split(" ! ")[0].split()
        assert words == [f"{d:04X}" for d in record.data]
        assert line.endswith(" ! " + ",".join(record.errors)) == bool(record.errors)


def test_text_mode_on_the_sample() -> None:
    if not SAMPLE.is_file():
        pytest.skip(f"the sample Chapter 10 recording is not at {SAMPLE}")
    code, out, _ = run("--text", "--rt", "14", str(SAMPLE))
    assert code == exitcodes.OK
    lines = out.splitlines()[1:]
    assert lines and all(" 14-" in line for line in lines)
