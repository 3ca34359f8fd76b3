"""Batched BIT-profile runs for dictionaries, calibration and benches.

The plant's compiled step advances every run of a batch in one call (a 416-run dictionary
simulates in about 10 s, see docs/ema-model.md), and :meth:`EmaBatch.advance` takes a dynamic
pressure per run, so one batch mixes flight conditions: the BIT command is the same for every run,
only the air load differs. :class:`Runs` is what the reasoner reads — channels, command,
dynamic pressure, corners — whether it came from here or from a ``mapr simulate`` file
(:func:`from_npz`).
"""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from mapr_daemon.ema import dataset
from mapr_daemon.ema.batch import RunSpec
from mapr_daemon.ema.faults import FaultSet
from mapr_daemon.ema.params import ActuatorParams
from mapr_daemon.ema.plant import EmaBatch
from mapr_daemon.errors import ConfigError
from mapr_daemon.reasoner.features import FloatArray, corner_samples
from mapr_daemon.testbed.profiles import bit_profile


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


def simulate_bit(params: ActuatorParams, fault_sets: Sequence[FaultSet],
                 dynamic_pressure_pa: Sequence[float], seeds: Sequence[int],
                 chunk: int = 250, progress: Callable[[float], None] | None = None,
                 ambient_c: Sequence[float | None] | None = None,
                 bus_v: Sequence[float | None] | None = None,
                 specs: Sequence[RunSpec] | None = None) -> Runs:
    """Fly the BIT profile once per (faults, q, seed), all in one batch.

    ``ambient_c`` and ``bus_v`` give each run's flight condition (ambient temperature, the
    aircraft bus's mean); ``None`` (for all runs or one) leaves it to the plant's own draw.

    ``specs`` flies the caller's own runs instead, one per pressure, each with its own
    parameters, model form, faults, seed and condition (a mismatched unit's, say); the
    per-run ``fault_sets``, ``seeds``, ``ambient_c`` and ``bus_v`` must then be empty, and the
    specs must share ``params``'s sample rate.
    """
    if specs is not None:
        if fault_sets or seeds or ambient_c or bus_v:
            raise ConfigError("give the runs either as specs or as faults, seeds and "
                              "conditions, not both", field="runs")
        fault_sets = [s.faults for s in specs]
        seeds = [s.seed for s in specs]
        ambient_c = [s.ambient_c for s in specs]
        bus_v = [s.bus_v for s in specs]
    n = len(fault_sets)
    amb = [None] * n if ambient_c is None else list(ambient_c)
    bus = [None] * n if bus_v is None else list(bus_v)
    if not (n == len(dynamic_pressure_pa) == len(seeds) == len(amb) == len(bus)) or not n:
        raise ConfigError("faults, pressures, seeds and conditions must be equally long",
                          field="runs")
    rate = params.sensors.sample_rate_hz
    prof = bit_profile(rate, "ground")
    if specs is None:
        specs = [RunSpec(params, fs, seed=int(s), ambient_c=a, bus_v=b)
                 for fs, s, a, b in zip(fault_sets, seeds, amb, bus, strict=True)]
    elif any(s.params.sensors.sample_rate_hz != rate for s in specs):
        raise ConfigError("the specs' sample rate differs from params'", field="specs")
    plant = EmaBatch(specs)
    q = np.asarray(dynamic_pressure_pa, dtype=np.float64)
    parts: list[dict[str, FloatArray]] = []
    for start in range(0, prof.n_samples, chunk):
        stop = min(prof.n_samples, start + chunk)
        # command (1, n) and pressure (runs, 1): explicit, a 1-D chunk as long as the batch
        # would be read as per-run
        parts.append(plant.advance(stop - start, prof.command_deg[None, start:stop],
                                   q[:, None]).channels)
        if progress is not None:
            progress(stop / prof.n_samples)
    channels = {k: np.concatenate([p[k] for p in parts], axis=1) for k in parts[0]}
    return Runs(channels, prof.command_deg.copy(), q, corner_samples(prof.corners_s, rate),
                rate, tuple(fs.label() for fs in fault_sets))


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
