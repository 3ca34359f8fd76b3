"""Engineering values -> data words for many messages at once, as columns.

:func:`encode_columns` is :func:`~mapr_daemon.icd.encoder.encode_message` with
``strict=False`` over ``n`` messages of one kind: each parameter's value is a column (one per
message, a scalar for all of them, ``(n, samples)`` for a repeating-group channel) and the
result is an ``(n, word_count)`` array of words. Values saturate to what the bits hold and
counters wrap, exactly as the per-message encoder does; the words are the same
(tests/icd/test_encode_columns.py checks every message of the shipped table against it).
The synthetic fleet archive encodes a flight's sensor blocks with it (a Python call per
message was most of a flight's time); the loopback terminals, which answer one poll at a time,
keep the per-message encoder.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
import numpy.typing as npt

from mapr_daemon.icd.errors import IcdValueError
from mapr_daemon.icd.model import Message, Parameter, ParamType

IntArray = npt.NDArray[np.int64]


def encode_columns(message: Message, values: Mapping[str, Any], n: int) -> IntArray:
    """The ``(n, word_count)`` data words of ``n`` messages ``message`` carrying ``values``
    (see the module docstring). Missing or unknown names raise :class:`IcdValueError`, as
    does a number that is not finite or a label the table does not list."""
    names = {p.name for p in message.all_parameters()}
    unknown = sorted(set(values) - names)
    if unknown:
        raise IcdValueError(f"message {message.name!r} has no parameter "
                            + ", ".join(repr(u) for u in unknown), field=unknown[0])
    words = np.zeros((n, message.word_count), dtype=np.int64)
    for p in message.parameters:
        column = np.broadcast_to(np.asarray(_get(values, p)), (n,))
        _place(words, p, 0, raw_columns(p, column))
    g = message.group
    if g is not None:
        for c in g.channels:
            block = _get(values, c)
            try:
                samples = np.broadcast_to(np.asarray(block), (n, g.samples))
            except ValueError:
                raise IcdValueError(f"needs {g.samples} samples per message, got shape "
                                    f"{np.shape(block)}", field=c.name) from None
            for i in range(g.samples):
                _place(words, c, g.start + i * g.stride, raw_columns(c, samples[:, i]))
    return words


def raw_columns(p: Parameter, column: npt.NDArray[Any]) -> IntArray:
    """The unsigned bit patterns (``width`` bits, before shifting) carrying ``column``, as
    :func:`~mapr_daemon.icd.encoder.to_raw` with ``strict=False`` gives them one by one."""
    mask = (1 << p.width) - 1
    if p.type is ParamType.ENUM:
        if column.dtype.kind in "UO":
            by_label = {label: code for code, label in p.labels.items()}
            try:
                return np.array([by_label[str(v)] for v in column], dtype=np.int64) & mask
            except KeyError as missing:
                raise IcdValueError(f"{missing.args[0]!r} is not one of "
                                    + ", ".join(p.labels.values()), field=p.name) from None
        return column.astype(np.int64) & mask
    if p.type in (ParamType.DISCRETE, ParamType.COUNTER):
        codes = column.astype(np.int64)
        if p.type is ParamType.COUNTER:
            return codes & mask
        if np.any((codes < 0) | (codes > mask)):
            raise IcdValueError(f"a code does not fit in {p.width} bit(s)", field=p.name)
        return codes
    numbers = column.astype(np.float64)
    if p.type is ParamType.FLOAT32:
        with np.errstate(over="ignore"):
            single = ((numbers - p.offset) / p.scale).astype(">f4")
        return single.view(">u4").astype(np.int64)
    if not np.all(np.isfinite(numbers)):
        raise IcdValueError(f"a value that is not finite cannot be carried by a {p.type}",
                            field=p.name)
    code = np.floor((numbers - p.offset) / p.scale + 0.5)
    code = np.clip(code, p.raw_min, p.raw_max).astype(np.int64)
    if p.type is ParamType.BCD:   # decimal digits become nibbles
        nibbles = np.zeros_like(code)
        rest = code.copy()
        for digit in range(p.width // 4):
            nibbles |= (rest % 10) << (4 * digit)
            rest //= 10
        return nibbles
    return code & mask


def _get(values: Mapping[str, Any], p: Parameter) -> Any:
    if p.name not in values:
        raise IcdValueError("no value given", field=p.name)
    return values[p.name]


def _place(words: IntArray, p: Parameter, base: int, bits: IntArray) -> None:
    field = bits << p.lsb
    indices = p.word_indices(base)
    if p.words == 1:
        words[:, indices[0]] |= field
    else:
        words[:, indices[0]] |= field >> 16
        words[:, indices[1]] |= field & 0xFFFF
