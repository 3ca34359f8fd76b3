"""Whole runs: drive an :class:`EmaBatch` over a profile and collect the result.

:func:`run_batch` is the batch entry point (fault dictionaries, tests, benches); the streaming
entry point is :meth:`EmaBatch.advance`, which this module simply calls in chunks.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence

import numpy as np

from mapr_daemon.arrays import FloatArray
from mapr_daemon.ema.batch import RunSpec
from mapr_daemon.ema.plant import EmaBatch
from mapr_daemon.ema.profile import Profile
from mapr_daemon.errors import ConfigError


@dataclasses.dataclass(frozen=True)
class RunResult:
    """Signals of a batch over one profile: arrays ``(n_runs, n_samples)``."""

    specs: tuple[RunSpec, ...]
    profile: Profile
    time_s: FloatArray
    channels: dict[str, FloatArray]
    truth: dict[str, FloatArray]


def run_batch(specs: Sequence[RunSpec], profile: Profile, *, powered: bool = True,
              chunk: int = 200,
              progress: Callable[[float], None] | None = None) -> RunResult:
    """Simulate every run over ``profile`` together; ``progress`` gets the done fraction."""
    plant = EmaBatch(specs, powered=powered)
    rate = 1.0 / plant.sample_period_s
    if profile.n_samples > 1:
        prof_rate = 1.0 / float(profile.time_s[1] - profile.time_s[0])
        if abs(prof_rate - rate) > 1e-6 * rate:
            raise ConfigError(f"profile sampled at {prof_rate:g} Hz, plant at {rate:g} Hz",
                              field="sample_rate_hz")
    n = profile.n_samples
    parts: list[dict[str, FloatArray]] = []
    truths: list[dict[str, FloatArray]] = []
    for start in range(0, n, chunk):
        stop = min(n, start + chunk)
        # (1, n): shared by the runs; a 1-D chunk as long as the batch would read as per-run
        block = plant.advance(stop - start, profile.command_deg[None, start:stop],
                              profile.dynamic_pressure_pa[None, start:stop])
        parts.append(block.channels)
        truths.append(block.truth)
        if progress is not None:
            progress(stop / n)
    channels = {k: np.concatenate([p[k] for p in parts], axis=1) for k in parts[0]}
    truth = {k: np.concatenate([p[k] for p in truths], axis=1) for k in truths[0]}
    return RunResult(tuple(specs), profile, profile.time_s.copy(), channels, truth)
