"""Batched BIT-profile runs for dictionaries, calibration and benches.

The plant's compiled step advances every run of a batch in one call, and
:meth:`EmaBatch.advance` takes a dynamic pressure per run, so one batch mixes flight conditions:
the BIT command is the same for every run, only the air load differs. A run does not depend on
the batch it shares, so :func:`stream_bit` cuts the runs into small batches, flies them on a
thread per core (the compiled step releases the GIL) and hands each batch to a reducing step
(e.g. its feature matrices) in the worker: a dictionary build never holds every run's raw
channels. :func:`simulate_bit` collects every run's channels when a caller needs them all.
:class:`Runs` is what the reasoner reads — channels, command, dynamic pressure, corners —
whether it came from here or from a ``mapr simulate`` file (:func:`from_npz`).
"""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import TypeVar

import numpy as np

from mapr_daemon.arrays import FloatArray
from mapr_daemon.ema import dataset
from mapr_daemon.ema.batch import RunSpec
from mapr_daemon.ema.bit import bit_profile
from mapr_daemon.ema.faults import FaultSet
from mapr_daemon.ema.params import ActuatorParams
from mapr_daemon.ema.plant import EmaBatch
from mapr_daemon.errors import ConfigError
from mapr_daemon.reasoner.diagnosis.features import corner_samples
from mapr_daemon.reasoner.training.workers import Progress, resolve, unordered

T = TypeVar("T")


@dataclasses.dataclass(frozen=True)
class Runs:
    """Signals of ``n`` runs over one BIT profile (arrays ``(n, samples)``)."""

    channels: dict[str, FloatArray]
    command_deg: FloatArray
    dynamic_pressure_pa: FloatArray
    corners: tuple[int, ...]
    sample_rate_hz: float
    labels: tuple[str, ...]

    @property
    def n(self) -> int:
        return int(self.dynamic_pressure_pa.size)


RUNS_PER_BATCH = 32
"""Runs per plant batch of :func:`stream_bit`: small enough that a worker's raw channels and
their derived signals stay near 25 MB, large enough that Python's share of a batch (noise
draws, ADC, one call per chunk of samples) stays small beside the compiled step."""


@dataclasses.dataclass(frozen=True, eq=False)
class BitRuns:
    """What :func:`stream_bit` flies: every run's faults, pressure, seed and condition."""

    fault_sets: tuple[FaultSet, ...]
    dynamic_pressure_pa: FloatArray
    seeds: tuple[int, ...]
    ambient_c: tuple[float | None, ...]
    bus_v: tuple[float | None, ...]
    specs: tuple[RunSpec, ...] | None = None
    """The caller's own runs (each its parameters, model form, faults, seed and condition: a
    mismatched unit's, say), flown instead of the actuator file's with the fields above."""

    @classmethod
    def of(cls, fault_sets: Sequence[FaultSet], dynamic_pressure_pa: Sequence[float],
           seeds: Sequence[int], ambient_c: Sequence[float | None] | None = None,
           bus_v: Sequence[float | None] | None = None) -> BitRuns:
        """The runs, checked: every sequence as long as ``fault_sets``, at least one run."""
        n = len(fault_sets)
        amb = (None,) * n if ambient_c is None else tuple(ambient_c)
        bus = (None,) * n if bus_v is None else tuple(bus_v)
        if not (n == len(dynamic_pressure_pa) == len(seeds) == len(amb) == len(bus)) or not n:
            raise ConfigError("faults, pressures, seeds and conditions must be equally long",
                              field="runs")
        return cls(tuple(fault_sets), np.asarray(dynamic_pressure_pa, dtype=np.float64),
                   tuple(int(s) for s in seeds), amb, bus)

    @classmethod
    def of_specs(cls, specs: Sequence[RunSpec], dynamic_pressure_pa: Sequence[float],
                 params: ActuatorParams) -> BitRuns:
        """The caller's own runs, one pressure each; they must share ``params``' sample rate."""
        if any(s.params.sensors.sample_rate_hz != params.sensors.sample_rate_hz for s in specs):
            raise ConfigError("the specs' sample rate differs from params'", field="specs")
        runs = cls.of([s.faults for s in specs], dynamic_pressure_pa, [s.seed for s in specs],
                      [s.ambient_c for s in specs], [s.bus_v for s in specs])
        return dataclasses.replace(runs, specs=tuple(specs))

    @property
    def n(self) -> int:
        return len(self.fault_sets)


def bit_layout(params: ActuatorParams) -> tuple[tuple[int, ...], int]:
    """The BIT profile's corner samples and its length in samples at the actuator's rate (what
    the window starts of M are computed from, before any run is flown)."""
    rate = params.sensors.sample_rate_hz
    prof = bit_profile(rate, "ground", params.bit)
    return corner_samples(prof.corners_s, rate), prof.n_samples


def _fly(params: ActuatorParams, runs: BitRuns, lo: int, hi: int, chunk: int,
         progress: Progress) -> Runs:
    """Runs ``lo:hi`` in one plant batch of their own (a run does not depend on its batch)."""
    rate = params.sensors.sample_rate_hz
    prof = bit_profile(rate, "ground", params.bit)
    specs = (list(runs.specs[lo:hi]) if runs.specs is not None else
             [RunSpec(params, runs.fault_sets[i], seed=runs.seeds[i],
                      ambient_c=runs.ambient_c[i], bus_v=runs.bus_v[i]) for i in range(lo, hi)])
    plant = EmaBatch(specs)
    q = runs.dynamic_pressure_pa[lo:hi]
    channels: dict[str, FloatArray] = {}
    for start in range(0, prof.n_samples, chunk):
        stop = min(prof.n_samples, start + chunk)
        # command (1, n) and pressure (runs, 1): explicit, a 1-D chunk as long as the batch
        # would be read as per-run
        block = plant.advance(stop - start, prof.command_deg[None, start:stop], q[:, None])
        for name, values in block.channels.items():
            if name not in channels:
                channels[name] = np.empty((hi - lo, prof.n_samples))
            channels[name][:, start:stop] = values
        progress.add((hi - lo) * (stop - start))
    return Runs(channels, prof.command_deg.copy(), q.copy(),
                corner_samples(prof.corners_s, rate), rate,
                tuple(fs.label() for fs in runs.fault_sets[lo:hi]))


