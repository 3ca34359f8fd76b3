"""``mapr commission``: fit an actuator's data sheet to its own healthy BITs, build its dictionary.

::

    mapr simulate --profile bit ... -o bits.npz           # or the unit's recorded BITs
    mapr commission --actuator configs/actuators/aileron-uav.yaml bits.npz -o unit42/
    mapr commission flight1.c10 flight2.c10 --config mapr.yaml --asset EMA1 -o unit42/
    mapr diagnose run.npz --dictionary unit42/dictionary.npz --actuator unit42/actuator.yaml

The BITs come from ``.npz`` run files (``mapr simulate``) or Chapter 10 recordings of the
aircraft's bus, mixed as you like. From a recording, one actuator's BITs are cut out of its
traffic as the daemon's BIT watcher cuts them (the ICD and the actuator's wiring of
``--config``, as ``mapr replay`` reads them; ``--asset`` chooses the actuator when the config
watches several; ``--c10-channel`` the 1553 channels read). The data sheet is ``--actuator``,
by default that asset's actuator file.

Writes into the output folder: ``actuator.yaml`` (the identified actuator, loadable like any
actuator file), ``commissioning.json`` (what was identified, with sd, from which BITs:
docs/commissioning.md) and ``dictionary.npz`` (the fault dictionary built on the identified
actuator; ``--spec`` for a smaller one, ``--no-dictionary`` to skip it). A BIT, or a file
of no BITs, that cannot be used is skipped with a one-line reason; the others go on.

``--single-allowance`` also calibrates what a true single fault may leave on this unit and
keeps it in the record: the unit's events then call a BIT no single fault explains within it
a pair, else "anomaly, not explained" (docs/commissioning.md, "Two faults at once within the
unit's single-fault allowance": more pairs answered honestly, more true single faults said
"unexplained"; off by default). ``--friction-law`` chooses the unit's friction law (the data
sheet's smoothed Coulomb + viscous, or stiction) by BIC from its BITs and bounds the identified
parameters at 4 prior sd (docs/commissioning.md, "The friction law on the mismatch bench";
off by default).

Exit codes: 0 done; 2 a file cannot be read or is neither a run file nor Chapter 10, or a bad
``--asset``; 65 no BIT to commission from (each file named on one line, with why); 78 a
config, ICD or data sheet error.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from mapr_daemon.cli import exitcodes
from mapr_daemon.cli.validate import bounded_int
from mapr_daemon.ema.params import ActuatorParams, load_actuator
from mapr_daemon.errors import ConfigError

if TYPE_CHECKING:
    from mapr_daemon.icd import Icd
    from mapr_daemon.pipeline.settings import AssetConfig
    from mapr_daemon.reasoner.commissioning.bits import BitRecord
    from mapr_daemon.service.config import Config


def add_subparser(subparsers: Any) -> None:
    p = subparsers.add_parser("commission",
                              help="identify an actuator from its healthy BITs, build its "
                                   "dictionary", description=__doc__,
                              formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("bits", nargs="+", type=Path,
                   help=".npz files of healthy BIT runs (mapr simulate --profile bit) and/or "
                        "Chapter 10 recordings of the bus")
    p.add_argument("--actuator", type=Path,
                   help="the data sheet (actuator YAML; default: the --asset's actuator file)")
    p.add_argument("-o", "--output", required=True, type=Path, help="output folder")
    p.add_argument("--tolerances", type=Path,
                   help="what to identify and its tolerance (default: "
                        "configs/commissioning/tolerances.yaml)")
    p.add_argument("--spec", type=Path, help="dictionary spec YAML (default: shipped)")
    p.add_argument("--no-dictionary", action="store_true",
                   help="identify only; do not build the dictionary")
    p.add_argument("--friction-law", action="store_true",
                   help="also choose the friction law (smoothed or sticking) from the BITs and "
                        "bound the identified parameters (off by default: measured both ways "
                        "in docs/commissioning.md)")
    p.add_argument("--single-allowance", action="store_true",
                   help="also calibrate the unit's single-fault allowance (pairs and "
                        "'unexplained' within it; fewer single faults named: off by default)")
    rec = p.add_argument_group("recordings", "how the BITs are found in a Chapter 10 recording")
    rec.add_argument("--config", metavar="FILE",
                     help="daemon config naming the ICD and the actuators on the bus (assets, "
                          "their wiring and data sheets; default: defaults)")
    rec.add_argument("--icd", metavar="FILE", help="message table (default: the config's)")
    rec.add_argument("--asset", metavar="NAME",
                     help="the actuator to commission, by its name in the config (needed when "
                          "the config has several)")
    rec.add_argument("--c10-channel", type=bounded_int(1, 0xFFFF, "channel ID"),
                     action="append", dest="c10_channels", metavar="ID",
                     help="read only this 1553 channel ID (repeat for more)")
    rec.add_argument("--year", type=bounded_int(1970, 2199, "year"),
                     help="year of day-of-year time packets")
    p.set_defaults(func=run)


def _say(message: str) -> None:
    print(f"mapr commission: {message}", file=sys.stderr)


def is_recording(path: Path) -> bool:
    """Whether an input is a Chapter 10 recording (else it is read as a run file)."""
    from drivers.chapter10.walker import looks_like_chapter10
    return looks_like_chapter10(path)


def _asset(config: Config, name: str | None) -> AssetConfig | None:
    """The config's asset called ``name`` (the only one when None); None, said, when there
    is no such asset or the choice is ambiguous."""
    names = ", ".join(a.name for a in config.assets)
    if name is None:
        if len(config.assets) == 1:
            return config.assets[0]
        _say(f"the config watches {len(config.assets)} actuators ({names}): choose one "
             "with --asset")
        return None
    chosen = next((a for a in config.assets if a.name == name), None)
    if chosen is None:
        _say(f"--asset {name}: not an actuator of the config (it has {names})")
    return chosen


def read_inputs(paths: Sequence[Path], params: ActuatorParams, config: Config,
                asset: AssetConfig, args: argparse.Namespace
                ) -> tuple[list[BitRecord], list[tuple[str, str]]]:
    """The BIT records of every input in the order given, and the files of none with why:
    ``.npz`` run files as :func:`read_bit_files` reads them, Chapter 10 recordings cut by
    :func:`~mapr_daemon.pipeline.recorded_bits.bits_from_recording` (each BIT of one not on
    the bus whole is skipped, said)."""
    from mapr_daemon.icd import load_icd
    from mapr_daemon.pipeline import wiring
    from mapr_daemon.pipeline.recorded_bits import bits_from_recording
    from mapr_daemon.reasoner.commissioning.workflow import read_bit_files

    records: list[BitRecord] = []
    skipped: list[tuple[str, str]] = []
    icd: Icd | None = None
    for path in paths:
        if not is_recording(path):
            more, none = read_bit_files([path])
            records += more
            skipped += none
            continue
        if icd is None:
            icd = load_icd(args.icd or config.icd)
            missing = wiring.not_in_icd(asset.signals, icd)
            if missing:
                raise ConfigError(f"not in the ICD {icd.name}: {', '.join(missing)}",
                                  path=config.source,
                                  field=f"assets[{config.assets.index(asset)}].signals")
        found = bits_from_recording(path, params, icd, asset, channels=args.c10_channels,
                                    year=args.year)
        for name, reason in found.skipped:
            _say(f"skipped {name}: {reason}")
        if found.damaged:
            _say(f"{path}: {found.damaged} damaged packets skipped")
        if not found.bits:
            skipped.append((str(path), found.why_none(icd)))
            continue
        _say(f"{path}: {len(found.bits)} BITs of {asset.name} (RT {asset.rt}) in "
             f"{found.messages} messages")
        records += found.bits
    return records, skipped


def run(args: argparse.Namespace) -> int:
    """Read the inputs (:func:`read_inputs`), run the commissioning workflow
    (:func:`~mapr_daemon.reasoner.commissioning.workflow.commission`), print its table."""
    from mapr_daemon.cli.commands.dictionary import default_spec_path
    from mapr_daemon.reasoner.commissioning.prior import default_tolerances_path, load_tolerances
    from mapr_daemon.reasoner.commissioning.workflow import commission
    from mapr_daemon.reasoner.diagnosis.dictionary import DictionarySpec
    from mapr_daemon.service.config import load_config

    for path in args.bits:
        if not path.is_file():
            raise OSError(f"{path}: no such file")
    config = load_config(args.config)
    needs_asset = args.actuator is None or args.asset is not None or \
        any(is_recording(p) for p in args.bits)
    asset = _asset(config, args.asset) if needs_asset else config.assets[0]
    if asset is None:
        return exitcodes.USAGE
    datasheet = args.actuator or Path(asset.actuator)
    params = load_actuator(datasheet)
    tolerances = load_tolerances(args.tolerances or default_tolerances_path(), params)
    records, skipped_files = read_inputs(args.bits, params, config, asset, args)
    if not records:   # the input is not there: each file named, with why
        for name, reason in skipped_files:
            _say(f"{name}: no BIT to commission from: {reason}")
        return exitcodes.DATAERR
    for name, reason in skipped_files:
        _say(f"skipped {name}: {reason}")
    spec = None if args.no_dictionary else DictionarySpec.load(args.spec or default_spec_path())
    try:
        done = commission(params, str(datasheet), records, tolerances, args.output, spec,
                          _say, progress=_say if sys.stderr.isatty() else None,
                          single_allowance=args.single_allowance,
                          friction_law=args.friction_law)
    except ConfigError as error:
        if error.field == "bits":
            _say(error.detail)
            return exitcodes.DATAERR
        raise
    ident = done.identification
    print(f"{'parameter':<30} {'data sheet':>11} {'identified':>11} {'sd %':>6}  identifiable")
    for e in ident.estimates:
        print(f"{e.path:<30} {e.datasheet:>11.5g} {e.value:>11.5g} {100 * e.sd_rel:>6.2f}  "
              f"{'yes' if e.identifiable else 'no'}")
    fit = (f"converged in {ident.iterations} iterations" if ident.converged else
           f"NOT converged after {ident.iterations} iterations")
    print(f"{len(ident.bits)} BITs used, {len(ident.skipped) + len(skipped_files)} skipped; "
          f"fit {fit}; {ident.model_runs} model runs in {ident.wall_s:.1f} s; wrote "
          + ", ".join(str(f) for f in done.files))
    return exitcodes.OK
