"""``--rt``, ``--tr`` and ``--sa`` on RT-RT transfers: each names one terminal's side, and
``decode``, ``decode --text``, ``decode --stats``, ``monitor`` and ``MonitorFilter`` agree.

The recording holds, on bus A, a few of each of:

* ``05-03<06-01``: RT 6 SA 1 transmits to RT 5 SA 3 (RT-RT);
* ``06-02<05-04``: RT 5 SA 4 transmits to RT 6 SA 2 (RT-RT);
* ``06-02``: BC to RT 6 SA 2 (BC-RT), and ``05-02`` T: RT 5 SA 2 to the BC (RT-BC).
"""

from __future__ import annotations

import contextlib
import io
import json
from datetime import datetime
from pathlib import Path

import pytest

from drivers.chapter10.writer import Chapter10Writer
from drivers.mil1553.record import MonitorRecord, TransferFormat
from drivers.monitor import MonitorFilter, open_monitor
from mapr_daemon.cli import exitcodes
from mapr_daemon.cli.main import main


def command(rt: int, tr: str, sa: int, wc: int) -> int:
    return rt << 11 | (tr == "T") << 10 | sa << 5 | wc & 31


def _message(t: int, fmt: TransferFormat, first: int, second: int | None,
             words: int) -> MonitorRecord:
    statuses = 2 if second is not None else 1
    span = (1 + (second is not None) + words + statuses) * 20_000 + statuses * 8_000
    return MonitorRecord(t, "A", fmt, first, data=tuple(range(words)),
                         status=(first & 0xF800,) * statuses, gaps_ns=(8_000,) * statuses,
                         command2=second, end_ns=t + span)


KINDS = {
    "05-03<06-01": (TransferFormat.RT_RT, command(5, "R", 3, 2), command(6, "T", 1, 2)),
    "06-02<05-04": (TransferFormat.RT_RT, command(6, "R", 2, 1), command(5, "T", 4, 1)),
    "06-02": (TransferFormat.BC_RT, command(6, "R", 2, 1), None),
    "05-02": (TransferFormat.RT_BC, command(5, "T", 2, 1), None),
}
COUNTS = {"05-03<06-01": 4, "06-02<05-04": 3, "06-02": 2, "05-02": 5}


def traffic() -> list[MonitorRecord]:
    records, t = [], 0
    for name, n in COUNTS.items():
        fmt, first, second = KINDS[name]
        for _ in range(n):
            records.append(_message(t, fmt, first, second, 2 if name == "05-03<06-01" else 1))
            t += 1_000_000
    return records


# (flags, names of the messages they keep): one terminal's side matches all of them
CASES: list[tuple[list[str], set[str]]] = [
    (["--rt", "5"], {"05-03<06-01", "06-02<05-04", "05-02"}),
    (["--rt", "5", "--tr", "R"], {"05-03<06-01"}),
    (["--rt", "5", "--tr", "T"], {"06-02<05-04", "05-02"}),
    (["--rt", "6", "--tr", "T"], {"05-03<06-01"}),
    (["--rt", "6", "--tr", "R"], {"06-02<05-04", "06-02"}),
    (["--rt", "5", "--sa", "2"], {"05-02"}),          # not 06-02<05-04: SA 2 is RT 6's
    (["--rt", "5", "--sa", "1"], set()),              # not 05-03<06-01: SA 1 is RT 6's
    (["--rt", "6", "--sa", "1"], {"05-03<06-01"}),
    (["--rt", "5", "--tr", "T", "--sa", "4"], {"06-02<05-04"}),
    (["--rt", "5", "--tr", "R", "--sa", "4"], set()),
    (["--sa", "2", "--tr", "R"], {"06-02<05-04", "06-02"}),
    (["--tr", "T"], {"05-03<06-01", "06-02<05-04", "05-02"}),
    (["--rt", "5,6", "--tr", "T", "--sa", "1-2"], {"05-03<06-01", "05-02"}),
]


