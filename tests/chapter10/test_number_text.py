"""The ``repr`` values writer of ``decode --icd`` (tables for short numbers, ``repr`` for the
rest, each distinct value written once) gives what ``json.dumps`` gives, number by number
and message by message: repeated values, -0.0, NaN, infinities, tiny and huge magnitudes,
codes and enumerations."""

from __future__ import annotations

import json
import random
import struct
from datetime import datetime
from pathlib import Path

import numpy as np
import pytest

from drivers.chapter10.writer import Chapter10Writer
from drivers.mil1553.record import MonitorRecord, TransferFormat
from mapr_daemon.cli.icdview.numbers import number_parts
from mapr_daemon.cli.icdview.view import IcdView

from .test_decode_batch import ICD, values_both_ways

SEED = 20260518


def written(values: list[float]) -> list[str]:
    heads, tails = number_parts(np.array(values, dtype=np.float64))
    return [h + t for h, t in zip(heads.tolist(), tails.tolist(), strict=True)]


def assert_as_json_dumps(values: list[float]) -> None:
    expected = [json.dumps(v) for v in values]
    got = written(values)
    wrong = [(v, g, e) for v, g, e in zip(values, got, expected, strict=True) if g != e]
    assert not wrong, wrong[:10]


@pytest.mark.parametrize("scale", [1.0, 0.1, 0.01, 0.001, 0.0001, 0.00025, 0.5, 2.0**-9,
                                   2.0**-16, 0.3, 1e-5, 7.0])
def test_every_16_bit_field_times_its_lsb(scale: float) -> None:
    raw = np.arange(-(1 << 16), 1 << 16, dtype=np.int64)
    assert_as_json_dumps((raw.astype(np.float64) * scale).tolist())
    assert_as_json_dumps((raw.astype(np.float64) * scale - 40.0).tolist())


def test_edges() -> None:
    tiny = [5e-324, -5e-324, 2.2250738585072014e-308, 1e-300, 1e-5, 9.999999999999999e-05]
    huge = [1e300, -1.7976931348623157e308, 1e16, 9999999999999998.0, 2.0**53, 2.0**53 + 2,
            1e15, 123456789.0, 10000.0, 9999.9999, 9999.99995, 9999.999949999999]
    near = [1e-4, -1e-4, 0.00010000000000000002, 0.0001 - 1e-20, 0.00015, 0.5, 0.05]
    special = [0.0, -0.0, float("nan"), float("inf"), float("-inf"), 1.0, -1.0]
    assert_as_json_dumps(tiny + huge + near + special)
    assert written([-0.0, 0.0]) == ["-0.0", "0.0"]
    assert written([float("nan"), float("-inf")]) == ["NaN", "-Infinity"]


def test_random_doubles_and_float32() -> None:
    rng = np.random.default_rng(SEED)
    bits = rng.integers(0, 1 << 64, 200_000, dtype=np.uint64)
    assert_as_json_dumps(bits.view(np.float64).tolist())
    single = rng.integers(0, 1 << 32, 200_000, dtype=np.uint64).astype(np.uint32)
    with np.errstate(invalid="ignore"):  # signalling NaNs among the random singles
        singles = single.view(np.float32).astype(np.float64)
    assert_as_json_dumps(singles.tolist())
    decimals = rng.integers(-10**8, 10**8, 200_000) / 10.0 ** rng.integers(0, 9, 200_000)
    assert_as_json_dumps(decimals.tolist())


SPECIAL_WORDS = (0x0000, 0x8000, 0x7F80, 0xFF80, 0x7FC0, 0x0001, 0x7F7F, 0xFFFF, 0x3F80,
                 0x1234, 0x0010, 0x4000)
"""Few distinct words, so values repeat; pairs of them are float32 -0.0, infinities, NaN,
a denormal, the largest single, 1.0; codes are 0, all ones and a few others."""


def repeating_traffic(count: int, seed: int) -> list[MonitorRecord]:
    """Messages of the ICD whose words come from :data:`SPECIAL_WORDS`, some short, some
    with errors."""
    icd = IcdView(str(ICD)).icd
    assert icd is not None
    rng = random.Random(seed)
    records = []
    t = 1_000_000
    for _ in range(count):
        message = rng.choice(icd.messages)
        words = max(message.word_count + rng.choice((0, 0, 0, 0, -1)), 0)
        tx = message.command >> 10 & 1
        records.append(MonitorRecord(
            t, "A", TransferFormat.RT_BC if tx else TransferFormat.BC_RT, message.command,
            data=tuple(rng.choice(SPECIAL_WORDS) for _ in range(words)),
            status=((message.command >> 11) << 11,), gaps_ns=(8_000,),
            errors=("parity",) if rng.random() < 0.05 else ()))
        t += 500_000
    return records


def test_repeated_and_special_values_decode_as_json_dumps(tmp_path: Path) -> None:
    path = tmp_path / "repeating.c10"
    with Chapter10Writer(path, start_time=datetime(2026, 5, 18, 9)) as writer:
        writer.write(repeating_traffic(3000, SEED))
    got, expected = values_both_ways(path)
    text = "".join(e for e in expected if e)
    for needle in ("-0.0", "NaN", "Infinity", "-Infinity", "e-", "e+", '"flags"', '"POSITION"'):
        assert needle in text, needle
    assert got == expected


def test_single_floats_are_what_the_traffic_gives() -> None:
    """The float32 words of :data:`SPECIAL_WORDS` are the specials the test above names."""
    pairs = {(hi, lo) for hi in SPECIAL_WORDS for lo in SPECIAL_WORDS}
    singles = {struct.unpack(">f", struct.pack(">HH", hi, lo))[0] for hi, lo in pairs}
    assert float("inf") in singles and float("-inf") in singles
    assert any(s != s for s in singles) and any(0 < s < 1e-38 for s in singles)
