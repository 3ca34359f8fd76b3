"""JSON text of many rows at once, compiled: floats exactly as ``json.dumps`` writes them.

``mapr decode --icd`` prints a few hundred thousand engineering values a minute of bus time.
Python's ``repr`` of a float (what ``json.dumps`` writes) costs about 0.2 µs, as much as the
rest of the decode; assembling each line from per-value strings costs as much again. Here a
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
as pool texts. :func:`shortest_decimals` does the search; :func:`write_objects` the writing
(rows of different shapes, one after the other).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from drivers.jit import kernel

IntArray = npt.NDArray[np.int64]
FloatArray = npt.NDArray[np.float64]

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
def write_objects(pool: npt.NDArray[np.uint8], pool_start: IntArray, row_head: IntArray,
                  row_field: IntArray, row_fields: IntArray, row_cell: IntArray,
                  field_open: IntArray, field_close: IntArray, field_key: IntArray,
                  field_cells: IntArray, text: IntArray, digits: IntArray,
                  mantissa: IntArray, code: npt.NDArray[np.uint8], code_text: IntArray,
                  marks_open: int, marks_close: int, tail: int, out: npt.NDArray[np.uint8],
                  ends: IntArray) -> int:
    """Write rows of different shapes one after the other into ``out`` (no newline);
    ``ends[r]`` is where row ``r`` ends; return the bytes written (``out`` must be large
    enough).

    Texts are pool entries: entry ``k`` is ``pool[pool_start[k]:pool_start[k + 1]]``; -1
    is none. Row ``r`` is ``row_head[r]``, then
    its ``row_fields[r]`` fields from ``row_field[r]`` on, each ``field_open[f]``, its
    ``field_cells[f]`` cells separated by ", " and ``field_close[f]``; its cells are taken
    in order from ``row_cell[r]`` on, each its pool text ``text[c]`` if not -1, else the
    number ``digits[c]``/``mantissa[c]`` of :func:`shortest_decimals`. Then, for each field
    whose cells' ``code`` bits, or-ed, give a text (``code_text[bits]`` not -1), that text
    after ``field_key[f]``: these separated by ", ", between ``marks_open`` and
    ``marks_close``, and only if there is one. Then ``tail``.
    """
    at = 0
    scratch = np.empty(24, dtype=np.uint8)
    for r in range(row_head.size):
        at = _put(pool, pool_start, row_head[r], out, at)
        c = row_cell[r]
        for f in range(row_field[r], row_field[r] + row_fields[r]):
            at = _put(pool, pool_start, field_open[f], out, at)
            for j in range(field_cells[f]):
                if j:
                    out[at] = 44  # ", "
                    out[at + 1] = 32
                    at += 2
                if text[c] >= 0:
                    at = _put(pool, pool_start, text[c], out, at)
                else:
                    at = _number(digits[c], mantissa[c], scratch, out, at)
                c += 1
            at = _put(pool, pool_start, field_close[f], out, at)
        c = row_cell[r]
        first = True
        for f in range(row_field[r], row_field[r] + row_fields[r]):
            bits = 0
            for _ in range(field_cells[f]):
                bits |= code[c]
                c += 1
            entry = code_text[bits]
            if entry < 0:
                continue
            if first:
                at = _put(pool, pool_start, marks_open, out, at)
                first = False
            else:
                out[at] = 44
                out[at + 1] = 32
                at += 2
            at = _put(pool, pool_start, field_key[f], out, at)
            at = _put(pool, pool_start, entry, out, at)
        if not first:
            at = _put(pool, pool_start, marks_close, out, at)
        at = _put(pool, pool_start, tail, out, at)
        ends[r] = at
    return at


@kernel
def _put(pool: npt.NDArray[np.uint8], pool_start: IntArray, entry: int,
         out: npt.NDArray[np.uint8], at: int) -> int:
    """Copy pool entry ``entry`` (none if -1) to ``out[at:]``; return the new end."""
    if entry < 0:
        return at
    start = int(pool_start[entry])
    size = int(pool_start[entry + 1]) - start
    out[at:at + size] = pool[start:start + size]
    return at + size


@kernel
def _number(digits: int, mantissa: int, scratch: npt.NDArray[np.uint8],
            out: npt.NDArray[np.uint8], at: int) -> int:
    """Write ``mantissa / 10**digits`` positionally (``.0`` for a whole number)."""
    if mantissa < 0:
        out[at] = 45  # "-"
        at += 1
        mantissa = -mantissa
    rest = np.uint64(mantissa)  # unsigned: division by 10 is a multiplication
    ten = np.uint64(10)
    count = 0
    while count <= digits or rest > 0:  # at least one digit before the point
        quotient = rest // ten
        scratch[count] = np.uint8(48 + (rest - quotient * ten))
        rest = quotient
        count += 1
    for j in range(count - 1, digits - 1, -1):
        out[at] = scratch[j]
        at += 1
    out[at] = 46  # "."
    at += 1
    if digits == 0:
        out[at] = 48
        return at + 1
    for j in range(digits - 1, -1, -1):
        out[at] = scratch[j]
        at += 1
    return at


NUMBER_BYTES = 24
"""Most bytes a number of :func:`shortest_decimals` takes (sign, 18 digits, point, one)."""


class TextPool:
    """Fixed texts (ASCII) numbered in the order first added, for :func:`write_objects`."""

    def __init__(self) -> None:
        self._index: dict[str, int] = {}
        self._texts: list[str] = []

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

    def extend(self, texts: list[str]) -> IntArray:
        """Add ``texts`` as new entries, without looking for equal ones (many texts once
        each: numbers); their entry numbers."""
        first = len(self._texts)
        self._texts += texts
        return np.arange(first, len(self._texts), dtype=np.int64)

    def longest(self) -> int:
        """Bytes of the longest entry."""
        return max(map(len, self._texts), default=0)

    def length(self, entry: int) -> int:
        """Bytes of entry ``entry`` (0 for -1)."""
        return 0 if entry < 0 else len(self._texts[entry])

    def arrays(self) -> tuple[npt.NDArray[np.uint8], IntArray]:
        """The pool's bytes and entry starts (one more than entries), for the kernel."""
        data = np.frombuffer("".join(self._texts).encode("ascii"), dtype=np.uint8)
        starts = np.zeros(len(self._texts) + 1, dtype=np.int64)
        np.cumsum([len(t) for t in self._texts], out=starts[1:])
        return data, starts
