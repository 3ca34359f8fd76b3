"""A Chapter 10 reader's batch of columns decoded by the ICD without building its records
(what a fleet task hands the daemon's pipeline) gives exactly what the records give."""

from __future__ import annotations

import contextlib
import io
from pathlib import Path

import numpy as np
import pytest

from drivers.chapter10.reader import Chapter10Reader
from mapr_daemon.cli.main import main
from mapr_daemon.icd import BatchResult, Icd, SignalStream, load_icd
from mapr_daemon.icd.columns import decode_columns

from .conftest import SAMPLE
from .test_decode_batch import ICD, traffic

__all__ = ["traffic"]


def assert_same(got: BatchResult, expected: BatchResult) -> None:
    assert (got.unmatched, got.empty, got.data_words) == \
        (expected.unmatched, expected.empty, expected.data_words)
    assert got.records == expected.records
    assert list(got.records) == list(expected.records), "messages in first-seen order"
    assert list(got.series) == list(expected.series), "parameters in the records' order"
    for name, series in expected.series.items():
        other = got.series[name]
        np.testing.assert_array_equal(other.t_ns, series.t_ns, err_msg=name)
        np.testing.assert_array_equal(other.raw, series.raw, err_msg=name)
        np.testing.assert_array_equal(other.flags, series.flags, err_msg=name)
        # bit for bit: NaN where NaN, -0.0 where -0.0
        assert other.value.tobytes() == series.value.tobytes(), name


def compare_file(path: Path, icd: Icd, merge: int) -> int:
    """Every batch of ``path`` decoded both ways; returns the messages the table described."""
    described = 0
    for batch in Chapter10Reader(path, arinc429=False).batches(merge):
        if batch.ms1553 is None:
            continue
        expected = icd.decode_batch(batch.records)
        assert_same(decode_columns(icd, batch.ms1553), expected)
        described += sum(expected.records.values())
    return described


@pytest.mark.parametrize("merge", [1, 700, 8192])
def test_columns_decode_as_their_records(traffic: Path, merge: int) -> None:
    """The ICD's messages with random words (short and long messages, errors, out-of-range
    codes) among varied other traffic, in batches of several sizes."""
    assert compare_file(traffic, load_icd(ICD), merge) > 1500


def test_the_sample_decodes_as_its_records(tmp_path: Path) -> None:
    """The real recording with the table ``mapr icd discover`` writes from it."""
    if not SAMPLE.is_file():
        pytest.skip(f"the sample Chapter 10 recording is not at {SAMPLE}")
    table = tmp_path / "sample.yaml"
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        assert main(["icd", "discover", str(SAMPLE), "--output", str(table)]) == 0
    assert compare_file(SAMPLE, load_icd(table), 8192) > 400


def test_the_signal_stream_takes_columns_as_records(traffic: Path) -> None:
    """The daemon's stream (block counters, lost and repeated blocks included) fed columns."""
    icd = load_icd(ICD)
    by_records, by_columns = SignalStream(icd), SignalStream(icd)
    for batch in Chapter10Reader(traffic, arinc429=False).batches(500):
        if batch.ms1553 is None:
            continue
        expected = by_records.feed(batch.records)
        got = by_columns.feed(batch.ms1553)
        assert list(got) == list(expected)
        for name, series in expected.items():
            assert got[name].value.tobytes() == series.value.tobytes(), name
            np.testing.assert_array_equal(got[name].t_ns, series.t_ns, err_msg=name)
    assert by_columns.stats == by_records.stats
    assert by_records.stats.decoded > 1500
