"""The commissioning workflow: identify a unit from its healthy BITs, write what was found,
build its dictionary and calibrate it to the unit — what ``mapr commission`` runs.

In one place so that a script, a notebook or a later in-service step can run the same steps
the CLI does: :func:`read_bit_files` turns ``.npz`` run files into BIT records (a file of no
BITs skipped with its reason; a Chapter 10 recording's BITs are cut by
:func:`mapr_daemon.pipeline.recorded_bits.bits_from_recording`, above this package: it needs
the ICD and the daemon's BIT cutter), :func:`commission` does the rest and writes, into one
folder, ``actuator.yaml`` (the identified actuator, loadable like any actuator file),
``commissioning.json`` (what was identified, with sd, from which BITs), ``discrepancy.npz``
(what the identified model still misses on the unit's healthy BITs,
:mod:`~mapr_daemon.reasoner.commissioning.discrepancy`) and ``dictionary.npz``. With a
discrepancy, the unit's own anomaly detector is calibrated on the same BITs read held out
(:mod:`~mapr_daemon.reasoner.commissioning.detector`, one baseline reading per BIT, about
0.7-0.8 s CPU each) and kept in the record, and so is the measured noise of each aging
kind's wear read against the baseline on the same BITs held out
(:mod:`~mapr_daemon.reasoner.commissioning.wear`, about 0.5 s CPU per BIT): what the trend
of a commissioned asset is fitted on. Both read each BIT against the discrepancy relearned
without it; those are made once (:func:`held_out_discrepancies`) and handed to both. With a
dictionary, what the unit's BITs can see of each fault mode is measured on the calibrated
dictionary (:mod:`~mapr_daemon.reasoner.commissioning.visibility`) and kept in the record
(``unit_calibration.visibility``).
"""

from __future__ import annotations

import dataclasses
import zipfile
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from mapr_daemon.ema.dump import write_actuator
from mapr_daemon.ema.params import ActuatorParams
from mapr_daemon.errors import ConfigError
from mapr_daemon.reasoner.commissioning import detector as det
from mapr_daemon.reasoner.commissioning import discrepancy as dsc
from mapr_daemon.reasoner.commissioning import visibility
from mapr_daemon.reasoner.commissioning import wear as baseline_wear
from mapr_daemon.reasoner.commissioning.bits import FIT_SIGNALS, BitRecord, from_runs
from mapr_daemon.reasoner.commissioning.calibrate import MIN_BITS, calibrate_unit, without_each
from mapr_daemon.reasoner.commissioning.friction_law import identify_with_law
from mapr_daemon.reasoner.commissioning.identify import FitOptions, Identification, identify
from mapr_daemon.reasoner.commissioning.prior import Tolerance
from mapr_daemon.reasoner.commissioning.record import CommissioningRecord, write_record
from mapr_daemon.reasoner.diagnosis.dictionary import DictionarySpec
from mapr_daemon.reasoner.training.corpus import from_npz
from mapr_daemon.reasoner.training.dictionary_build import build
from mapr_daemon.reasoner.training.prognosis_build import RESOLVE_SD

ACTUATOR_FILE = "actuator.yaml"
RECORD_FILE = "commissioning.json"
DICTIONARY_FILE = "dictionary.npz"
DISCREPANCY_FILE = "discrepancy.npz"

Say = Callable[[str], None]
"""Where the workflow's one-line reports go (the CLI prefixes them and prints to stderr)."""


@dataclasses.dataclass(frozen=True)
class Commissioned:
    """What one commissioning did and wrote."""

    identification: Identification
    record: CommissioningRecord
    folder: Path
    dictionary: str | None
    """The dictionary's file name in :attr:`folder`; None when none was built."""
    discrepancy: str | None = None
    """The learned discrepancy's file name in :attr:`folder`; None when none was learned."""

    @property
    def files(self) -> list[Path]:
        """Every file written, in the order written."""
        return [self.folder / ACTUATOR_FILE] + \
            ([self.folder / self.discrepancy] if self.discrepancy else []) + \
            [self.folder / RECORD_FILE] + \
            ([self.folder / self.dictionary] if self.dictionary else [])


def read_bit_files(paths: Sequence[Path]) -> tuple[list[BitRecord], list[tuple[str, str]]]:
    """Every run of every ``.npz`` file as a BIT record, and the files skipped with why (a
    file of no BITs). An unreadable file or one that is not a run file raises OSError."""
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


def identification_notes(ident: Identification) -> dict[str, str]:
    """Per identified parameter, the comment written beside it in ``actuator.yaml``."""
    out = {}
    for e in ident.estimates:
        if e.identifiable:
            out[e.path] = (f"identified: data sheet {e.datasheet:.6g}, "
                           f"sd {100 * e.sd_rel:.2g} %")
        else:
            out[e.path] = (f"data sheet (not identifiable: sd {100 * e.sd_rel:.2g} % of "
                           f"{100 * e.prior_sd_rel:.2g} % prior)")
    if ident.friction_law is not None:
        out["motor.breakaway_ratio"] = "friction law chosen from the BITs (stiction)"
        if ident.params.motor.breakaway_ratio > 0.0:
            # the friction terms were refitted under that law
            for path in ("motor.viscous_friction_nm_s", "motor.coulomb_friction_nm"):
                out[path] = out.get(path, "") + "; refitted under the chosen friction law"
    return out


