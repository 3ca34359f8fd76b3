"""The compiled JSON row writer writes every number as ``json.dumps`` does, or leaves it to
``repr``; rows come out as their pieces say."""

from __future__ import annotations

import json

import numpy as np

from drivers.jsontext import NUMBER_BYTES, TextPool, shortest_decimals, write_rows

SEED = 20261125


def numbers_as_written(values: np.ndarray) -> list[str | None]:
    """Each value as the writer writes it (one row, one cell per value); None where
    :func:`shortest_decimals` leaves it to the caller."""
    digits, mantissa = shortest_decimals(values)
    pool = TextPool()
    none, bar = pool.add(""), pool.add("|")
    out = np.empty(values.size * (NUMBER_BYTES + 1), np.uint8)
    cells = (1, values.size)
    data, starts = pool.arrays()
    written = write_rows(data, starts, none, np.full(values.size, none, np.int64),
                         np.full(values.size, bar, np.int64),
                         digits.reshape(cells), mantissa.reshape(cells),
                         np.full(cells, -1, np.int64), np.full((1, 0), -1, np.int64),
                         np.zeros(0, np.int64), -1, -1, none, out)
    texts = out[:written].tobytes().decode("ascii").rstrip("\n").split("|")[:-1]
    return [t if d >= 0 else None for t, d in zip(texts, digits.tolist(), strict=True)]


def test_numbers_are_written_as_json_dumps_writes_them() -> None:
    rng = np.random.default_rng(SEED)
    scaled = [rng.integers(-(1 << 31), 1 << 31, 20_000) * lsb
              for lsb in (1.0, 0.1, 0.01, 0.001, 0.0001, 0.00025, 2.0 ** -9, 2.0 ** -17, 1e-7)]
    bits = rng.integers(0, 1 << 63, 20_000, dtype=np.int64).view(np.float64)
    special = np.array([0.0, -0.0, 0.1 * 3, 1932 * 0.1, 2.0 ** -17 * 3, 1e-4,
                        np.nextafter(1e-4, 0), 9.9999e-5, 1e15, 2.0 ** 48,
                        np.nextafter(2.0 ** 48, 0), 1e16, 123456789012.345,
                        0.5, -2.5, 1e-3, 7.0, np.nan, np.inf, -np.inf])
    values = np.concatenate([*scaled, bits, rng.normal(0, 1e3, 20_000), special])
    written = numbers_as_written(values)
    fast = [(text, value) for text, value in zip(written, values.tolist(), strict=True)
            if text is not None]
    assert len(fast) > 0.6 * values.size   # all but the random bit patterns
    assert [text for text, _ in fast] == [json.dumps(value) for _, value in fast]
    left = {repr(v) for t, v in zip(written, values.tolist(), strict=True) if t is None}
    assert {"-0.0", "nan", "inf", "-inf", "1e+16", "9.9999e-05"} <= left


def test_rows_carry_their_texts_marks_and_numbers() -> None:
    pool = TextPool()
    head, tail = pool.add('{"m": 1'), pool.add("}")
    prefix = np.array([pool.add(', "a": '), pool.add(', "g": ['), pool.add(", ")], np.int64)
    suffix = np.array([-1, -1, pool.add("]")], np.int64)
    values = np.array([[1.5, 2.0, -0.25], [3.0, 1e-4, 10.0]])
    digits, mantissa = shortest_decimals(values.ravel())
    text = np.full((2, 3), -1, np.int64)
    text[1, 0] = pool.add('"ON"')
    marks = np.array([[-1], [pool.add('["missing"]')]], np.int64)
    mark_key = np.array([pool.add('"a": ')], np.int64)
    marks_open, marks_close = pool.add(', "flags": {'), pool.add("}")
    out = np.empty(1024, np.uint8)
    data, starts = pool.arrays()
    written = write_rows(data, starts, head, prefix, suffix, digits.reshape(2, 3),
                         mantissa.reshape(2, 3), text, marks, mark_key, marks_open,
                         marks_close, tail, out)
    lines = out[:written].tobytes().decode("ascii").splitlines()
    assert [json.loads(line) for line in lines] == [
        {"m": 1, "a": 1.5, "g": [2.0, -0.25]},
        {"m": 1, "a": "ON", "g": [0.0001, 10.0], "flags": {"a": ["missing"]}}]
