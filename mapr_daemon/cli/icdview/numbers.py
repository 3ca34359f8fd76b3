"""Numbers as ``json.dumps`` writes them, for a column of values at once, without a
``repr`` per number where the number is short.

A value's text is given in two parts, to be written one after the other (the ``repr`` writer
of :mod:`mapr_daemon.cli.icdview.batch` joins them, once per distinct value of a column):
most engineering values of a 1553 bus are a 16-bit field times a decimal LSB, whose shortest
decimal has at most 4 places and an integer part below 10 000; for those both parts come
from tables made once (the signed integer part; the point and the places), indexed with
numpy, so no number is formatted (joining the two parts costs a fraction of a ``repr``). The
rest (more places, larger, NaN, infinities) are written by ``repr`` in the first part, the
second empty: in bench/chapter10_speed.py's random traffic a sixth of the numbers (a quarter
of the distinct ones), of which three fifths are LSB products that need 16 or 17 digits
(``0.001 * 15623`` is ``15.623000000000001``), a quarter BNR values (binary LSBs: more
places), the rest float32 values and counters from 10 000 on.

Why the tables' text is ``repr``'s: for ``1e-4 <= |v| < 1e4`` the spacing of doubles near
``v`` is below ``2e-12``, far below ``1e-4``, so at most one decimal of at most 4 places
reads back as ``v``. It is found with ``k = rint(|v| * 10**4)``: it exists if and only if
``k / 10**4 == |v|`` (exact: the quotient of two exact doubles is rounded once, as parsing
the decimal rounds it). Written with its trailing zeros left out (the places' table leaves
them out) it has the fewest significant digits of all decimals that read back, which is
what ``repr`` writes, positionally (``repr`` writes an exponent only below 1e-4 and from
1e16 on), with ``.0`` for a whole number. ``-0.0`` is ``-0`` and ``.0``, as ``repr``
writes it. tests/chapter10/test_number_text.py checks it against ``json.dumps``, number by
number.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
import numpy.typing as npt

PLACES = 4
"""Most decimal places the tables write."""

WHOLE = 10**PLACES
"""The integer parts the tables write are below this."""


@lru_cache(maxsize=1)
def _tables() -> tuple[npt.NDArray[np.object_], npt.NDArray[np.object_]]:
    """The integer parts (0 .. WHOLE - 1, then the same negative, ``-0`` included) and
    the point with the places (index: the places' digits as a 4-digit number, 0 for
    ``.0``): about 3 ms, once per process."""
    whole = list(map(str, range(WHOLE)))
    heads = np.array(whole + ["-" + text for text in whole], dtype=object)
    places = [("." + text.zfill(PLACES)).rstrip("0") for text in whole]
    places[0] = ".0"
    return heads, np.array(places, dtype=object)


def number_parts(values: npt.NDArray[np.float64]
                 ) -> tuple[npt.NDArray[np.object_], npt.NDArray[np.object_]]:
    """Two object arrays of texts whose concatenation, element by element, is what
    ``json.dumps`` writes for each of ``values`` (``repr``; ``NaN``, ``Infinity``,
    ``-Infinity`` by name)."""
    magnitude = np.abs(values)
    with np.errstate(over="ignore", invalid="ignore"):  # huge, infinite, NaN: repr below
        scaled = np.rint(magnitude * WHOLE)
        short = (scaled / WHOLE == magnitude) & (magnitude < WHOLE)   # NaN is not: repr
    k = np.where(short, scaled, 0).astype(np.int64)
    heads_table, places_table = _tables()
    whole = k // WHOLE
    heads = heads_table[whole + WHOLE * np.signbit(values)]
    tails = places_table[k - whole * WHOLE]
    long = np.flatnonzero(~short)
    if long.size:
        heads[long] = list(map(repr, values[long].tolist()))
        tails[long] = ""
        for at in long[~np.isfinite(values[long])].tolist():
            heads[at] = _non_finite(float(values[at]))
    return heads, tails


def _non_finite(value: float) -> str:
    """``json.dumps(value)`` of NaN or an infinity."""
    return "NaN" if value != value else ("Infinity" if value > 0 else "-Infinity")
