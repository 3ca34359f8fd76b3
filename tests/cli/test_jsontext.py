"""The compiled JSON row writer writes every number as ``json.dumps`` does, or leaves it to
``repr``; rows of any shape come out as their pieces say."""

from __future__ import annotations

import json

import numpy as np

from drivers.jit import COPY_BLOCK
from mapr_daemon.cli.icdview.jsontext import NUMBER_BYTES, TextPool, shortest_decimals, write_rows

SEED = 20261125


def numbers_as_written(values: np.ndarray) -> list[str | None]:
    """Each value as the writer writes it (one row of one cell per value); None where
    :func:`shortest_decimals` leaves it to the caller."""
    digits, mantissa = shortest_decimals(values)
    n = values.size
    out = np.empty(n * NUMBER_BYTES + COPY_BLOCK, np.uint8)
    ends = np.empty(n, np.int64)
    data, starts = TextPool().arrays()
    empty = np.full(n, TextPool.EMPTY, np.int64)   # one template cell, nothing around it
    numbers = np.full(n, -1, np.int64)
    written = write_rows(data, starts, np.ones(n, np.int64), np.arange(n + 1, dtype=np.int64),
                         np.zeros(n, np.int64), empty, empty, empty[:1], numbers[:1], numbers,
                         digits, mantissa, np.zeros(n, np.uint8), np.full(256, -1, np.int64),
                         TextPool.EMPTY, TextPool.EMPTY, out, ends)
    text = out[:written].tobytes().decode("ascii")
    texts = [text[a:b] for a, b in zip([0, *ends[:-1].tolist()], ends.tolist(), strict=True)]
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


def test_rows_of_different_shapes_carry_their_texts_marks_and_numbers() -> None:
    pool = TextPool()
    # one template, fields: "a" scalar, "g" array of two, "b" scalar, "e" empty array
    lead = pool.add_all(['{"m": 1, "a": ', ', "g": [', ", ", '], "b": '])
    close = pool.add(', "e": []')
    cell_key = np.array([pool.add(f'"{k}": ') if k else -1 for k in ("a", "", "g", "b")],
                        np.int64)
    # a second template: a head and one scalar "z"; a row of no cells is its head alone
    lead = np.append(lead, pool.add('{"m": 2, "z": '))
    cell_key = np.append(cell_key, pool.add('"z": '))
    head, tail, newline = pool.add('{"m": 1'), pool.add("}"), pool.add("\n")
    # rows: m 1 / m 2 / m 1, no data / not described / m 1
    row_cells = np.array([4, 1, 0, 0, 4])
    row_cell = np.array([0, 4, 5, 5, 5, 9])
    row_template = np.array([0, 4, 0, 0, 0])
    row_close = np.array([close, TextPool.EMPTY, head, TextPool.EMPTY, close])
    row_tail = np.array([tail, tail, tail, newline, tail])
    values = np.array([1.5, 2.0, -0.25, 3.0, 7.0, 1e-4, 10.0, 1e-4, 0.0])
    digits, mantissa = shortest_decimals(values)
    text = np.full(values.size, -1, np.int64)
    text[3] = pool.add('"ON"')
    code = np.array([0, 1, 2, 1, 4, 0, 0, 0, 1], np.uint8)   # or-ed per field
    code_text = np.full(256, -1, np.int64)
    code_text[1], code_text[3] = pool.add('["low"]'), pool.add('["low", "high"]')
    marks_open, marks_close = pool.add(', "flags": {'), pool.add("}")
    out = np.empty(1024, np.uint8)
    ends = np.empty(row_cells.size, np.int64)
    data, starts = pool.arrays()
    written = write_rows(data, starts, row_cells, row_cell, row_template, row_close, row_tail,
                         lead, cell_key, text, digits, mantissa, code, code_text, marks_open,
                         marks_close, out, ends)
    whole = out[:written].tobytes().decode("ascii")
    rows = [whole[a:b] for a, b in zip([0, *ends[:-1].tolist()], ends.tolist(), strict=True)]
    assert rows[3] == "\n"
    assert [json.loads(row) for row in rows[:3] + rows[4:]] == [
        {"m": 1, "a": 1.5, "g": [2.0, -0.25], "b": "ON", "e": [],
         "flags": {"g": ["low", "high"], "b": ["low"]}},
        {"m": 2, "z": 7.0},
        {"m": 1},
        {"m": 1, "a": 0.0001, "g": [10.0, 0.0001], "b": 0.0, "e": [],
         "flags": {"b": ["low"]}}]


def test_millions_of_scaled_values_are_written_as_repr_writes_them() -> None:
    """The numbers of an ICD decode: 16-bit fields (signed or not) times the usual LSBs,
    with offsets, the edges of 4 places and of 10 000, and doubles of every magnitude the
    writer takes, each with its sign; every one the writer writes reads as ``repr``'s."""
    rng = np.random.default_rng(SEED + 1)
    raw = rng.integers(-(1 << 15), 1 << 16, 50_000).astype(np.float64)
    lsbs = (0.001, 0.01, 0.1, 1 / 3, 2.0 ** -15, 2.0 ** -8, 0.05, 0.0025, 1e-4, 360 / 65536)
    scaled = [raw * lsb + offset for lsb in lsbs for offset in (0.0, -273.15, 0.5)]
    edges = np.array([9999.9999, 10000.0, 1e-4, 0.0001, 9999.99995, 99999.9999, 0.00011,
                      1.0000000000000002, 0.30000000000000004, 2.0 ** 48 - 1])
    near = np.concatenate([np.nextafter(edges, 0), edges, np.nextafter(edges, np.inf)])
    magnitudes = 10.0 ** rng.uniform(-4, np.log10(2.0 ** 48), 300_000)
    values = np.concatenate([*scaled, near, magnitudes])
    values = np.concatenate([values, -values])
    written = numbers_as_written(values)
    got = [(text, value) for text, value in zip(written, values.tolist(), strict=True)
           if text is not None]
    assert len(got) > 0.97 * values.size   # the rest: 16 digits past 2**53, left to repr
    assert [text for text, _ in got] == [repr(value) for _, value in got]
