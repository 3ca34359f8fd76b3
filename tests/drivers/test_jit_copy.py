"""``copy_block`` copies a fixed block with nothing checked, so it takes only what its
callers size their buffers for: 1-D C-contiguous uint8 arrays and integer offsets."""

from __future__ import annotations

import numba
import numpy as np
import pytest

from drivers.jit import COPY_BLOCK, copy_block


@numba.njit
def _copy(target: np.ndarray, at: int, source: np.ndarray, start: int) -> None:
    copy_block(target, at, source, start)


def test_copies_one_block_from_and_to_byte_offsets() -> None:
    source = np.arange(3 * COPY_BLOCK, dtype=np.uint8)
    target = np.zeros(3 * COPY_BLOCK, dtype=np.uint8)
    _copy(target, 5, source, 7)
    assert target[5:5 + COPY_BLOCK].tolist() == list(range(7, 7 + COPY_BLOCK))
    assert not target[:5].any() and not target[5 + COPY_BLOCK:].any()


@pytest.mark.parametrize("source", [
    np.zeros(64, np.int64),                              # offsets would be scaled by 8
    np.arange(128, dtype=np.uint8)[::2],                 # strided: not the elements asked
    np.zeros((2, 32), np.uint8),                         # two-dimensional
], ids=["int64", "strided", "2-d"])
def test_anything_else_does_not_compile(source: np.ndarray) -> None:
    with pytest.raises(numba.core.errors.TypingError):
        _copy(np.zeros(64, np.uint8), 0, source, 0)
