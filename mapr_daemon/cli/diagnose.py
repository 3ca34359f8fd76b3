"""``mapr diagnose``: is there an anomaly in a BIT run, which fault, how severe.

::

    mapr simulate --fault esr@0.5 --condition cruise -o run.npz
    mapr diagnose run.npz --dictionary dictionary.npz

Prints one JSON object per run of the file (one line each): ``anomaly``, ``fault``,
``severity`` (in ``unit``, the faulted parameter's value), ``confidence``, ``parameters``,
``soh``, ``rul`` (null: one run has no trend, see ``mapr prognose``), ``evidence``.
``--paper`` uses the paper's chosen-curve classifier instead of ours.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

from mapr_daemon.ema.params import default_actuator_path, load_actuator
from mapr_daemon.errors import ConfigError


def add_subparser(subparsers: Any) -> None:
    p = subparsers.add_parser("diagnose", help="anomaly, fault, severity of BIT runs (JSON)",
                              description=__doc__,
                              formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("run", type=Path, help=".npz from mapr simulate (BIT profile)")
    p.add_argument("--dictionary", required=True, type=Path,
                   help="fault dictionary from mapr dictionary build")
    p.add_argument("--actuator", type=Path, help="actuator YAML (default: aileron-uav)")
    p.add_argument("--index", type=int, help="only this run of the file (0-based)")
    p.add_argument("--paper", action="store_true", help="the paper's curve classifier")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from mapr_daemon.reasoner.corpus import from_npz
    from mapr_daemon.reasoner.dictionary import Dictionary
    from mapr_daemon.reasoner.events import Reasoner

    d = Dictionary.load(args.dictionary)
    runs = from_npz(args.run)
    if abs(runs.sample_rate_hz - d.sample_rate_hz) > 1e-9:
        raise ConfigError(f"run at {runs.sample_rate_hz:g} Hz, dictionary at "
                          f"{d.sample_rate_hz:g} Hz", path=str(args.run), field="sample_rate_hz")
    reasoner = Reasoner(d, load_actuator(args.actuator or default_actuator_path()))
    indices = range(runs.n) if args.index is None else [args.index]
    for i in indices:
        if not 0 <= i < runs.n:
            raise ConfigError(f"no run {i} (the file has {runs.n})", field="index")
        channels = {k: v[i] for k, v in runs.channels.items()}
        event = reasoner.diagnose(channels, runs.command_deg,
                                  float(runs.dynamic_pressure_pa[i]), paper=args.paper)
        print(json.dumps(event))
    return 0
