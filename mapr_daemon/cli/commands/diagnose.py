"""``mapr diagnose``: is there an anomaly in a BIT run, which fault, how severe.

::

    mapr simulate --fault esr@0.5 --condition cruise -o run.npz
    mapr diagnose run.npz --dictionary dictionary.npz

Prints one JSON object per run of the file (one line each, in file order): ``run`` (its
0-based index in the file), ``anomaly``, ``fault``, ``severity`` (in ``unit``, the faulted
parameter's value), ``confidence``, ``parameters``, ``soh``, ``component``, ``rul`` (null: one
run has no trend, see ``mapr prognose``), ``evidence``. ``--paper`` uses the paper's
chosen-curve classifier instead of ours.

``--commissioned DIR`` (a ``mapr commission`` folder with a learned discrepancy) adds a second
reading, ``baseline``: the run's fault mode and severity read against the unit's own
commissioned healthy behaviour, identified model plus discrepancy (docs/commissioning.md,
"Reading a fault against the unit's baseline"): ``mode`` (null: no fault explains the run
better than none), ``switch``, ``severity`` (fraction of the Table 1 range), ``value`` (the
faulted parameter's), ``explained``, ``cost`` and ``pair`` (the best pair of two faults in
different parts: ``modes``, ``severities``, ``cost``; named or not); with a folder
commissioned since the unit's detector exists, ``detection``: its two statistics against the
unit's thresholds (docs/commissioning.md, "The unit's own detector"). The dictionary's
decision is unchanged (the daemon's ``assets[].commissioned`` combines the two).

The runs of a file are independent: each is diagnosed by a fresh reasoner, so its event is
the one ``--index`` gives it alone. ``--same-unit`` says they are successive BITs of one
actuator instead: one reasoner, in file order, adapts its reference model across them
(docs/reasoner.md, model adaptation).

A run that cannot be diagnosed (NaN or infinite samples, a numerical failure on its data)
gets an event with ``anomaly`` null, ``confidence`` 0 and ``evidence.error`` = {type,
message}; the other runs are diagnosed. Exit status: 0 every run diagnosed; 65 every run
has its line but at least one is such an error event; 2 bad argument or unreadable file,
78 dictionary or configuration error (then nothing, or only the lines before it, is printed).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from mapr_daemon.cli import exitcodes
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
    p.add_argument("--same-unit", action="store_true",
                   help="the runs are successive BITs of one actuator: adapt the reference "
                        "model across them, in file order (default: each run on its own)")
    p.add_argument("--paper", action="store_true", help="the paper's curve classifier")
    p.add_argument("--commissioned", type=Path, metavar="DIR",
                   help="a mapr commission folder: add the reading against the unit's "
                        "commissioned baseline")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from mapr_daemon.reasoner.diagnosis.dictionary import Dictionary
    from mapr_daemon.reasoner.reasoner import Reasoner
    from mapr_daemon.reasoner.training.corpus import from_npz

    d = Dictionary.load(args.dictionary)
    runs = from_npz(args.run)
    if abs(runs.sample_rate_hz - d.sample_rate_hz) > 1e-9:
        raise ConfigError(f"run at {runs.sample_rate_hz:g} Hz, dictionary at "
                          f"{d.sample_rate_hz:g} Hz", path=str(args.run), field="sample_rate_hz")
    if args.index is not None and not 0 <= args.index < runs.n:
        print(f"mapr diagnose: no run {args.index} (the file has {runs.n})", file=sys.stderr)
        return exitcodes.USAGE
    params = load_actuator(args.actuator or default_actuator_path())
    unit = Reasoner(d, params) if args.same_unit else None
    baseline = reader = None
    if args.commissioned is not None:
        from mapr_daemon.reasoner.commissioning.baseline import Baseline
        baseline = Baseline.load(args.commissioned)
        # the daemon's second reading: a run it cannot read is said, not a traceback
        reader = Reasoner(d, params, baseline=baseline)
    flagged = 0
    for i in range(runs.n) if args.index is None else [args.index]:
        reasoner = unit if unit is not None else Reasoner(d, params)
        channels = {k: v[i] for k, v in runs.channels.items()}
        diagnosis = reasoner.diagnose_or_flag(channels, runs.command_deg,
                                              float(runs.dynamic_pressure_pa[i]),
                                              paper=args.paper)
        flagged += diagnosis.error is not None
        line = {"run": i, **diagnosis.to_json()}
        if baseline is not None and reader is not None:
            reading = reader.baseline_reading(channels, runs.command_deg,
                                              float(runs.dynamic_pressure_pa[i]))
            line["baseline"] = baseline.to_json(reading)
            if baseline.detector is not None and not isinstance(reading, str):
                line["baseline"]["detection"] = baseline.detector.evidence(reading)
        print(json.dumps(line), flush=True)
    return exitcodes.DATAERR if flagged else exitcodes.OK
