"""Seeds for the benches: drawn afresh at every run unless given, and printed, so no printed
figure depends on a seed set that design choices were made on, and any can be rerun."""

from __future__ import annotations

import os

import numpy as np

FIRST = 10_000
"""Fresh seeds start here and stay below 10^8 (per-run seeds derived from them by the benches
then stay clear of the design sets: the dictionary's from 0, the validation set's from
5,000,000, the estimators' from 3,000,000 and 7,000,000)."""


def fresh(seed: int | None) -> int:
    """``seed`` if given, else one drawn from the operating system; printed either way."""
    if seed is None:
        seed = FIRST + int(np.random.SeedSequence().entropy % 90_000_000)
    print(f"seed {seed} (rerun with --seed {seed})")
    return seed


def master(seed: int | None, rerun: str) -> int:
    """A bench's master seed: ``seed`` if given, else 63 bits drawn from the operating system;
    printed with the command that reruns it (``rerun``, the seed appended) and the load
    average, the two lines every campaign bench opens with."""
    if seed is None:
        seed = int(np.random.SeedSequence().entropy % 2**63)  # type: ignore[operator]
    print(f"master seed {seed}  (rerun: {rerun} --seed {seed})")
    print(f"load average {' '.join(f'{x:.2f}' for x in os.getloadavg())} (2 cores, shared)")
    return seed