@pytest.fixture(scope="module")
def recording(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("rtrt") / "rtrt.c10"
    with Chapter10Writer(path, start_time=datetime(2026, 4, 1, 9)) as writer:
        writer.write(traffic())
    return path


def mapr(*argv: str) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(list(argv))
    return code, out.getvalue(), err.getvalue()


def _count(names: set[str]) -> int:
    return sum(COUNTS[n] for n in names)


def terminals_column(header: str) -> int:
    """Where the terminals (``RT-SA``, ``05-03<06-01`` for RT-RT) stand in ``decode --text``:
    the column after the transfer format's, whatever columns come before it (a recording's
    ``ch``)."""
    return header.split().index("format") + 1


@pytest.mark.parametrize(("flags", "kept"), CASES)
def test_decode_text_prints_the_messages_of_that_side(flags: list[str], kept: set[str],
                                                      recording: Path) -> None:
    code, out, _ = mapr("decode", "--text", *flags, str(recording))
    assert code == exitcodes.OK
    header, *lines = out.splitlines()
    shown = {line.split()[terminals_column(header)] for line in lines}
    assert shown == kept
    assert len(lines) == _count(kept)


@pytest.mark.parametrize(("flags", "kept"), CASES)
def test_decode_json_monitor_and_monitorfilter_agree(flags: list[str], kept: set[str],
                                                     recording: Path) -> None:
    code, out, _ = mapr("decode", *flags, str(recording))
    assert code == exitcodes.OK
    decoded = [json.loads(line)["t_ns"] for line in out.splitlines()]
    assert len(decoded) == _count(kept)

    code, out, _ = mapr("monitor", "--backend", "chapter10", "-O", f"path={recording}",
                        "--json", *flags)
    assert code == exitcodes.OK
    assert [json.loads(line)["t_ns"] for line in out.splitlines()] == decoded

    values = dict(zip(flags[::2], flags[1::2], strict=True))
    numbers = {k: frozenset(int(x) for part in v.split(",") for x in
                            range(int(part.split("-")[0]), int(part.split("-")[-1]) + 1))
               for k, v in values.items() if k in ("--rt", "--sa")}
    wanted = MonitorFilter(rt=numbers.get("--rt"), sa=numbers.get("--sa"),
                           tr=values.get("--tr"))
    with open_monitor("chapter10", path=str(recording), filters=[wanted]) as monitor:
        assert [r.t_ns for r in monitor] == decoded


@pytest.mark.parametrize(("flags", "row"), [
    (["--rt", "5", "--tr", "T"], "RT05 T"),
    (["--rt", "5", "--tr", "R"], "RT05 R"),
    (["--rt", "6", "--tr", "T"], "RT06 T"),
    (["--rt", "6", "--tr", "R"], "RT06 R"),
])
def test_stats_rows_count_what_the_filter_prints(flags: list[str], row: str,
                                                 recording: Path) -> None:
    """``decode --rt X --tr D`` prints as many messages as ``--stats`` lists under
    ``RTxx D`` (with or without the filter), and the filtered table shows only that side."""
    kept = dict(CASES_BY_FLAGS)[tuple(flags)]
    code, whole, _ = mapr("decode", "--stats", "json", str(recording))
    assert code == exitcodes.OK
    rows = [json.loads(line) for line in whole.splitlines()]
    side = [r for r in rows if r["kind"] == "rtsa"
            and f"RT{r['rt']:02d} {r['tr']}" == row]
    assert sum(r["messages"] for r in side) == _count(kept)

    code, table, _ = mapr("decode", "--stats", *flags, str(recording))
    assert code == exitcodes.OK
    heading, header, *body = table.split("\n\n")[0].splitlines()
    assert heading == "channel 1 (1553)" and header.startswith("RT/SA")   # a table per bus
    assert body and all(line.startswith(row) for line in body)
    assert sum(int(line[16:26]) for line in body) == _count(kept)


CASES_BY_FLAGS = [(tuple(flags), kept) for flags, kept in CASES]


def test_monitor_and_decode_write_rt_rt_the_same_way(recording: Path) -> None:
    """Both text views: the receive command, ``<``, the transmit command, in bus order."""
    code, out, _ = mapr("monitor", "--backend", "chapter10", "-O", f"path={recording}",
                        "--rt", "6", "--tr", "T")
    assert code == exitcodes.OK
    assert "RT_RT        RT05 R SA03 WC02 < RT06 T SA01 WC02 " in out.splitlines()[0]
    code, out, _ = mapr("decode", "--text", "--rt", "6", "--tr", "T", str(recording))
    header, first = out.splitlines()[:2]
    assert first.split()[terminals_column(header)] == "05-03<06-01"


@pytest.mark.parametrize(("flags", "rows"), [
    (["--rt", "5"], ["RT05 R SA03", "RT05 T SA02", "RT05 T SA04"]),
    (["--rt", "5", "--tr", "T"], ["RT05 T SA02", "RT05 T SA04"]),
    (["--rt", "6", "--tr", "T"], ["RT06 T SA01"]),
    (["--rt", "5", "--sa", "2"], ["RT05 T SA02"]),
    (["--sa", "2", "--tr", "R"], ["RT06 R SA02"]),
])
def test_catalog_stats_by_rt_selects_the_same_sides(flags: list[str], rows: list[str],
                                                    tmp_path: Path) -> None:
    """The catalog's per-RT/SA rows, filtered with decode's definitions: each row is a side,
    and its count is what ``decode`` prints with the same flags when one row is left."""
    import dataclasses

    from drivers.rtstats import TrafficStatistics
    from mapr_daemon.catalog import CatalogWriter

    stats = TrafficStatistics()
    stats.add_batch(traffic())
    path = tmp_path / "c.sqlite"
    with CatalogWriter(path) as writer:
        writer.open_session(backend="chapter10", config_hash="cafe", started_ns=10**18)
        writer.add_rt_stats(10**18, 10**18 + 10**9,
                            [dataclasses.asdict(r) for r in stats.rows()])
    code, out, _ = mapr("catalog", "--catalog", str(path), "--json", "stats", "--by-rt",
                        *flags)
    assert code == exitcodes.OK
    got = json.loads(out)["rt_sa"]
    assert [f"RT{r['rt']:02d} {r['tr']} SA{r['sa']:02d}" for r in got] == rows
    kept = dict(CASES_BY_FLAGS).get(tuple(flags))
    if kept is not None:
        assert sum(r["messages"] for r in got) == _count(kept)


def test_catalog_stats_side_flags_need_by_rt(tmp_path: Path) -> None:
    from mapr_daemon.catalog import CatalogWriter

    path = tmp_path / "c.sqlite"
    with CatalogWriter(path) as writer:
        writer.open_session(backend="chapter10", config_hash="cafe", started_ns=10**18)
    code, _, err = mapr("catalog", "--catalog", str(path), "stats", "--rt", "5")
    assert code == exitcodes.USAGE and "--by-rt" in err
