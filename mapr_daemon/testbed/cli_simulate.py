"""``mapr simulate``: fault-seeded EMA runs written as one ``.npz`` (see docs/simulate.md).

Single run (or a few faults at once, a compound fault)::

    mapr simulate --fault esr=0.5 --fault friction=3 --profile bit --condition cruise -o run.npz

Any point of the envelope, not only the named conditions: ``--pressure`` (dynamic pressure,
Pa; 0 is a BIT on the ground), ``--ambient`` (C) and ``--bus-voltage`` (the aircraft bus's
mean over the flight, V) replace the condition's air load and the plant's own draws::

    mapr simulate --pressure 0 --ambient -35 --bus-voltage 22.5 -o cold-ground-bit.npz

A mismatched unit — drawn off the actuator file by part-to-part tolerances plus a model form
the file does not describe (stiction, control law and rates, housekeeping load, Hall offset,
sensor gain/offset; ``mapr_daemon.testbed.mismatch``) — its truth in the file's metadata::

    mapr simulate --actuator configs/actuators/elevator-uav.yaml --unit 17 --pressure 0 -o u17.npz

A whole dictionary from a spec file, with a progress bar on stderr::

    mapr simulate --batch configs/profiles/dictionary-416.yaml -o dictionary.npz
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from mapr_daemon.ema.batch import RunSpec
from mapr_daemon.ema.bit import bit_profile
from mapr_daemon.ema.faults import FaultSet, at_severity, parse_fault
from mapr_daemon.ema.params import (
    ActuatorParams,
    BitParams,
    default_actuator_path,
    load_actuator,
    with_sample_rate,
)
from mapr_daemon.ema.profile import Profile
from mapr_daemon.errors import ConfigError


def add_subparser(subparsers: Any) -> None:
    p = subparsers.add_parser("simulate", help="simulate fault-seeded EMA runs into an .npz",
                              description=__doc__,
                              formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("-o", "--output", required=True, type=Path, help="output .npz file")
    p.add_argument("--batch", type=Path, help="YAML spec of many runs (overrides the rest)")
    p.add_argument("--actuator", type=Path, help="actuator YAML (default: aileron-uav)")
    p.add_argument("--fault", action="append", default=[],
                   help="kind=value, kind@severity or short|open=SWITCH; repeat for compound")
    p.add_argument("--profile", choices=("bit", "jsbsim"), default="bit")
    p.add_argument("--condition", default="cruise", help="ground, approach, climb, cruise, dash")
    p.add_argument("--pressure", type=_finite(0.0, 1e5), metavar="PA",
                   help="dynamic pressure, Pa (replaces the condition's; 0 = on the ground)")
    p.add_argument("--ambient", type=_finite(-60.0, 125.0), metavar="C",
                   help="ambient temperature, C (default: drawn around the actuator file's)")
    p.add_argument("--bus-voltage", type=_finite(0.0, 60.0), metavar="V",
                   help="aircraft bus mean, V (default: drawn around its nominal; the plant "
                        "clips it to the file's bus.min_v..max_v)")
    p.add_argument("--duration", type=float, default=30.0, help="JSBSim flight length (s)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--unit", type=_seed, metavar="SEED",
                   help="fly a mismatched unit drawn off the actuator file by this seed")
    p.add_argument("--sample-rate", type=float, help="sensor output rate, Hz (default: file)")
    p.add_argument("--cold", action="store_true", help="start with the SMPS off (soft start)")
    p.set_defaults(func=run)


def _finite(lo: float, hi: float) -> Any:
    """An argparse type: a finite number in ``[lo, hi]`` (a bad value exits 2, naming it)."""
    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
        if not math.isfinite(value) or not lo <= value <= hi:
            raise argparse.ArgumentTypeError(f"{text} is outside {lo:g}..{hi:g}")
        return value
    return parse


def _seed(text: str) -> int:
    """An argparse type: a seed, a whole number >= 0 (a bad value exits 2, naming it)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a whole number: {text!r}") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"{text} is negative")
    return value


def _at_pressure(prof: Profile, pressure_pa: float | None) -> Profile:
    """The profile with its dynamic pressure replaced (the command stays as it is)."""
    if pressure_pa is None:
        return prof
    q = np.full_like(prof.dynamic_pressure_pa, pressure_pa)
    return dataclasses.replace(prof, dynamic_pressure_pa=q,
                               name=f"{prof.name.split('@')[0]}@{pressure_pa:g}Pa")


def _profile(kind: str, cond: str, rate: float, duration: float, seed: int,
             bit: BitParams) -> Profile:
    """The flight: the actuator's BIT motion at a condition, or a JSBSim flight."""
    if kind == "bit":
        return bit_profile(rate, cond, bit)
    if kind == "jsbsim":  # imported when used: JSBSim is slow to load
        from mapr_daemon.testbed.profiles_jsbsim import jsbsim_flight
        return jsbsim_flight(rate, cond, duration, seed=seed)
    raise ConfigError(f"unknown profile {kind!r} (bit, jsbsim)", field="profile")