def stream_bit(params: ActuatorParams, runs: BitRuns, reduce: Callable[[Runs], T], *,
               chunk: int = 250, runs_per_batch: int = RUNS_PER_BATCH,
               workers: int | None = None,
               progress: Callable[[float], None] | None = None) -> Iterator[tuple[int, T]]:
    """Fly the BIT profile once per run, in batches of ``runs_per_batch`` on ``workers``
    threads, and yield ``(first run index, reduce(batch))`` as each batch lands.

    ``reduce`` runs in the worker (e.g. the batch's feature matrices), so the raw channels of
    only ``workers`` batches are alive at once. Batches land in any order; each run's result is
    the same as in one batch of all runs, bit for bit, whatever the batch size or worker count.
    ``workers=None`` uses :func:`~mapr_daemon.reasoner.training.workers.usable_cores`. ``progress``
    gets the fraction of run-samples flown (monotone, ending at 1.0), from any thread.
    """
    if runs_per_batch < 1 or chunk < 1:
        raise ConfigError("runs_per_batch and chunk must be >= 1", field="runs_per_batch")
    n_workers = resolve(workers)
    total = runs.n * bit_layout(params)[1]
    count = Progress(total, progress)

    def one(lo: int) -> tuple[int, T]:
        return lo, reduce(_fly(params, runs, lo, min(runs.n, lo + runs_per_batch), chunk, count))

    yield from unordered(one, range(0, runs.n, runs_per_batch), n_workers)


def simulate_bit(params: ActuatorParams, fault_sets: Sequence[FaultSet],
                 dynamic_pressure_pa: Sequence[float], seeds: Sequence[int],
                 chunk: int = 250, progress: Callable[[float], None] | None = None,
                 ambient_c: Sequence[float | None] | None = None,
                 bus_v: Sequence[float | None] | None = None, *,
                 specs: Sequence[RunSpec] | None = None,
                 workers: int | None = None, runs_per_batch: int = RUNS_PER_BATCH) -> Runs:
    """Fly the BIT profile once per (faults, q, seed): every run's channels in one :class:`Runs`.

    ``ambient_c`` and ``bus_v`` give each run's flight condition (ambient temperature, the
    aircraft bus's mean); ``None`` (for all runs or one) leaves it to the plant's own draw.
    The runs are flown as :func:`stream_bit` flies them (batches on ``workers`` threads); a
    caller that only needs each run's M should use :func:`stream_bit` with a reducing step
    rather than keep every run's raw channels.

    ``specs`` flies the caller's own runs instead, one per pressure, each with its own
    parameters, model form, faults, seed and condition (a mismatched unit's, say); the
    per-run ``fault_sets``, ``seeds``, ``ambient_c`` and ``bus_v`` must then be empty, and the
    specs must share ``params``'s sample rate.
    """
    if specs is not None:
        if fault_sets or seeds or ambient_c or bus_v:
            raise ConfigError("give the runs either as specs or as faults, seeds and "
                              "conditions, not both", field="runs")
        todo = BitRuns.of_specs(specs, dynamic_pressure_pa, params)
    else:
        todo = BitRuns.of(fault_sets, dynamic_pressure_pa, seeds, ambient_c, bus_v)
    channels: dict[str, FloatArray] = {}
    first: Runs | None = None
    for lo, part in stream_bit(params, todo, lambda r: r, chunk=chunk,
                               runs_per_batch=runs_per_batch, workers=workers,
                               progress=progress):
        for name, values in part.channels.items():
            if name not in channels:
                channels[name] = np.empty((todo.n, values.shape[1]))
            channels[name][lo:lo + part.n] = values
        if first is None:
            first = part
    assert first is not None   # BitRuns.of refuses zero runs
    return Runs(channels, first.command_deg, todo.dynamic_pressure_pa.copy(), first.corners,
                first.sample_rate_hz, tuple(fs.label() for fs in todo.fault_sets))


def from_npz(path: str | Path) -> Runs:
    """The runs of a ``mapr simulate`` file flown on the BIT profile."""
    data = dataset.load(path)
    meta = json.loads(str(data["meta_json"]))
    rate = float(meta["sample_rate_hz"])
    conds = [str(c) for c in data["condition"]]
    if not all(c.startswith("bit") for c in conds):
        raise ConfigError("the reasoner's fault curves need BIT-profile runs "
                          f"(got {sorted(set(conds))})", path=str(path), field="profile")
    prof = bit_profile(rate, "ground")
    channels = {k[3:]: np.asarray(v, dtype=np.float64) for k, v in data.items()
                if k.startswith("ch_")}
    n = channels["position_deg"].shape[1]
    if n != prof.n_samples:
        raise ConfigError(f"{n} samples, the BIT profile has {prof.n_samples}",
                          path=str(path), field="time_s")
    q = np.asarray(data["in_dynamic_pressure_pa"], dtype=np.float64).mean(axis=1)
    return Runs(channels, np.asarray(data["in_command_deg"][0], dtype=np.float64), q,
                corner_samples(prof.corners_s, rate), rate,
                tuple(str(x) for x in data["run_label"]))