def unit_dictionary(params: ActuatorParams, spec: DictionarySpec, out: Path,
                    bits: Sequence[BitRecord], say: Say) -> tuple[str, dict[str, Any]]:
    """Build the dictionary on the identified actuator, calibrate it to the unit's own BITs
    (``bits``, those the identification used; :func:`~.calibrate.calibrate_unit`) and save
    it; its file name and what the calibration did."""
    d = build(params, spec)
    if len(bits) < MIN_BITS:
        reason = (f"{len(bits)} BITs: calibrating the dictionary to the unit needs at least "
                  f"{MIN_BITS}; the dictionary is the identified model's alone")
        say(reason)
        d.save(out / DICTIONARY_FILE)
        return DICTIONARY_FILE, {"skipped": reason}
    m = np.stack([d.record_matrix(b.channels, b.command_deg) for b in bits])
    q = np.array([b.dynamic_pressure_pa for b in bits])
    built = d
    d, report = calibrate_unit(d, m, q)
    d.save(out / DICTIONARY_FILE)
    say(f"dictionary calibrated to the unit on {report.bits} BITs: its cells sit "
        f"{report.offset_rms:.1f} healthy spreads (rms) from the model's, "
        f"{report.widened_cells} cells scatter more than twice the model's; thresholds "
        + ", ".join(f"{k} {a:.3g} -> {b:.3g}" for k, (a, b) in report.thresholds.items()))
    summary = report.as_dict()
    try:
        seen = visibility.measure(d, params, bits, held_out=without_each(built, m, q))
    except ConfigError as error:
        say(f"what the unit's BITs can see was not measured: {error.detail}")
    else:
        summary["visibility"] = seen.to_json()
        say("what this unit's BITs can see (each mode's model departure added to its healthy "
            "BITs, decided by its calibrated dictionary):")
        for line in seen.lines():
            say(f"  {line}")
        note = seen.false_alarm_note()
        if note is not None:
            say(note)
    return DICTIONARY_FILE, summary


def commission(params: ActuatorParams, datasheet: str, records: Sequence[BitRecord],
               tolerances: tuple[Tolerance, ...], out: Path, spec: DictionarySpec | None,
               say: Say, progress: Say | None = None, single_allowance: bool = False,
               friction_law: bool = False) -> Commissioned:
    """Identify ``params`` (the data sheet read from ``datasheet``) from ``records``, write
    the identified actuator and the record into ``out`` and, with a ``spec``, the unit's
    calibrated dictionary; with ``single_allowance`` the detector also keeps the unit's
    single-fault allowance (:func:`~.detector.single_allowance`; off by default: on the
    mismatch bench it turned 11-17 % of true single faults into "unexplained"); with
    ``friction_law`` the fit also chooses the friction law and bounds the parameters
    (:func:`~.friction_law.identify_with_law`; off by default).
    ConfigError (``field="bits"``) when no BIT can be used."""
    fit = identify_with_law if friction_law else identify
    ident = fit(params, list(records), tolerances, progress=progress)
    if ident.friction_law is not None:
        m = ident.params.motor
        say("friction law chosen from the BITs: " + (
            f"stiction, breakaway {m.breakaway_ratio:g} x Coulomb, Stribeck speed "
            f"{m.stribeck_speed_rad_s:g} rad/s" if m.breakaway_ratio > 0.0 else
            "the data sheet's smoothed Coulomb + viscous"))
    for name, reason in ident.skipped:
        say(f"skipped {name}: {reason}")
    out.mkdir(parents=True, exist_ok=True)
    used = {(b.source, b.index) for b in ident.bits}
    header = (f"{params.name}, identified by mapr commission from {len(ident.bits)} healthy "
              f"BITs\n(data sheet {datasheet}; record {RECORD_FILE})")
    write_actuator(out / ACTUATOR_FILE, ident.params, header, identification_notes(ident))
    if not ident.converged:
        say(f"identification did NOT converge in {ident.iterations} iterations: the identified "
            "values are its last iterate (the record says converged: false); commission again "
            "from more BITs or check them")
    discrepancy, disc_summary = learn_discrepancy(ident, records, out, say)
    detector = wear = None
    if discrepancy is not None:
        bits = [r for r in records if (r.source, r.index) in used]
        disc = dsc.Discrepancy.load(out / discrepancy)
        held_out = held_out_discrepancies(ident, bits, disc)
        detector = unit_detector(ident, params, bits, disc, held_out, say, single_allowance)
        wear = unit_wear(ident, bits, disc, held_out, say)
    dictionary = calibration = None
    if spec is not None:
        dictionary, calibration = unit_dictionary(
            ident.params, spec, out, [r for r in records if (r.source, r.index) in used], say)
    record = CommissioningRecord.of(ident, tolerances, datasheet, ACTUATOR_FILE, dictionary,
                                    calibration, disc_summary, detector, wear)
    write_record(out / RECORD_FILE, record)
    return Commissioned(ident, record, out, dictionary, discrepancy)


