"""``mapr commission``: fit an actuator's data sheet to its own healthy BITs, build its dictionary.

::

    mapr simulate --profile bit ... -o bits.npz           # or the unit's recorded BITs
    mapr commission --actuator configs/actuators/aileron-uav.yaml bits.npz -o unit42/
    mapr diagnose run.npz --dictionary unit42/dictionary.npz --actuator unit42/actuator.yaml

Writes into the output folder: ``actuator.yaml`` (the identified actuator, loadable like any
actuator file), ``commissioning.json`` (what was identified, with sd, from which BITs:
docs/commissioning.md) and ``dictionary.npz`` (the fault dictionary built on the identified
actuator; ``--spec`` for a smaller one, ``--no-dictionary`` to skip it). A BIT that cannot
be used is skipped with a one-line reason; the others go on.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from mapr_daemon.cli import exitcodes
from mapr_daemon.ema.params import load_actuator
from mapr_daemon.errors import ConfigError


def add_subparser(subparsers: Any) -> None:
    p = subparsers.add_parser("commission",
                              help="identify an actuator from its healthy BITs, build its "
                                   "dictionary", description=__doc__,
                              formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("bits", nargs="+", type=Path,
                   help=".npz files of healthy BIT runs (mapr simulate --profile bit)")
    p.add_argument("--actuator", required=True, type=Path, help="the data sheet (actuator YAML)")
    p.add_argument("-o", "--output", required=True, type=Path, help="output folder")
    p.add_argument("--tolerances", type=Path,
                   help="what to identify and its tolerance (default: "
                        "configs/commissioning/tolerances.yaml)")
    p.add_argument("--spec", type=Path, help="dictionary spec YAML (default: shipped)")
    p.add_argument("--no-dictionary", action="store_true",
                   help="identify only; do not build the dictionary")
    p.set_defaults(func=run)


def _say(message: str) -> None:
    print(f"mapr commission: {message}", file=sys.stderr)


def run(args: argparse.Namespace) -> int:
    """Read the BIT files, run the commissioning workflow
    (:func:`~mapr_daemon.reasoner.commissioning.workflow.commission`), print its table."""
    from mapr_daemon.cli.commands.dictionary import default_spec_path
    from mapr_daemon.reasoner.commissioning.prior import default_tolerances_path, load_tolerances
    from mapr_daemon.reasoner.commissioning.workflow import commission, read_bit_files
    from mapr_daemon.reasoner.diagnosis.dictionary import DictionarySpec

    params = load_actuator(args.actuator)
    tolerances = load_tolerances(args.tolerances or default_tolerances_path(), params)
    for path in args.bits:
        if not path.is_file():
            raise OSError(f"{path}: no such file")
    records, skipped_files = read_bit_files(list(args.bits))
    for name, reason in skipped_files:
        _say(f"skipped {name}: {reason}")
    if not records:
        _say("no BIT to commission from")
        return exitcodes.USAGE
    spec = None if args.no_dictionary else DictionarySpec.load(args.spec or default_spec_path())
    try:
        done = commission(params, str(args.actuator), records, tolerances, args.output, spec,
                          _say, progress=_say if sys.stderr.isatty() else None)
    except ConfigError as error:
        if error.field == "bits":
            _say(error.detail)
            return exitcodes.USAGE
        raise
    ident = done.identification
    print(f"{'parameter':<30} {'data sheet':>11} {'identified':>11} {'sd %':>6}  identifiable")
    for e in ident.estimates:
        print(f"{e.path:<30} {e.datasheet:>11.5g} {e.value:>11.5g} {100 * e.sd_rel:>6.2f}  "
              f"{'yes' if e.identifiable else 'no'}")
    print(f"{len(ident.bits)} BITs used, {len(ident.skipped) + len(skipped_files)} skipped; "
          f"{ident.model_runs} model runs in {ident.wall_s:.1f} s; wrote "
          + ", ".join(str(f) for f in done.files))
    return exitcodes.OK