def _params(path: Path | None, rate: float | None) -> ActuatorParams:
    params = load_actuator(path or default_actuator_path())
    return with_sample_rate(params, rate) if rate else params


class _Progress:
    """A one-line text progress bar on stderr, only when stderr is a terminal or forced."""

    def __init__(self, total_runs: int, enabled: bool) -> None:
        self.total, self.done, self.enabled = total_runs, 0, enabled
        self.start = time.monotonic()

    def group(self, n_runs: int) -> Any:
        def update(fraction: float) -> None:
            if not self.enabled:
                return
            runs = self.done + fraction * n_runs
            bar = "#" * int(30 * runs / self.total)
            elapsed = time.monotonic() - self.start
            sys.stderr.write(f"\r[{bar:<30}] {runs:6.1f}/{self.total} runs {elapsed:6.1f} s")
            sys.stderr.flush()
        return update

    def finish_group(self, n_runs: int) -> None:
        self.done += n_runs

    def close(self) -> None:
        if self.enabled:
            sys.stderr.write("\n")


def _batch_groups(spec_path: Path) -> tuple[list[tuple[Profile, list[RunSpec]]], dict[str, Any]]:
    try:
        spec = yaml.safe_load(spec_path.read_text(encoding="utf-8"))
    except OSError as error:
        raise ConfigError(f"cannot read: {error.strerror}", path=str(spec_path)) from None
    except yaml.YAMLError as error:
        raise ConfigError(f"not valid YAML: {error}", path=str(spec_path)) from None
    if not isinstance(spec, dict) or "runs" not in spec:
        raise ConfigError("a batch spec is a mapping with 'runs'", path=str(spec_path),
                          field="runs")
    actuator = spec.get("actuator")
    params = _params(Path(actuator) if actuator else None, spec.get("sample_rate_hz"))
    fault_sets: list[FaultSet] = []
    for entry in spec["runs"]:
        if entry == "healthy":
            fault_sets.append(FaultSet())
        elif isinstance(entry, dict) and "severities" in entry:
            fault_sets += [FaultSet.of([at_severity(params, entry["fault"], float(s))])
                           for s in entry["severities"]]
        elif isinstance(entry, dict) and "faults" in entry:
            fault_sets.append(FaultSet.of([parse_fault(str(f), params) for f in entry["faults"]]))
        else:
            raise ConfigError(f"bad run entry {entry!r}", path=str(spec_path), field="runs")
    seeds = [int(s) for s in spec.get("seeds", [0])]
    groups = []
    for k, cond in enumerate(spec.get("conditions", ["cruise"])):
        prof = _profile(spec.get("profile", "bit"), str(cond), params.sensors.sample_rate_hz,
                        float(spec.get("duration_s", 30.0)), seed=k, bit=params.bit)
        runs = [RunSpec(params, fs, seed=1000 * k + 17 * i + s)
                for s in seeds for i, fs in enumerate(fault_sets)]
        groups.append((prof, runs))
    return groups, {"actuator": params.name, "spec": str(spec_path)}


def run(args: argparse.Namespace) -> int:
    # the simulation kernels (numba) load here, not for `mapr simulate --help`
    from mapr_daemon.ema import dataset
    from mapr_daemon.ema.run import RunResult, run_batch

    if args.batch:
        groups, meta = _batch_groups(args.batch)
    else:
        params = _params(args.actuator, args.sample_rate)
        faults = FaultSet.of([parse_fault(f, params) for f in args.fault])
        prof = _at_pressure(_profile(args.profile, args.condition,
                                     params.sensors.sample_rate_hz, args.duration, args.seed,
                                     params.bit),
                            args.pressure)
        meta = {"actuator": params.name}
        if args.unit is None:
            spec = RunSpec(params, faults, seed=args.seed, ambient_c=args.ambient,
                           bus_v=args.bus_voltage)
        else:
            from mapr_daemon.testbed.mismatch import draw_unit  # imported when used
            unit = draw_unit(params, args.unit)
            spec = unit.spec(faults, seed=args.seed, ambient_c=args.ambient,
                             bus_v=args.bus_voltage)
            meta["unit"] = unit.describe()
        groups = [(prof, [spec])]
    total = sum(len(runs) for _, runs in groups)
    bar = _Progress(total, enabled=sys.stderr.isatty() or total > 1)
    results: list[RunResult] = []
    for prof, runs in groups:
        results.append(run_batch(runs, prof, powered=not args.cold,
                                 progress=bar.group(len(runs))))
        bar.finish_group(len(runs))
    bar.close()
    first = groups[0][1][0].params.sensors
    meta.update(sample_rate_hz=first.sample_rate_hz, step_s=first.step_s,
                cold_start=bool(args.cold))
    dataset.save(args.output, results, meta)
    print(f"wrote {args.output}: {total} runs x {results[0].time_s.size} samples")
    return 0
