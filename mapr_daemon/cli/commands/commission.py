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
import zipfile
from pathlib import Path
from typing import TYPE_CHECKING, Any

from mapr_daemon.cli import exitcodes
from mapr_daemon.ema.params import ActuatorParams, load_actuator
from mapr_daemon.errors import ConfigError

if TYPE_CHECKING:
    from mapr_daemon.reasoner.identify import Identification
    from mapr_daemon.reasoner.identify_bits import BitRecord

ACTUATOR_FILE = "actuator.yaml"
RECORD_FILE = "commissioning.json"
DICTIONARY_FILE = "dictionary.npz"


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


def _read_bits(paths: list[Path]) -> tuple[list[BitRecord], list[tuple[str, str]]]:
    """Every run of every file as a BIT record; a file of no BITs is skipped with its reason.
    An unreadable file is an unreadable input: OSError (exit 2)."""
    from mapr_daemon.reasoner.corpus import from_npz
    from mapr_daemon.reasoner.identify_bits import from_runs

    records: list[BitRecord] = []
    skipped: list[tuple[str, str]] = []
    for path in paths:
        try:
            runs = from_npz(path)
        except ConfigError as error:
            skipped.append((str(path), error.detail))
            continue
        except (KeyError, ValueError, zipfile.BadZipFile) as error:
            raise OSError(f"{path}: not a mapr simulate run file ({error})") from None
        records += from_runs(runs, str(path))
    return records, skipped


def _notes(ident: Identification) -> dict[str, str]:
    out = {}
    for e in ident.estimates:
        if e.identifiable:
            out[e.path] = (f"identified: data sheet {e.datasheet:.6g}, "
                           f"sd {100 * e.sd_rel:.2g} %")
        else:
            out[e.path] = (f"data sheet (not identifiable: sd {100 * e.sd_rel:.2g} % of "
                           f"{100 * e.prior_sd_rel:.2g} % prior)")
    return out


def _dictionary(params: ActuatorParams, spec_path: Path | None, out: Path,
                bits: list[BitRecord]) -> tuple[str, dict[str, Any]]:
    """Build the dictionary on the identified actuator, calibrate it to the unit's own BITs
    (``bits``, the records the identification used: :func:`~mapr_daemon.reasoner.adapt.
    calibrate_unit`) and save it; returns its file name and what the calibration did."""
    import numpy as np

    from mapr_daemon.cli.commands.dictionary import default_spec_path
    from mapr_daemon.reasoner.adapt import MIN_BITS, calibrate_unit
    from mapr_daemon.reasoner.build import build
    from mapr_daemon.reasoner.dictionary import DictionarySpec
    from mapr_daemon.reasoner.events import Reasoner

    spec = DictionarySpec.load(spec_path or default_spec_path())
    d = build(params, spec)
    if len(bits) < MIN_BITS:
        reason = (f"{len(bits)} BITs: calibrating the dictionary to the unit needs at least "
                  f"{MIN_BITS}; the dictionary is the identified model's alone")
        _say(reason)
        d.save(out / DICTIONARY_FILE)
        return DICTIONARY_FILE, {"skipped": reason}
    reasoner = Reasoner(d, params)
    m = np.stack([reasoner.matrix(b.channels, b.command_deg) for b in bits])
    q = np.array([b.dynamic_pressure_pa for b in bits])
    d, report = calibrate_unit(d, m, q)
    d.save(out / DICTIONARY_FILE)
    _say(f"dictionary calibrated to the unit on {report.bits} BITs: its cells sit "
         f"{report.offset_rms:.1f} healthy spreads (rms) from the model's, "
         f"{report.widened_cells} cells scatter more than twice the model's; thresholds "
         + ", ".join(f"{k} {a:.3g} -> {b:.3g}" for k, (a, b) in report.thresholds.items()))
    return DICTIONARY_FILE, report.as_dict()


def run(args: argparse.Namespace) -> int:
    from mapr_daemon.ema.dump import write_actuator
    from mapr_daemon.reasoner.commissioning import CommissioningRecord, write_record
    from mapr_daemon.reasoner.identify import identify
    from mapr_daemon.reasoner.identify_prior import default_tolerances_path, load_tolerances

    params = load_actuator(args.actuator)
    tolerances = load_tolerances(args.tolerances or default_tolerances_path(), params)
    for path in args.bits:
        if not path.is_file():
            raise OSError(f"{path}: no such file")
    records, skipped_files = _read_bits(list(args.bits))
    for name, reason in skipped_files:
        _say(f"skipped {name}: {reason}")
    if not records:
        _say("no BIT to commission from")
        return exitcodes.USAGE
    tty = sys.stderr.isatty()
    try:
        ident = identify(params, records, tolerances, progress=_say if tty else None)
    except ConfigError as error:
        if error.field == "bits":
            _say(error.detail)
            return exitcodes.USAGE
        raise
    for name, reason in ident.skipped:
        _say(f"skipped {name}: {reason}")
    out: Path = args.output
    out.mkdir(parents=True, exist_ok=True)
    used = {(b.source, b.index) for b in ident.bits}
    header = (f"{params.name}, identified by mapr commission from {len(ident.bits)} healthy "
              f"BITs\n(data sheet {args.actuator}; record {RECORD_FILE})")
    write_actuator(out / ACTUATOR_FILE, ident.params, header, _notes(ident))
    dictionary = None
    calibration = None
    if not args.no_dictionary:
        dictionary, calibration = _dictionary(ident.params, args.spec, out,
                                              [r for r in records if (r.source, r.index) in used])
    record = CommissioningRecord.of(ident, tolerances, str(args.actuator), ACTUATOR_FILE,
                                    dictionary, calibration)
    write_record(out / RECORD_FILE, record)
    print(f"{'parameter':<30} {'data sheet':>11} {'identified':>11} {'sd %':>6}  identifiable")
    for e in ident.estimates:
        print(f"{e.path:<30} {e.datasheet:>11.5g} {e.value:>11.5g} {100 * e.sd_rel:>6.2f}  "
              f"{'yes' if e.identifiable else 'no'}")
    print(f"{len(ident.bits)} BITs used, {len(ident.skipped) + len(skipped_files)} skipped; "
          f"{ident.model_runs} model runs in {ident.wall_s:.1f} s; wrote {out / ACTUATOR_FILE}, "
          f"{out / RECORD_FILE}" + (f", {out / dictionary}" if dictionary else ""))
    return exitcodes.OK
