"""`mapr decode FILE.c10` writes batches (JSON lines assembled from arrays, ICD values
decoded per message group), byte for byte what one ``json.dumps`` per record gives."""

from __future__ import annotations

import contextlib
import io
import json
import random
from datetime import datetime
from pathlib import Path
from typing import Any

import pytest

from drivers.chapter10.reader import Chapter10Reader
from drivers.chapter10.writer import Chapter10Writer
from drivers.mil1553.record import MonitorRecord, TransferFormat
from mapr_daemon.cli.icdview.view import IcdView
from mapr_daemon.cli.main import main

from .conftest import SAMPLE
from .test_reader_batch import SEED, varied_records

ICD = Path(__file__).resolve().parents[2] / "configs" / "icd" / "ema-testbed.yaml"


def reference_lines(path: Path, icd: str | None = None) -> str:
    """What `decode` printed before batching: one json.dumps per record."""
    view = IcdView(icd)
    out = []
    for batch in Chapter10Reader(path, batched=False):
        for record in batch.records:
            line: dict[str, Any] = record.to_json()
            line["channel"] = record.extra["channel"]
            if "time" in record.extra:
                line["time"] = record.extra["time"]
            values = view.values(record)
            if values is not None:
                line["values"] = values
            out.append(json.dumps(line) + "\n")
        if batch.arinc429 is not None:
            out += [json.dumps(word) + "\n" for word in batch.arinc429.to_json()]
    return "".join(out)


def decode(*argv: str) -> str:
    out = io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(io.StringIO()):
        assert main(["decode", *argv]) == 0
    return out.getvalue()


def icd_traffic(count: int, seed: int) -> list[MonitorRecord]:
    """Messages of the ICD with random words (labels, groups, out-of-range and invalid
    codes, short and long messages, errors), among varied other traffic."""
    icd = IcdView(str(ICD)).icd
    assert icd is not None
    rng = random.Random(seed)
    records = varied_records(count // 2, seed)
    t = records[-1].end_ns + 10_000
    for _ in range(count - len(records)):
        message = rng.choice(icd.messages)
        words = message.word_count + rng.choice((0, 0, 0, -1, 1))
        tx = message.command >> 10 & 1
        fmt = TransferFormat.RT_BC if tx else TransferFormat.BC_RT
        errors = ("parity",) if rng.random() < 0.1 else ()
        data = tuple(rng.getrandbits(16) for _ in range(max(words, 0)))
        records.append(MonitorRecord(t, "A", fmt, message.command, data=data,
                                     status=((message.command >> 11) << 11,),
                                     gaps_ns=(8_000,), errors=errors))
        t += 800_000
    return records


@pytest.fixture(scope="module")
def traffic(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("decode") / "icd.c10"
    with Chapter10Writer(path, start_time=datetime(2026, 5, 2, 10)) as writer:
        writer.write(icd_traffic(4000, SEED + 7))
    return path


def test_json_lines_are_byte_identical(traffic: Path) -> None:
    expected = reference_lines(traffic)
    assert expected.count("\n") == 4000
    assert decode(str(traffic)) == expected


@pytest.fixture(params=["repr", "compiled"])
def values_writer(request: pytest.FixtureRequest, monkeypatch: pytest.MonkeyPatch) -> str:
    """``decode --icd`` in this process with the ``repr`` values writer throughout, or the
    compiled one from the first message on."""
    import mapr_daemon.cli.icdview.batch as batch_module

    compiled = request.param == "compiled"
    monkeypatch.setattr(batch_module, "COMPILED_AFTER", 0 if compiled else 10**12)
    monkeypatch.setattr(batch_module, "_numba_loaded", lambda: False)
    return str(request.param)


def test_icd_values_are_byte_identical(traffic: Path, values_writer: str) -> None:
    expected = reference_lines(traffic, str(ICD))
    assert expected.count('"values"') > 1500 and expected.count('"flags"') > 100
    assert decode("--icd", str(ICD), str(traffic)) == expected


def test_the_sample_decodes_byte_identically(values_writer: str, tmp_path: Path) -> None:
    """The real recording, plain, with the testbed's table (which describes none of its
    messages) and with the table ``mapr icd discover`` writes from it (one parameter per
    word of every message it holds)."""
    if not SAMPLE.is_file():
        pytest.skip(f"the sample Chapter 10 recording is not at {SAMPLE}")
    assert decode(str(SAMPLE)) == reference_lines(SAMPLE)
    assert decode("--icd", str(ICD), str(SAMPLE)) == reference_lines(SAMPLE, str(ICD))
    table = tmp_path / "sample.yaml"
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        assert main(["icd", "discover", str(SAMPLE), "--output", str(table)]) == 0
    expected = reference_lines(SAMPLE, str(table))
    assert expected.count('"values"') > 400
    assert decode("--icd", str(table), str(SAMPLE)) == expected


def values_both_ways(path: Path, compiled: bool = False
                     ) -> tuple[list[str | None], list[str | None]]:
    """Per message of ``path`` (the testbed table): the values text the batch writer gives
    (the compiled one if ``compiled``), and ``json.dumps`` of :meth:`IcdView.values` of its
    record (None for both where the table describes nothing)."""
    from mapr_daemon.cli.icdview.batch import batch_values_json

    view = IcdView(str(ICD))
    assert view.icd is not None
    written: list[str | None] = []
    expected: list[str | None] = []
    for batch in Chapter10Reader(path).batches():
        if batch.ms1553 is None:
            continue
        written += batch_values_json(view.icd, batch.ms1553, compiled=compiled)
        for record in batch.records:
            values = view.values(record)
            expected.append(None if values is None else json.dumps(values))
    return written, expected


@pytest.mark.parametrize("compiled", [False, True], ids=["repr", "compiled"])
def test_both_values_writers_write_what_json_dumps_writes(traffic: Path, compiled: bool) -> None:
    """The Python writer and the compiled one (used once a decode has written many values)
    give each message the text of ``json.dumps`` of :meth:`IcdView.values`."""
    written, expected = values_both_ways(traffic, compiled)
    assert sum(text is not None for text in expected) > 1500
    assert written == expected


def test_a_long_decode_turns_to_the_compiled_writer(traffic: Path,
                                                    monkeypatch: pytest.MonkeyPatch) -> None:
    """A process without numba writes with ``repr`` until COMPILED_AFTER messages have
    values, then with the compiled writer; the text is the same either way."""
    import mapr_daemon.cli.icdview.batch as batch_module

    calls: list[bool] = []
    batch_texts = batch_module._batch_texts

    def spy(icd: Any, batch: Any, compiled: bool, lead: str) -> tuple[list[str], int]:
        calls.append(compiled)
        return batch_texts(icd, batch, compiled, lead)

    monkeypatch.setattr(batch_module, "COMPILED_AFTER", 100)
    monkeypatch.setattr(batch_module, "_batch_texts", spy)
    monkeypatch.setattr(batch_module, "_numba_loaded", lambda: False)
    view = IcdView(str(ICD))
    assert view.icd is not None
    values = batch_module.BatchValues(view.icd)
    batch = next(b.ms1553 for b in Chapter10Reader(traffic).batches() if b.ms1553 is not None)
    first, second = values(batch), values(batch)
    assert calls == [False, True] and first == second
    assert sum(text.startswith(', "values": {') for text in first) > 100
