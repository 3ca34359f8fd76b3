"""JSON text of many rows at once, compiled: floats exactly as ``json.dumps`` writes them.

``mapr decode --icd`` prints a few hundred thousand engineering values a minute of bus time.
Python's ``repr`` of a float (what ``json.dumps`` writes) costs as much as the rest of the
decode (docs/figures.md); assembling each line from per-value strings costs as much again. Here a
batch of rows is written into one byte buffer by a compiled kernel (:mod:`drivers.jit`),
each row where the last ended, from a pool of fixed texts (keys, labels, flag lists) and
numbers.

*Numbers.* ``repr`` gives the shortest decimal that reads back as the same float (the
closest such if several), positional for magnitudes in [1e-4, 1e16). For such a value, the
shortest one is found by trying 0, 1, 2... digits after the point: with
``m = rint(|x| * 10**d)``, the text of ``m / 10**d`` reads back as ``x`` exactly when the
(correctly rounded) division ``m / 10**d`` equals ``x``, which is how reading the text
rounds. The first ``d`` that reads back is ``repr``'s text: while ``|x| * 10**d < 2**48``
two decimals ``10**-d`` apart cannot both round to ``x`` (its spacing is 16 times finer), so
the shortest is unique, and the product is close enough to ``m`` for ``rint`` to find it.
From there (15 significant digits and more: ``0.1 * 3``, most scaled values of an ICD) the
product is taken exactly (:func:`_long_decimal`). Values outside all this (NaN,
infinities, -0.0, tiny or huge magnitudes, exact ties) are left to the caller (``repr``),
as pool texts. :func:`shortest_decimals` does the search; :func:`write_rows` the writing
(rows of different shapes, one after the other).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from drivers.jit import COPY_BLOCK, copy_block, inline_kernel, kernel
from mapr_daemon.arrays import FloatArray

WRITTEN_FOR_BLOCK = 32
"""The :data:`~drivers.jit.COPY_BLOCK` this file's kernels were compiled for. numba caches a
kernel by its own source file only, so a new block size in drivers/jit.py alone would leave
the cached kernels copying the old size while the buffers are sized for the new one (bytes
written past their end): such a change must come with one here, which renews this file's
cache."""
if COPY_BLOCK != WRITTEN_FOR_BLOCK:
    raise ImportError("mapr_daemon/cli/icdview/jsontext.py is written for "
                      f"{WRITTEN_FOR_BLOCK}-byte copies, "
                      f"drivers/jit.py copies {COPY_BLOCK}: change both (and clear the "
                      "kernel cache)")

IntArray = npt.NDArray[np.int64]

_POWERS = np.array([10.0 ** d for d in range(21)])
"""Exact powers of ten (all below 2**53)."""
_LIMIT = 2.0 ** 48
_SMALLEST = 1e-4
_EXACT_INT = 2 ** 53
"""Integers up to this are exact as floats."""
_SEVENTEEN_DIGITS = 10 ** 16
"""``repr`` turns to an exponent below this magnitude."""


@kernel
def shortest_decimals(values: FloatArray) -> tuple[IntArray, IntArray]:
    """Per value, the digits after the point of ``repr`` (-1 where the caller must use
    ``repr``, see the module doc) and the decimal's integer ``m`` (signed): the text is
    ``m / 10**d`` written out, ``.0`` when ``d`` is 0."""
    digits = np.full(values.size, -1, dtype=np.int64)
    mantissa = np.zeros(values.size, dtype=np.int64)
    for i in range(values.size):
        x = values[i]
        size = abs(x)
        if x == 0.0:
            if not np.signbit(x):
                digits[i] = 0
            continue
        if not (size >= _SMALLEST and size < _LIMIT):  # NaN fails both
            continue
        for d in range(_POWERS.size):
            scaled = size * _POWERS[d]
            if scaled >= _LIMIT:   # 15 digits or more: exact products from here
                places, exact = _long_decimal(size, d)
                if places >= 0:
                    digits[i] = places
                    mantissa[i] = exact if x > 0 else -exact
                break
            m = np.rint(scaled)
            if m / _POWERS[d] == size:
                digits[i] = d
                mantissa[i] = np.int64(m) if x > 0 else -np.int64(m)
                break
    return digits, mantissa
@kernel
def _long_decimal(size: float, first: int) -> tuple[int, int]:
    """The shortest decimal of ``size`` with ``first`` or more digits after the point
    (where ``size * 10**first >= 2**48``): digits after the point and the decimal's integer,
    or (-1, -1) where only ``repr`` can tell (an exact tie, 16 digits above 2**53).

    ``size * 10**d`` is taken exactly, as the sum of two floats (Dekker's product), and
    rounded to the nearest integer ``n``. Up to 2**53, ``n`` is exact as a float and reads
    back as ``size`` exactly when ``n / 10**d == size``, as in :func:`shortest_decimals`.
    Past it, ``n`` has 17 significant digits: a double always reads back from its nearest
    17-digit decimal, which is then ``repr``'s (the closest of the shortest).
    """
    for d in range(first, _POWERS.size):
        hi, lo = _product(size, _POWERS[d])
        whole = np.floor(hi)
        frac = hi - whole          # exact; a multiple of hi's spacing (>= 1/16 here)
        n = int(whole)
        if frac == 0.0:            # lo may be more than a half (hi >= 2**52)
            step = np.rint(lo)
            if abs(lo - step) == 0.5:
                return -1, -1
            n += int(step)
        elif frac == 0.5:          # lo (at most half of hi's spacing) decides
            if lo == 0.0:
                return -1, -1
            n += int(lo > 0.0)
        else:                      # at least one spacing from a half: lo cannot tip it
            n += int(frac > 0.5)
        if n > _EXACT_INT:
            if n >= _SEVENTEEN_DIGITS:
                return d, n
            return -1, -1
        if float(n) / _POWERS[d] == size:
            return d, n
    return -1, -1


@kernel
def _product(a: float, b: float) -> tuple[float, float]:
    """``a * b`` exactly, as ``hi + lo`` (Dekker: each factor split into two halves of 26
    bits, whose products are exact)."""
    hi = a * b
    big = 134217729.0 * a   # 2**27 + 1
    a_hi = big - (big - a)
    a_lo = a - a_hi
    big = 134217729.0 * b
    b_hi = big - (big - b)
    b_lo = b - b_hi
    lo = ((a_hi * b_hi - hi) + a_hi * b_lo + a_lo * b_hi) + a_lo * b_lo
    return hi, lo


@kernel
def write_rows(pool: npt.NDArray[np.uint8], pool_start: IntArray, row_cells: IntArray,
               row_cell: IntArray, row_template: IntArray, row_close: IntArray,
               row_tail: IntArray, cell_lead: IntArray, cell_key: IntArray, text: IntArray,
               digits: IntArray, mantissa: IntArray, code: npt.NDArray[np.uint8],
               code_text: IntArray, marks_open: int, marks_close: int,
               out: npt.NDArray[np.uint8], ends: IntArray) -> int:
    """Write rows one after the other into ``out``; ``ends[r]`` is where row ``r`` ends;
    return the bytes written (``out`` must be large enough).

    Texts are pool entries (see :class:`TextPool`: entry 0 is empty, and ``out`` has
    :data:`COPY_BLOCK` bytes to spare past the text). Rows follow *templates*, one per
    shape of row, laid out as cells: template cell ``t`` is ``cell_lead[t]``, the text
    before it (the row's head and the key and bracket of its field for a field's first
    cell, ", " within an array, a field's closing bracket and the next key between
    fields), then the row's cell. Row ``r`` has ``row_cells[r]`` cells, taken in order
    from ``row_cell[r]`` on with the template cells from ``row_template[r]`` on; a cell is
    its pool text ``text[c]`` if not -1, else the number ``digits[c]``/``mantissa[c]`` of
    :func:`shortest_decimals`. Then ``row_close[r]`` (what follows the last cell; a row of
    no cells: all of its text). Then the flags: a field's cells' ``code`` bits, or-ed up to
    its last cell (where ``cell_key[t]``, the field's key, is not -1), give a text
    (``code_text[bits]`` not -1), written after that key; these separated by ", ", between
    ``marks_open`` and ``marks_close``, and only if there is one. Then ``row_tail[r]``.

    A shape's fixed texts are one pool entry between two cells, and the flags are
    gathered while the cells are written: one copy per cell and one pass over the cells
    (rather than a copy per field's key, bracket and separator and a second pass for the
    flags). Each text is copied by fixed blocks (:func:`drivers.jit.copy_block`), not byte
    by byte: a loop whose length changes from one text to the next cost most of the time.
    """
    at = 0
    flagged = np.empty(2 * cell_key.size + 2, dtype=np.int64)   # (key, text) pairs
    for r in range(row_cells.size):
        c = row_cell[r]
        t = row_template[r]
        bits = 0
        marks = 0
        for _ in range(row_cells[r]):
            at = _put(pool, pool_start, cell_lead[t], out, at)
            entry = text[c]
            if entry >= 0:
                at = _put(pool, pool_start, entry, out, at)
            else:
                at = _number(digits[c], mantissa[c], out, at)
            bits |= code[c]
            key = cell_key[t]
            if key >= 0 and bits:   # a field's last cell, flagged
                entry = code_text[bits]
                if entry >= 0:
                    flagged[marks] = key
                    flagged[marks + 1] = entry
                    marks += 2
                bits = 0
            c += 1
            t += 1
        at = _put(pool, pool_start, row_close[r], out, at)
        if marks:
            at = _put(pool, pool_start, marks_open, out, at)
            for k in range(0, marks, 2):
                if k:
                    out[at] = 44  # ", "
                    out[at + 1] = 32
                    at += 2
                at = _put(pool, pool_start, flagged[k], out, at)
                at = _put(pool, pool_start, flagged[k + 1], out, at)
            at = _put(pool, pool_start, marks_close, out, at)
        at = _put(pool, pool_start, row_tail[r], out, at)
        ends[r] = at
    return at


@inline_kernel
def _put(pool: npt.NDArray[np.uint8], pool_start: IntArray, entry: int,
         out: npt.NDArray[np.uint8], at: int) -> int:
    """Copy pool entry ``entry`` to ``out[at:]`` (by blocks: see :func:`write_rows`);
    return the new end."""
    start = pool_start[entry]
    size = pool_start[entry + 1] - start
    copy_block(out, at, pool, start)
    if size > COPY_BLOCK:
        done = COPY_BLOCK
        while done < size:
            copy_block(out, at + done, pool, start + done)
            done += COPY_BLOCK
    return int(at + size)


_PAIRS = np.array([ord(c) for i in range(100) for c in f"{i:02d}"], dtype=np.uint8)
"""The two digits of 0..99, one after the other."""
_UPOWERS = np.array([10 ** d for d in range(20)], dtype=np.uint64)
"""Powers of ten as integers: 10**19 is the last below 2**64."""


@inline_kernel
def _number(digits: int, mantissa: int, out: npt.NDArray[np.uint8], at: int) -> int:
    """Write ``mantissa / 10**digits`` positionally (``.0`` for a whole number).

    The integer and fractional parts are written from their last digit back, two digits
    per division (a table of the pairs 00..99), the fraction padded with zeros to
    ``digits`` places."""
    if mantissa < 0:
        out[at] = 45  # "-"
        at += 1
        mantissa = -mantissa
    rest = np.uint64(mantissa)
    if digits == 0:
        whole = rest
        fraction = np.uint64(0)
    elif digits >= _UPOWERS.size:   # 20 places: the mantissa (< 2**63) has fewer digits
        whole = np.uint64(0)
        fraction = rest
    else:
        whole = rest // _UPOWERS[digits]
        fraction = rest - whole * _UPOWERS[digits]
    size = 1
    while size < 20 and whole >= _UPOWERS[size]:
        size += 1
    end = at + size
    _digits_back(whole, size, out, end)
    out[end] = 46  # "."
    if digits == 0:
        out[end + 1] = 48
        return end + 2
    _digits_back(fraction, digits, out, end + 1 + digits)
    return end + 1 + digits


@inline_kernel
def _digits_back(value: np.uint64, count: int, out: npt.NDArray[np.uint8], end: int) -> None:
    """Write ``value`` as ``count`` digits (leading zeros) ending before ``out[end]``."""
    hundred = np.uint64(100)
    at = end
    while count >= 2:
        quotient = value // hundred
        pair = 2 * int(value - quotient * hundred)
        out[at - 2] = _PAIRS[pair]
        out[at - 1] = _PAIRS[pair + 1]
        value = quotient
        at -= 2
        count -= 2
    if count:
        out[at - 1] = np.uint8(48 + int(value % np.uint64(10)))


NUMBER_BYTES = 24
"""Most bytes a number of :func:`shortest_decimals` takes (sign, 18 digits, point, one)."""


class TextPool:
    """Fixed texts (ASCII) numbered in the order first added, for :func:`write_rows`.

    Entry 0 is the empty text (where a row has nothing to write: :func:`write_rows` takes
    no "none"), and the pool's bytes end in :data:`~drivers.jit.COPY_BLOCK` spare bytes,
    so that every entry can be copied by whole blocks."""

    EMPTY = 0

    def __init__(self) -> None:
        self._index: dict[str, int] = {"": self.EMPTY}
        self._texts: list[str] = [""]

    def add(self, text: str) -> int:
        """The entry number of ``text`` (added if new)."""
        entry = self._index.get(text)
        if entry is None:
            entry = self._index[text] = len(self._texts)
            self._texts.append(text)
        return entry

    def add_all(self, texts: list[str]) -> IntArray:
        """The entry numbers of ``texts`` (each added if new)."""
        return np.array([self.add(text) for text in texts], dtype=np.int64)

    def longest(self) -> int:
        """Bytes of the longest entry."""
        return max(map(len, self._texts), default=0)

    def arrays(self) -> tuple[npt.NDArray[np.uint8], IntArray]:
        """The pool's bytes (and the spare ones) and entry starts (one more than entries),
        for the kernel."""
        data = np.frombuffer(("".join(self._texts) + "\0" * COPY_BLOCK).encode("ascii"),
                             dtype=np.uint8)
        starts = np.zeros(len(self._texts) + 1, dtype=np.int64)
        np.cumsum([len(t) for t in self._texts], out=starts[1:])
        return data, starts
