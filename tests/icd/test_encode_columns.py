"""Encoding many messages at once as columns gives the per-message encoder's words exactly
(strict=False: saturating, counters wrapping), for every message of the EMA table and for
each parameter type."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
import pytest

from mapr_daemon.icd import Icd
from mapr_daemon.icd.encode_columns import encode_columns
from mapr_daemon.icd.encoder import encode_message
from mapr_daemon.icd.errors import IcdValueError
from mapr_daemon.icd.model import Message, Parameter, ParamType

N = 64


def _column(p: Parameter, rng: np.random.Generator, shape: tuple[int, ...]) -> Any:
    """Values over the parameter's whole range and a little past it (saturation)."""
    if p.type is ParamType.ENUM:
        return rng.choice(np.array(list(p.labels.values())), size=shape)
    if p.type is ParamType.DISCRETE:
        return rng.integers(0, 1 << p.width, size=shape)
    if p.type is ParamType.COUNTER:
        return rng.integers(0, 3 << p.width, size=shape)   # wraps
    low = p.raw_min * p.scale + p.offset
    high = p.raw_max * p.scale + p.offset
    span = abs(high - low) or 1.0
    return rng.uniform(min(low, high) - 0.1 * span, max(low, high) + 0.1 * span, size=shape)


def _values(message: Message, rng: np.random.Generator) -> dict[str, Any]:
    values = {p.name: _column(p, rng, (N,)) for p in message.parameters}
    if message.group is not None:
        values.update({c.name: _column(c, rng, (N, message.group.samples))
                       for c in message.group.channels})
    return values


def _one_by_one(message: Message, values: dict[str, Any]) -> np.ndarray:
    rows = []
    for i in range(N):
        row = {k: (v[i].tolist() if np.ndim(v) else v) for k, v in values.items()}
        rows.append(encode_message(message, row, strict=False))
    return np.array(rows, dtype=np.int64).reshape(N, message.word_count)


def test_every_message_of_the_ema_table(ema: Icd) -> None:
    rng = np.random.default_rng(5)
    for message in ema.messages:
        values = _values(message, rng)
        assert np.array_equal(encode_columns(message, values, N),
                              _one_by_one(message, values)), message.name


@pytest.mark.parametrize("spec", [
    "type: twos, lsb: 0.5", "type: unsigned, lsb: 0.25, offset: -10",
    "type: bnr, msb_weight: 90", "type: bnr, msb_weight: 16384, words: 2",
    "type: bcd", "type: float32, words: 2", "type: twos, words: 2, lsb: 0.001",
])
def test_each_type(one_parameter: Callable[..., Icd], spec: str) -> None:
    message = one_parameter(spec).message("m")
    values = _values(message, np.random.default_rng(9))
    assert np.array_equal(encode_columns(message, values, N), _one_by_one(message, values))


def test_scalars_broadcast_and_bad_values_are_named(ema: Icd) -> None:
    message = ema.message("ema_bit_result")
    names = [p.name for p in message.parameters]
    values: dict[str, Any] = {name: 0 for name in names}
    values["bit_state"] = np.array(["RUNNING", "DONE"])
    words = encode_columns(message, values, 2)
    for i, state in enumerate(("RUNNING", "DONE")):
        assert tuple(words[i]) == encode_message(message, {**values, "bit_state": state},
                                                 strict=False)
    with pytest.raises(IcdValueError, match="bit_state"):
        encode_columns(message, {**values, "bit_state": np.array(["NOT_A_STATE"])}, 1)
    with pytest.raises(IcdValueError, match="no_such"):
        encode_columns(message, {**values, "no_such": 1}, 1)