def learn_discrepancy(ident: Identification, records: Sequence[BitRecord], out: Path,
                      say: Say) -> tuple[str | None, dict[str, Any] | None]:
    """Learn what the identified model still misses on the BITs the identification used
    (:func:`~.discrepancy.learn_unit`), save it into ``out``; its file name and summary, or
    (None, None) with fewer than :data:`~.discrepancy.MIN_BITS` BITs (said in one line)."""
    used = {(b.source, b.index) for b in ident.bits}
    bits = [r for r in records if (r.source, r.index) in used]
    if len(bits) < dsc.MIN_BITS:
        say(f"{len(bits)} BITs: learning the model's discrepancy needs at least "
            f"{dsc.MIN_BITS}; none learned")
        return None, None
    disc = dsc.learn_unit(ident.params, bits, FitOptions().decimate)
    disc.save(out / DISCREPANCY_FILE)
    summary = disc.summary()
    say("discrepancy learned on the unit's healthy BITs; held-out residual per signal, noise "
        "units, model -> corrected: " + ", ".join(
            f"{k} {f.held_out_none:.3g} -> {f.held_out:.3g}"
            for k, f in zip(FIT_SIGNALS, disc.fits, strict=True)))
    return DISCREPANCY_FILE, {"file": DISCREPANCY_FILE, **summary}


def held_out_discrepancies(ident: Identification, bits: Sequence[BitRecord],
                           disc: dsc.Discrepancy) -> list[dsc.Discrepancy] | None:
    """``disc`` relearned without each of ``bits`` (those the identification used,
    :func:`~.discrepancy.held_out_discrepancies`), made once for the detector and the wear
    reading, which both read every commissioning BIT against the baseline that has not seen
    it; None when there are too few BITs to hold one out (each step then says so)."""
    if len(bits) < max(det.MIN_HELD_OUT, baseline_wear.MIN_HELD_OUT):
        return None
    try:
        return dsc.held_out_discrepancies(disc, ident.params, bits)
    except ConfigError:
        return None


def unit_detector(ident: Identification, datasheet: ActuatorParams,
                  bits: Sequence[BitRecord], disc: dsc.Discrepancy,
                  held_out: Sequence[dsc.Discrepancy] | None, say: Say,
                  allowance: bool = False) -> dict[str, Any] | None:
    """The unit's anomaly detector (:func:`~.detector.calibrate`) on ``bits`` (those the
    identification used), each read against ``disc`` relearned without it (``held_out``,
    None: made here); what the record keeps, or None (said in one line) when there are too
    few BITs."""
    try:
        d = det.calibrate(ident.params, datasheet, disc, bits, allowance=allowance,
                          held_out=held_out)
    except ConfigError as error:
        say(f"no anomaly detector on the baseline: {error.detail}")
        return None
    say(f"anomaly detector calibrated on {len(bits)} held-out BITs (false-alarm target "
        f"{d.alpha:g}); thresholds, healthy spreads squared: " + ", ".join(
            f"{k} {t.threshold:.3g} (largest held out {t.largest:.3g})"
            for k, t in d.tails.items()))
    return d.to_json()


def unit_wear(ident: Identification, bits: Sequence[BitRecord], disc: dsc.Discrepancy,
              held_out: Sequence[dsc.Discrepancy] | None, say: Say) -> dict[str, Any] | None:
    """Each aging kind's wear reading against the baseline, its offset and sd measured on
    ``bits`` (those the identification used), each read against ``disc`` relearned without it
    (``held_out``, None: made here; :func:`~.wear.measure`); what the record keeps, or None
    (said in one line) when there are too few BITs."""
    try:
        w = baseline_wear.measure(ident.params, disc, bits, held_out=held_out)
    except ConfigError as error:
        say(f"no wear reading on the baseline: {error.detail}")
        return None
    say(f"wear read against the baseline on {len(bits)} held-out BITs, offset / sd at h = 0 "
        "(+ sd growth per unit h), fractions of the failure threshold: " + ", ".join(
            f"{k} {v.offset:+.3f} / {v.sd0:.3f} (+{v.sd1:.3f})" for k, v in w.kinds.items())
        + "; read against the baseline: " + (", ".join(w.read_kinds) or "none")
        + f" (sd at the threshold <= {RESOLVE_SD:g}; the others keep the "
        "prognostic model's estimators)")
    return w.to_json()
