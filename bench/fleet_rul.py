"""RUL in the product, measured: a run-to-failure fleet flown, recorded, replayed, read back.

    python3 bench/fleet_rul.py [--units-per-kind 2] [--healthy-units 2] [--bit-every 4]
                               [--seed N] [--jobs 2]
                               [--kinds esr,capacitance,friction,smps_ron_high]
                               [--dictionary D.npz --prognosis P.npz] [--out DIR]
                               [--no-memory] [--keep-recordings] [--mean-life 200]
                               [--expected-life N] [--readback [--reassess]]
                               [--mismatch [--commission-bits 20] [--baseline]]
                               [--whole-flights [--flight-scale 0.5] [--templates 2]
                                [--healthy-flights 60] [--built-only]]

Each unit is an actuator aging along :func:`mapr_daemon.ema.degradation.trajectory` (mean life
200 flights, +/-30 %, as :mod:`mapr_daemon.reasoner.training.rul_scoring` and the fleet prior of the
prognostic model; ``--mean-life`` flies units the prior does not describe), one tail per
unit. Every
``--bit-every``-th flight from flight 0 to its end of life is flown by the testbed
(:func:`mapr_daemon.testbed.fleet.fly_flight`: 2 s of bus traffic, a BIT at its start, the
unit's true parameter at that flight seeded, a flight condition drawn per flight from the five
named ones) and recorded as Chapter 10; recordings are flown by ``--jobs`` processes. Each
recording is replayed, in flight order per unit, through ``mapr replay REC --diagnose --config C
--flight N --flight-hours 1.5 --tail UNIT --catalog DB`` (the command's own entry point, run
in this process) into one catalog for the run. Trajectory index ``f`` is declared flight
``f + 1`` (flight numbers start at 1), so the true RUL at flight ``N`` is ``eol - (N - 1)``.

Read back from the catalog (``bits`` table), per unit, at each BIT from a quarter of its life
on (true RUL > 0): the RUL of the unit's TRUE kind's mode (``health.modes[kind]``: median and
the 90 % interval, in flights; ``rul`` null there means beyond the horizon; no ``rul`` key
means no trend yet (BITs on fewer than three flights): no prediction, counted as a miss;
every trended kind states one from then on, evidenced or not) and, separately, the
headline (leading-mode) RUL, stated only for an evidenced kind. Scored:

* alpha-lambda (alpha 0.2, lambda 0.5 and 0.75, t0 = flight 0): at the BIT nearest
  ``lambda * eol`` the stored point estimate (the median) lies within +-20 % of the true RUL.
  The catalog keeps the median and the 5/95 % points, not the trend's draws, so the
  in-memory bench's beta = 0.5 criterion (half the draws inside the band) cannot be applied;
  the point criterion is what is scored here;
* coverage: the share of points whose stored 90 % interval holds the true RUL (target 85-95 %);
* the share of points where the leading mode is the true kind;
* units that do not age (``--healthy-units``, 40 BITs each at the default BIT spacing): BITs
  whose health names a wearing mode (false wear), and how many carry a RUL.

Per kind and overall, with the worst unit beside the average. Then the same units' paths
(same trajectory seeds) through the in-memory path (:func:`mapr_daemon.reasoner.training.rul_scoring
.observe_units` and ``score``: its own BIT simulations, estimators and calibration, not the
product's prognostic model nor the bus), scored with both criteria.

``--expected-life N`` states the parts' expected life in the configuration
(``assets[].expected_life_flights``, every kind): the fleet prior is then centred there with
the aging model's part-to-part spread; without it the prior's own life (200 flights) is held
loosely (``trend.LIFE_SD``), as for a user with no reliability figure. ``--readback
--reassess`` scores a kept catalog under another such configuration: each BIT's health is
computed afresh (``health.assess``, as the daemon does) from the estimates the run stored.

``--mismatch``: the same trajectories on units that are NOT the data sheet's twin. Each unit
is also drawn as a built unit (:func:`mapr_daemon.testbed.mismatch.fleet` off the shipped data
sheet: part-to-part tolerances and a model form the sheet does not carry), and flown with its
own parameters and form (``fly_flight(..., params=, form=)``). Its part ages by the twin's
ratio to its OWN healthy value (ESR doubles from the unit's ESR; friction's factor multiplies
the unit's friction), so the end of life and the true RUL are the twin's. Before its first
flight each built unit is commissioned: ``--commission-bits`` healthy BITs flown on it at
conditions drawn over the envelope (a named flight condition, ambient uniform over the
actuator's envelope, bus mean uniform over ``bus.min_v..max_v``), cut from their recordings as
``mapr commission`` cuts them, and the shipped dictionary calibrated to the unit on them
(:func:`mapr_daemon.reasoner.commissioning.calibrate.calibrate_unit`); the unit's dictionary
and calibration report are saved under ``OUT/mismatch/TAIL/`` and the tail's replay config
names its dictionary (``assets[].dictionary``). Then its BIT flights (the twin's flight seeds
and conditions) are flown and replayed into a catalog of their own and scored as above, and
the twin's and the built units' summaries are printed beside each other. The built units and
their commissioning flights draw from a stream of their own, so the twin's figures are those
of a run without ``--mismatch`` on the same seed. Per kind, what the BITs were diagnosed as is
printed too: an "unexplained" BIT (an anomaly no known fault mode fits) states no severity for
the true kind, but its wear estimate is stored and trended like any other BIT's, so the RUL
read back does not depend on the decision.

``--mismatch --baseline``: each built unit is ALSO commissioned as ``mapr commission
--no-dictionary`` does, on the same cut BITs (identification, learned discrepancy, the unit's
anomaly detector and the measured noise of each aging kind's wear read against the baseline:
:func:`mapr_daemon.reasoner.commissioning.workflow.commission`, ``--jobs`` units at a time,
into ``OUT/mismatch/TAIL/baseline/``), and every built-unit recording is replayed a second
time with the tail's config plus ``assets[].commissioned`` (same calibrated dictionary) into
``OUT/mismatch/fleet-baseline.db``: the BITs are read against the baseline (the event's
decision, and each trended kind's wear with the unit's measured sd,
:mod:`mapr_daemon.reasoner.commissioning.wear`). Scored as above and printed beside the
twin and the old path, with the baseline-read wear of the true kind against the truth
(bias, gain, error sd against the stated sd). Cost: identification ~50-200 s CPU per unit,
the detector's and the wear's held-out readings ~1.2 s CPU per commissioning BIT, and each
replayed BIT ~1.5-2 s CPU more than the old path (the reading with pairs on every BIT, the
detector's, plus ~0.4 s for the wear).

``--whole-flights``: EVERY flight of every unit is flown whole, not a 2 s excerpt: the testbed
aircraft on the bus along the whole-flight profile (:mod:`mapr_daemon.testbed.whole_recording`:
taxi out with the control check, JSBSim climb, cruise turns, cruise hold, approach, taxi in;
``--flight-scale`` times the 255 s profile's phase lengths), the flight control computer
asking for a BIT at power-up (a PBIT) on every ``--bit-every``-th flight (``--bit-every 1``:
every flight). ``--templates`` profiles are flown over the bus once each (seeds from the run's
own stream) and drawn per flight; each flight is the unit's EMA answering in one of them
(its fault, seed and, with ``--mismatch``, its own parameters and form). Each recording is
replayed twice, in flight order per unit: with the in-flight tracker on (the default
``reasoner.inflight``: the tracker runs over the traffic between BITs, friction's per-flight
change from the unit's first three flights is stored in the ``inflight`` table and fused
into the trend) into ``fleet.db``, and BITs only (``reasoner.inflight: false``) into
``fleet-bits-only.db``; both are scored as above and printed beside each other, with the
per-flight in-flight friction change read back against the unit's true path (its error sd
over its stated sd and the stated 90 % band's coverage, by third of life; the stated sd
is the learned one, ``reasoner/inflight/scatter.py``). Units that do not age fly
``--healthy-flights`` flights (default 60). ``--built-only`` (with ``--mismatch``) flies
and scores only the built units, so that the twin's run of the same ``--seed`` can go in
another process beside it. Cost: ~4.5 % of the bus time per
flight to fly, each replay ~1-2 % (docs/testbed.md), the templates ~1x their length once.

Seeds are fresh each run (bench/seeds.py) and printed; every unit and flight seed derives from
the run's seed, clear of the dictionary's, the prognostic model's and the fleet prior's.
Without ``--dictionary``/``--prognosis`` both are built first (``mapr dictionary build
--prognosis``; about two minutes).
"""

from __future__ import annotations

import argparse
import contextlib
import copy
import io
import itertools
import json
import math
import os
import resource
import sqlite3
import sys
import tempfile
import time
from collections import Counter
from collections.abc import Mapping, Sequence
from concurrent.futures import Future, ProcessPoolExecutor
from datetime import timedelta
from pathlib import Path

import numpy as np
from rul_scoring import Point, UnitScore, kind_summary, score_points
from seeds import fresh

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from mapr_daemon.arrays import FloatArray
from mapr_daemon.catalog import history
from mapr_daemon.catalog.inflight import load_inflight
from mapr_daemon.catalog.model import BitRecord as StoredBit
from mapr_daemon.catalog.schema import version_of
from mapr_daemon.cli.main import main as mapr
from mapr_daemon.ema.degradation import FAILURE, Trajectory, trajectory
from mapr_daemon.ema.faults import Fault, FaultSet, nominal_value
from mapr_daemon.ema.params import default_actuator_path, load_actuator
from mapr_daemon.ema.profile import CONDITIONS
from mapr_daemon.findings import Health
from mapr_daemon.pipeline.trending import AssetHistory
from mapr_daemon.reasoner.commissioning.bits import BitRecord
from mapr_daemon.reasoner.inflight.baseline import Baseline
from mapr_daemon.reasoner.prognosis import trend
from mapr_daemon.reasoner.prognosis.assessment import assess
from mapr_daemon.reasoner.prognosis.prognostic_model import PrognosticModel
from mapr_daemon.reasoner.prognosis.soh import degradation
from mapr_daemon.reasoner.training.rul_scoring import bit_flights, observe_units, score
from mapr_daemon.testbed.fleet import FIRST_DAY, fly_flight
from mapr_daemon.testbed.flight_template import FlightTemplate
from mapr_daemon.testbed.mismatch import Unit as BuiltUnit
from mapr_daemon.testbed.mismatch import fleet
from mapr_daemon.testbed.whole_recording import flight_seconds, record_flight, whole_template

KINDS = ("capacitance", "esr", "friction", "smps_ron_high")
MEAN_LIFE = 200.0
FLIGHT_HOURS = 1.5
FLIGHT_S = 2.0
LAMBDAS = (0.5, 0.75)
ALPHA = 0.2
HEALTHY = "healthy"
HEALTHY_FLIGHTS = 160
"""Flights of a healthy unit (a BIT every ``--bit-every``: 40 BITs at 4)."""
SEED_BASE = 1_000_000_000
"""Unit and flight seeds are drawn above this: clear of the dictionary's seeds (from 0), the
prognostic model's (7,000,000 and 8,000,000 up) and the fleet prior's units (10,000 up)."""


def build_models(out: Path) -> tuple[Path, Path]:
    """The dictionary and prognostic model, built as ``mapr dictionary build`` builds them."""
    d, p = out / "dictionary.npz", out / "prognosis.npz"
    started = time.monotonic()
    rc = mapr(["dictionary", "build", "-o", str(d), "--prognosis", str(p)])
    if rc != 0:
        raise SystemExit(f"dictionary build failed (exit {rc})")
    print(f"dictionary and prognostic model built in {time.monotonic() - started:.0f} s")
    return d, p


class Unit:
    """One run-to-failure unit: its tail, kind, path and BIT flights (trajectory indices);
    or, with ``kind`` :data:`HEALTHY`, a unit that does not age (its BITs every
    ``bit_every`` flights up to :data:`HEALTHY_FLIGHTS`)."""

    def __init__(self, tail: str, kind: str, seed: int, bit_every: int,
                 mean_life: float = MEAN_LIFE, healthy_flights: int = HEALTHY_FLIGHTS) -> None:
        self.tail, self.kind, self.seed = tail, kind, seed
        self.path: Trajectory = trajectory(load_actuator(default_actuator_path()),
                                           "esr" if kind == HEALTHY else kind,
                                           int(mean_life * 2), seed, mean_life)
        self.flights = list(range(0, healthy_flights, bit_every)) if kind == HEALTHY else \
            [int(f) for f in bit_flights(self.path, bit_every)]
        self.built: BuiltUnit | None = None
        """The built unit flown (``--mismatch``), None: the data sheet's twin."""
        self.scale = 1.0
        """The built unit's healthy value of the aging parameter over the data sheet's."""

    def built_as(self, built: BuiltUnit) -> Unit:
        """This unit's trajectory (same seed, same flights) flown on ``built``: its own
        parameters and model form. The part ages by the same ratio to ITS healthy value
        (ESR doubling from the unit's own ESR, not the data sheet's), so the end of life and
        the true RUL are the twin's; friction's factor multiplies the unit's own friction."""
        out = copy.copy(self)
        out.built = built
        sheet = load_actuator(default_actuator_path())
        out.scale = 1.0 if self.kind == HEALTHY else \
            nominal_value(built.params, self.kind) / nominal_value(sheet, self.kind)
        return out

    def faults(self, f: int) -> FaultSet:
        if f <= 0 or self.kind == HEALTHY:
            return FaultSet()
        return FaultSet.of([Fault(self.kind, self.path.fault(f).value * self.scale)])


def _fly(path: str, unit: Unit, f: int, seed: int, condition: str, index: int) -> str:
    b = unit.built
    fly_flight(path, unit.faults(f), seed=seed, condition=condition, flight_s=FLIGHT_S,
               start=FIRST_DAY + timedelta(days=f, minutes=index),
               params=None if b is None else b.params, form=None if b is None else b.form)
    return path


Plan = dict[str, list[tuple[int, str]]]
"""Per tail, each BIT flight's (seed, flight condition), in the order of ``Unit.flights``."""


def flight_plan(units: Sequence[Unit], rng: np.random.Generator) -> Plan:
    """Every BIT flight's seed and named condition, drawn once so that the twin and the
    built unit fly the same flights (same seeds, same conditions)."""
    names = sorted(CONDITIONS)
    return {u.tail: [(int(rng.integers(SEED_BASE, 2 * SEED_BASE)),
                      names[int(rng.integers(len(names)))]) for _ in u.flights] for u in units}


def replay(path: str, config: Path, catalog: Path, tail: str, flight: int) -> tuple[int, str]:
    """``mapr replay`` of one recording as its flight of ``tail``; (exit code, its output)."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        rc = mapr(["replay", path, "--diagnose", "--config", str(config), "--flight",
                   str(flight), "--flight-hours", str(FLIGHT_HOURS), "--tail", tail,
                   "--catalog", str(catalog), "--no-progress"])
    return rc, out.getvalue() + err.getvalue()


def fly_and_replay(units: Sequence[Unit], out: Path, configs: Mapping[str, Path],
                   catalog: Path, jobs: int, plan: Plan, keep: bool,
                   also: Sequence[tuple[Mapping[str, Path], Path]] = ()) -> int:
    """Fly every BIT flight (seeds and conditions from ``plan``) in ``jobs`` processes; replay
    each unit's in flight order as its recordings land, with its tail's config, and again
    with each of ``also``'s (configs, catalog) (``--baseline``: the same recordings read
    against the unit's commissioned baseline). Returns the replays that failed (each named
    on stdout)."""
    failed = 0
    done = 0
    total = sum(len(u.flights) for u in units)
    started = time.monotonic()
    with ProcessPoolExecutor(jobs) as pool:
        futures: list[list[Future[str]]] = []
        for i, u in enumerate(units):
            (out / u.tail).mkdir(parents=True, exist_ok=True)
            futures.append([pool.submit(
                _fly, str(out / u.tail / f"flight-{f + 1:04d}.ch10"), u, f, seed, condition,
                i) for f, (seed, condition) in zip(u.flights, plan[u.tail], strict=True)])
        for u, fs in zip(units, futures, strict=True):
            for f, fut in zip(u.flights, fs, strict=True):
                path = _flown(fut, u.tail, f)
                if path is None:
                    failed += 1
                    continue
                for cfgs, cat in [(configs, catalog), *also]:
                    rc, text = replay(path, cfgs[u.tail], cat, u.tail, f + 1)
                    if rc != 0:
                        print(f"  {u.tail} flight {f + 1}: mapr replay exit {rc} "
                              f"({cat.name}): {text.strip().splitlines()[-1:]}")
                        failed += 1
                if not keep:
                    Path(path).unlink(missing_ok=True)
                done += 1
            print(f"  {u.tail} ({u.kind}, EoL {u.path.eol_flight:.1f}): {len(u.flights)} BIT "
                  f"flights replayed ({done}/{total}, {time.monotonic() - started:.0f} s)",
                  flush=True)
    return failed


def _flown(fut: Future[str], tail: str, flight: int) -> str | None:
    """The recording a flying task wrote, or None (said in one line) when it failed: one bad
    flight never stops the fleet."""
    try:
        path = fut.result()
    except Exception as error:
        print(f"  {tail} flight {flight + 1}: flying failed: {error}")
        return None
    return path


def _fly_commissioning(path: str, built: BuiltUnit, seed: int, condition: str,
                       ambient_c: float, bus_v: float, index: int, days_before: int) -> str:
    """One healthy commissioning flight of a built unit, ``days_before`` its first flight."""
    fly_flight(path, FaultSet(), seed=seed, condition=condition, flight_s=FLIGHT_S,
               start=FIRST_DAY - timedelta(days=days_before, minutes=-index),
               params=built.params, form=built.form, ambient_c=ambient_c, bus_v=bus_v)
    return path


def commission(units: Sequence[Unit], out: Path, dictionary: Path, base_config: str,
               n_bits: int, jobs: int, rng: np.random.Generator, keep: bool,
               records_out: dict[str, list[BitRecord]] | None = None) -> dict[str, Path]:
    """Commission each built unit before its first flight, as an operator would: ``n_bits``
    healthy BITs flown on the unit at conditions drawn over the envelope (a named flight
    condition, ambient uniform over ``envelope.ambient_*_c``, bus mean uniform over
    ``bus.min_v..max_v``), recorded, cut from the recording as ``mapr commission`` cuts them
    (:func:`~mapr_daemon.pipeline.recorded_bits.bits_from_recording`), the shipped dictionary
    calibrated to the unit on them
    (:func:`~mapr_daemon.reasoner.commissioning.calibrate.calibrate_unit`) and saved; the
    tail's replay config names it (``assets[].dictionary``). Returns each tail's config;
    ``records_out`` (when given) receives each tail's cut BITs (``--baseline`` commissions
    the unit on the same ones)."""
    from mapr_daemon.icd import load_icd
    from mapr_daemon.pipeline.recorded_bits import bits_from_recording
    from mapr_daemon.reasoner.commissioning.calibrate import MIN_BITS, calibrate_unit
    from mapr_daemon.reasoner.diagnosis.dictionary import Dictionary
    from mapr_daemon.service.config import load_config

    shipped = Dictionary.load(dictionary)
    generic = out / "mapr.yaml"
    config = load_config(generic)
    asset = config.assets[0]
    params = load_actuator(asset.actuator)
    icd = load_icd(config.icd)
    env, bus = params.envelope, params.bus
    names = sorted(CONDITIONS)
    started = time.monotonic()
    configs: dict[str, Path] = {}
    with ProcessPoolExecutor(jobs) as pool:
        futures: list[list[Future[str]]] = []
        for i, u in enumerate(units):
            assert u.built is not None
            where = out / u.tail / "commissioning"
            where.mkdir(parents=True, exist_ok=True)
            futures.append([pool.submit(
                _fly_commissioning, str(where / f"bit-{k + 1:02d}.ch10"), u.built,
                int(rng.integers(SEED_BASE, 2 * SEED_BASE)), names[int(rng.integers(len(names)))],
                float(rng.uniform(env.ambient_min_c, env.ambient_max_c)),
                float(rng.uniform(bus.min_v, bus.max_v)), i, n_bits - k) for k in range(n_bits)])
        for u, fs in zip(units, futures, strict=True):
            b = u.built
            assert b is not None
            records = []
            for fut in fs:
                path = Path(fut.result())
                found = bits_from_recording(path, params, icd, asset)
                records += found.bits
                if not keep:
                    path.unlink(missing_ok=True)
            if records_out is not None:
                records_out[u.tail] = records
            if len(records) < MIN_BITS:   # said, and the tail replays uncommissioned
                print(f"  {u.tail}: {len(records)} BITs cut from {n_bits} flights: not "
                      "commissioned, replayed with the shipped dictionary")
                configs[u.tail] = generic
                continue
            m = np.stack([shipped.record_matrix(b.channels, b.command_deg) for b in records])
            q = np.array([b.dynamic_pressure_pa for b in records])
            unit_d, report = calibrate_unit(shipped, m, q)
            unit_path = out / u.tail / "dictionary.npz"
            unit_d.save(unit_path)
            tail_config = out / u.tail / "mapr.yaml"
            tail_config.write_text(base_config.replace(
                "    rt: 5\n", f"    rt: 5\n    dictionary: {unit_path.resolve()}\n"),
                encoding="utf-8")
            configs[u.tail] = tail_config
            (out / u.tail / "commissioning.json").write_text(
                json.dumps({"unit": b.describe(), "calibration": report.as_dict()},
                           indent=1, default=float) + "\n", encoding="utf-8")
            raised = ", ".join(f"{k} x{b / a:.2f}" for k, (a, b) in report.thresholds.items())
            print(f"  {u.tail} ({u.kind}, unit seed {b.seed}; {_form(u)}): "
                  f"calibrated on {report.bits} of {n_bits} healthy BITs, offsets "
                  f"{report.offset_rms:.1f} healthy sd rms, {report.widened_cells} cells "
                  f"widened > 2x, thresholds {raised} "
                  f"({time.monotonic() - started:.0f} s)", flush=True)
    return configs


def _form(u: Unit) -> str:
    """A built unit's model form in a few words, and its aging part's healthy value over the
    data sheet's."""
    assert u.built is not None
    f = u.built.form
    words = [f"stiction {f.breakaway_ratio:.1f}x" if f.breakaway_ratio else "no stiction",
             "voltage mode" if f.voltage_mode else "current mode",
             f"loops {f.current_loop_hz / 1e3:g}/{f.position_loop_hz / 1e3:g} kHz"
             if f.current_loop_hz else "continuous loops",
             f"housekeeping {f.housekeeping_w:.1f} W", f"Hall {f.hall_offset_deg:+.1f} deg",
             f"aging part x{u.scale:.2f} the sheet's"]
    return ", ".join(words)


def load_bits(conn: sqlite3.Connection, tail: str) -> list[StoredBit]:
    """The tail's stored BITs from a catalog of any schema version (a kept catalog is read
    as it is, never migrated)."""
    return history.load_bits(conn, tail=tail, version=version_of(conn))


def _value(row: dict[str, object], key: str) -> float:
    v = row.get(key)
    return math.inf if v is None else float(v)  # type: ignore[arg-type]


def catalog_points(conn: sqlite3.Connection, u: Unit) -> tuple[list[Point], list[Point]]:
    """(the true kind's mode, the headline) points of one unit, from its stored BITs."""
    eol = u.path.eol_flight
    mode_pts: list[Point] = []
    head_pts: list[Point] = []
    for b in load_bits(conn, tail=u.tail):
        if b.flight is None:
            continue
        f = b.flight - 1
        true = eol - f
        if f < 0.25 * eol or true <= 0:
            continue
        row = b.health.modes.get(u.kind) if b.health.modes else None
        if row is not None and "rul" in row:
            mode_pts.append(Point(f, true, _value(row, "rul"), _value(row, "low"),
                                  _value(row, "high"), b.health.mode))
        else:
            mode_pts.append(Point(f, true, None, None, None, b.health.mode))
        h = b.health
        # no headline RUL: none yet, or withheld (the trend leans on the assumed life); a
        # RUL beyond the horizon is a prediction of "not within it" (inf)
        has = h.mode is not None and (h.rul is not None or "does not reach the failure "
                                      "threshold" in (h.note or ""))
        head_pts.append(Point(f, true, *((math.inf if h.rul is None else h.rul,
                                          0.0 if h.rul_low is None else h.rul_low,
                                          math.inf if h.rul_high is None else h.rul_high)
                                         if has else (None, None, None)), h.mode))
    return mode_pts, head_pts


def reassessed_points(conn: sqlite3.Connection, u: Unit, model: PrognosticModel
                      ) -> tuple[list[Point], list[Point]]:
    """As :func:`catalog_points`, but each BIT's health computed afresh from the stored
    estimates and conditions (``health.assess``, the function the daemon calls, with the
    history up to that BIT) under ``model`` as configured now, instead of the stored health."""
    eol = u.path.eol_flight
    mode_pts: list[Point] = []
    head_pts: list[Point] = []
    for flight, h in reassessed(conn, u, model):
        f = flight - 1
        true = eol - f
        if f < 0.25 * eol or true <= 0:
            continue
        row = h.modes.get(u.kind)
        mode_pts.append(Point(f, true, _value(row, "rul"), _value(row, "low"),
                              _value(row, "high"), h.mode) if row is not None and "rul" in row
                        else Point(f, true, None, None, None, h.mode))
        has = h.mode is not None and h.rul is not None
        head_pts.append(Point(f, true, *((h.rul, h.rul_low, h.rul_high) if has
                                         else (None, None, None)), h.mode))
    return mode_pts, head_pts


def estimate_errors(conn: sqlite3.Connection, u: Unit, model: PrognosticModel
                    ) -> tuple[FloatArray, FloatArray]:
    """The unit's stored per-BIT estimates of its true kind, read by the model's
    :class:`~mapr_daemon.reasoner.prognosis.wear_noise.Noise` at each BIT's stored flight condition,
    minus the true degradation; and the sd the model states for them (same scale)."""
    noise = model.noise.get(u.kind)
    if noise is None:
        return np.zeros(0), np.zeros(0)
    params = load_actuator(default_actuator_path())
    err, sd = [], []
    for b in load_bits(conn, tail=u.tail):
        est = b.wear.get(u.kind)
        if b.flight is None or est is None:
            continue
        h = degradation(params, u.kind, float(u.path.values[b.flight - 1]))
        cond = model.scaled(b.conditions)   # read at the BIT's stored flight condition
        rows = None if cond is None else np.array([cond])
        err.append(float(noise.calibrate(np.array([est]), rows)[0]) - h)
        sd.append(float(noise.h_sd(np.array([max(h, 0.0)]), rows)[0]))
    return np.array(err), np.array(sd)


def print_errors(conn: sqlite3.Connection, units: Sequence[Unit], model: PrognosticModel,
                 kinds: Sequence[str]) -> None:
    """What limits the trend: the fleet's per-BIT estimate error against the stated noise."""
    print("\nper-BIT estimate of the true kind on the fleet's BITs (calibrated, in units of "
          "the threshold) against the model's stated noise:")
    for k in kinds:
        parts = [estimate_errors(conn, u, model) for u in units if u.kind == k]
        err = np.concatenate([e for e, _ in parts]) if parts else np.zeros(0)
        sd = np.concatenate([s for _, s in parts]) if parts else np.zeros(0)
        if err.size == 0:
            print(f"  {k:>14}: no estimates")
            continue
        z = err / np.maximum(sd, 1e-9)
        leads = Counter(b.health.mode or "none" for u in units if u.kind == k
                        for b in load_bits(conn, tail=u.tail)
                        if b.flight is not None and b.flight - 1 >= 0.25 * u.path.eol_flight)
        print(f"  {k:>14}: leading mode from a quarter of life on: "
              + ", ".join(f"{m} {n}" for m, n in leads.most_common()))
        print(f"  {k:>14}: {err.size} BITs, error mean {err.mean():+.3f} sd {err.std():.3f}; "
              f"stated sd mean {sd.mean():.3f}; |error| > 1.645 stated sd in "
              f"{100 * np.mean(np.abs(z) > 1.645):.0f} % (10 % if calibrated); "
              f"lag-one correlation of the standardised errors {lag_one(parts):+.2f} "
              f"(successive BITs of a unit, about zero: {trend.SERIAL_RHO:+.2f} in the trend)")
        means, sampling = unit_offsets(parts)
        if means.size:
            print(f"  {k:>14}: per-unit mean error " + ", ".join(f"{m:+.3f}" for m in means)
                  + f"; rms {math.sqrt(float(np.mean(means ** 2))):.3f}, of which sampling "
                  f"{math.sqrt(float(np.mean(sampling))):.3f} (chance of as much from "
                  f"sampling alone {offset_p(means, sampling):.2f}): a unit's persistent "
                  f"offset sd {offset_sd(means, sampling):.3f} about 0, mean "
                  f"{float(np.mean(means)):+.3f} (in the trend sd "
                  f"{trend.UNIT_OFFSET_SD.get(k, 0.0):.3f} about "
                  f"{trend.UNIT_OFFSET_MEAN.get(k, 0.0):+.3f})")
    zs = [e / np.maximum(s, 1e-9) for u in units if u.kind in kinds
          for e, s in [estimate_errors(conn, u, model)]]
    print(f"  {'all':>14}: lag-one correlation of the standardised errors "
          f"{lag_one([(z, np.ones_like(z)) for z in zs]):+.2f}")


def unit_offsets(parts: Sequence[tuple[FloatArray, FloatArray]]
                 ) -> tuple[FloatArray, FloatArray]:
    """Each unit's mean estimate error (its persistent offset plus sampling noise) and that
    mean's sampling variance: the errors' variance over the unit's BITs, inflated for their
    AR(1) correlation at :data:`~mapr_daemon.reasoner.prognosis.trend.SERIAL_RHO`
    (``(1 + rho)/(1 - rho)``); units with fewer than three BITs are left out."""
    rho = trend.SERIAL_RHO
    kept = [e for e, _ in parts if e.size >= 3]
    means = np.array([float(e.mean()) for e in kept])
    sampling = np.array([float(e.var(ddof=1)) / e.size * (1.0 + rho) / (1.0 - rho)
                         for e in kept])
    return means, sampling


def offset_sd(means: FloatArray, sampling: FloatArray) -> float:
    """The sd of a unit's persistent offset about 0 (the trend's prior is centred there):
    the mean square of the units' mean errors less their sampling part, 0 if none is left."""
    return math.sqrt(max(float(np.mean(means ** 2) - np.mean(sampling)), 0.0)) \
        if means.size else math.nan


def offset_p(means: FloatArray, sampling: FloatArray) -> float:
    """The chance that sampling alone gives units' mean errors as far from 0 as these
    (chi-square of ``mean**2/sampling`` over the units): small, a persistent offset."""
    from scipy.stats import chi2
    return float(chi2.sf(float(np.sum(means ** 2 / np.maximum(sampling, 1e-12))), means.size)) \
        if means.size else math.nan


def lag_one(parts: Sequence[tuple[FloatArray, FloatArray]]) -> float:
    """Pooled lag-one correlation of successive BITs' standardised errors ``err/sd`` over
    units, about zero (not each unit's mean: a bias a unit keeps is correlation too)."""
    zs = [e / np.maximum(s, 1e-9) for e, s in parts if e.size >= 2]
    if not zs:
        return math.nan
    num = sum(float(z[1:] @ z[:-1]) for z in zs)
    den = sum(0.5 * float(z[1:] @ z[1:] + z[:-1] @ z[:-1]) for z in zs)
    return num / den if den > 0.0 else math.nan


def reassessed(conn: sqlite3.Connection, u: Unit, model: PrognosticModel
               ) -> list[tuple[int, Health]]:
    """Each stored BIT's flight and health of one unit, the health computed afresh from the
    stored estimates and conditions (``health.assess``, the function the daemon calls, with
    the history up to that BIT) under ``model`` as configured now; the unit's stored
    in-flight rows of the flights before each BIT are fused as the daemon fuses them
    (:class:`~mapr_daemon.pipeline.trending.AssetHistory`: a PBIT is flown at power-up, so
    its own flight's row comes after it)."""
    hist = AssetHistory()
    try:
        stored = load_inflight(conn, tail=u.tail)
    except sqlite3.OperationalError:   # a catalog kept from before the in-flight table
        stored = []
    rows = sorted((r for r in stored if r.flight is not None), key=lambda r: int(r.flight or 0))
    out: list[tuple[int, Health]] = []
    for b in load_bits(conn, tail=u.tail):
        if b.flight is None or not b.wear:
            continue
        while rows and int(rows[0].flight or 0) < b.flight:
            hist.add_inflight(rows.pop(0))
        hist.add(float(b.flight), dict(b.wear), dict(b.conditions), b.wear_source)
        out.append((b.flight, assess(model, hist.flights, hist.wear, diagnosed=b.fault,
                                     seed=len(hist.flights), conditions=hist.conditions,
                                     inflight=hist.observations(), sources=hist.sources)))
    return out


def print_healthy(conn: sqlite3.Connection, units: Sequence[Unit],
                  model: PrognosticModel | None = None) -> None:
    """False wear: BITs of units that do not age whose health names a wearing mode (the
    stored health, or with ``model`` each BIT's health re-assessed under it)."""
    healthy = [u for u in units if u.kind == HEALTHY]
    if not healthy:
        return
    bits = {u.tail: [b.health for b in load_bits(conn, tail=u.tail)] if model is None
            else [h for _, h in reassessed(conn, u, model)] for u in healthy}
    total = sum(len(b) for b in bits.values())
    worn = Counter(h.mode for hs in bits.values() for h in hs if h.mode)
    ever = sum(any(h.mode for h in hs) for hs in bits.values())
    ruls = sum(h.rul is not None for hs in bits.values() for h in hs)
    worst = max((sum(h.mode is not None for h in hs) for hs in bits.values()), default=0)
    print(f"\nunits that do not age ({len(healthy)}{', re-assessed' if model else ''}): a "
          f"wearing mode at {sum(worn.values())} of {total} BITs (worst unit {worst}), {ruls} "
          f"with a RUL, {ever} units ever; modes {dict(worn) or 'none'}")


def print_table(title: str, scores: Sequence[UnitScore], kinds: Sequence[str]) -> None:
    print(f"\n== {title} ==")
    print(f"{'unit':>10} {'kind':>14} {'EoL':>6} {'pts':>4} {'none':>4} {'al@0.5':>7} "
          f"{'al@0.75':>7} {'cover':>6} {'in20%':>6} {'lead':>5}  at lambda 0.75: true / "
          "est [low, high]")
    for s in scores:
        print(s.line())
    for k in [*kinds, "all"]:
        print(kind_summary(k, [s for s in scores if k == "all" or s.kind == k]))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--units-per-kind", type=int, default=2)
    ap.add_argument("--bit-every", type=int, default=4, help="flights between BITs")
    ap.add_argument("--kinds", default=",".join(KINDS))
    ap.add_argument("--healthy-units", type=int, default=2,
                    help="units that do not age, scored for false wear")
    ap.add_argument("--seed", type=int)
    ap.add_argument("--mean-life", type=float, default=MEAN_LIFE,
                    help="mean life of the units, in flights (the fleet prior the prognostic "
                         f"model is built with assumes {MEAN_LIFE:g}: another value measures "
                         "the RUL on units the prior does not describe)")
    ap.add_argument("--jobs", type=int, default=2, help="processes flying recordings")
    ap.add_argument("--dictionary", type=Path)
    ap.add_argument("--prognosis", type=Path)
    ap.add_argument("--out", type=Path, help="run directory (default: a temporary one)")
    ap.add_argument("--no-memory", action="store_true", help="skip the in-memory path")
    ap.add_argument("--keep-recordings", action="store_true")
    ap.add_argument("--readback", action="store_true",
                    help="score the catalog an earlier run (same --seed, --out and sizes) "
                         "left in --out, without flying again")
    ap.add_argument("--expected-life", type=float,
                    help="state the parts' expected life (flights) in the configuration "
                         "(assets[].expected_life_flights, every kind); default: none stated")
    ap.add_argument("--reassess", action="store_true",
                    help="with --readback: compute each BIT's health afresh from the stored "
                         "estimates under this run's configuration (e.g. another "
                         "--expected-life) instead of reading the stored health")
    ap.add_argument("--mismatch", action="store_true",
                    help="also fly every unit's trajectory on a built unit that is not the "
                         "data sheet's twin (testbed/mismatch.py), commissioned first, and "
                         "print its figures beside the twin's")
    ap.add_argument("--commission-bits", type=int, default=20,
                    help="with --mismatch: healthy BITs each built unit is commissioned on")
    ap.add_argument("--baseline", action="store_true",
                    help="with --mismatch: also commission each built unit as `mapr "
                         "commission --no-dictionary` does (identification, discrepancy, "
                         "detector, wear noise) on the same BITs, replay the same recordings "
                         "again with assets[].commissioned (wear read against the unit's "
                         "baseline) and print those figures beside the old path's")
    ap.add_argument("--built-only", action="store_true",
                    help="with --whole-flights --mismatch: fly and score the built units only "
                         "(the twin's run of the same seed apart, e.g. in another process)")
    ap.add_argument("--whole-flights", action="store_true",
                    help="fly EVERY flight whole (testbed whole flights, a PBIT at power-up "
                         "on every --bit-every-th), replay each with the in-flight tracker "
                         "on and again BITs only, and score both")
    ap.add_argument("--flight-scale", type=float, default=WHOLE_SCALE,
                    help="with --whole-flights: each phase's length over the 255 s flight's")
    ap.add_argument("--templates", type=int, default=2,
                    help="with --whole-flights: whole-flight profiles flown (rotated over the "
                         "flights)")
    ap.add_argument("--healthy-flights", type=int,
                    help=f"flights of a unit that does not age (default {HEALTHY_FLIGHTS}; "
                         f"{WHOLE_HEALTHY} with --whole-flights)")
    args = ap.parse_args()
    kinds = [k.strip() for k in args.kinds.split(",") if k.strip()]
    seed = fresh(args.seed)
    started = time.monotonic()
    rng = np.random.default_rng(seed)
    with contextlib.ExitStack() as stack:
        out = args.out or Path(stack.enter_context(tempfile.TemporaryDirectory()))
        out.mkdir(parents=True, exist_ok=True)
        if args.dictionary is None or args.prognosis is None:
            args.dictionary, args.prognosis = build_models(out)
        model = PrognosticModel.load(args.prognosis)
        print(f"prognostic model {args.prognosis}: trends {', '.join(model.kinds)}; "
              f"unobservable: {model.unobservable or 'none'}")
        for k in kinds:
            n = model.noise.get(k)
            if n is not None:
                nominal = model.scaled({"dynamic_pressure_pa": 1000.0, "ambient_c": 25.0,
                                        "supply_v": model.supply_nominal_v})
                at_nominal = float(n.h_sd(np.array([1.0]), None if nominal is None else
                                          np.array([nominal]))[0])
                print(f"  {k:>20}: estimate = {n.offset:.3f} + {n.gain:.3f} h, noise sd "
                      f"{n.sd0:.3f} + {n.sd1:.3f} h over the envelope (sd at h = 1: "
                      f"{float(n.sd(np.array(1.0))) / n.gain:.3f} of the threshold; "
                      f"{at_nominal:.3f} at nominal supply and 25 C, 1 kPa)")
        if args.whole_flights:
            return whole_main(args, seed, out, model, kinds, rng, started)
        units = [Unit(f"U{i + 1:02d}", k, int(rng.integers(SEED_BASE, 2 * SEED_BASE)),
                     args.bit_every, args.mean_life)
                 for i, k in enumerate([*(k for k in kinds for _ in range(args.units_per_kind)),
                                        *[HEALTHY] * args.healthy_units])]
        print(f"{len(units)} units ({args.units_per_kind} per kind of {', '.join(kinds)}, "
              f"{args.healthy_units} that do not age; mean life {args.mean_life:g} flights, "
              f"the fleet prior's {MEAN_LIFE:g}), "
              f"BIT every {args.bit_every} flights: {sum(len(u.flights) for u in units)} "
              f"recordings; unit seeds " + ", ".join(f"{u.tail}={u.seed}" for u in units))
        config = out / "mapr.yaml"
        lives = "" if args.expected_life is None else \
            "    expected_life_flights: {" + ", ".join(
                f"{k}: {args.expected_life:g}" for k in kinds) + "}\n"
        print(f"expected life stated in the configuration: "
              f"{'none' if args.expected_life is None else f'{args.expected_life:g} flights'}")
        base_config = (f"reasoner:\n  dictionary: {args.dictionary.resolve()}\nassets:\n"
                       f"  - name: EMA1\n    rt: 5\n    prognosis: "
                       f"{args.prognosis.resolve()}\n{lives}")
        config.write_text(base_config, encoding="utf-8")
        plan = flight_plan(units, rng)
        built = built_units(units, seed) if args.mismatch else []
        catalog = out / "fleet.db"
        if not args.readback:
            catalog.unlink(missing_ok=True)
            failed = fly_and_replay(units, out, {u.tail: config for u in units}, catalog,
                                    max(args.jobs, 1), plan, args.keep_recordings)
            print(f"flown and replayed in {time.monotonic() - started:.0f} s; failed: {failed}")
        twin = read_catalog(catalog, units, model, kinds, args)
        if built:
            where = out / "mismatch"
            where.mkdir(exist_ok=True)
            (where / "mapr.yaml").write_text(base_config, encoding="utf-8")
            mm_catalog = where / "fleet.db"
            bl_catalog = where / "fleet-baseline.db"
            if not args.readback:
                mm_catalog.unlink(missing_ok=True)
                t0 = time.monotonic()
                print(f"\ncommissioning {len(built)} built units on {args.commission_bits} "
                      "healthy BITs each (flown on the unit over the envelope, cut from the "
                      "recordings, the shipped dictionary calibrated to the unit):")
                cut: dict[str, list[BitRecord]] = {}
                configs = commission(built, where, args.dictionary, base_config,
                                     args.commission_bits, max(args.jobs, 1),
                                     np.random.default_rng([seed, MISMATCH_STREAM, 1]),
                                     args.keep_recordings, cut if args.baseline else None)
                also: list[tuple[Mapping[str, Path], Path]] = []
                if args.baseline:
                    t1 = time.monotonic()
                    print(f"\ncommissioning the same {len(built)} built units as `mapr "
                          "commission --no-dictionary` does (identification, discrepancy, "
                          "detector, wear noise) on the same BITs, "
                          f"{max(args.jobs, 1)} processes:")
                    also = [(commission_baselines(built, where, cut, configs,
                                                  max(args.jobs, 1)), bl_catalog)]
                    print(f"baselines commissioned in {time.monotonic() - t1:.0f} s wall")
                    bl_catalog.unlink(missing_ok=True)
                print(f"commissioned in {time.monotonic() - t0:.0f} s; flying the same "
                      "trajectories, flight seeds and conditions on the built units:")
                t0 = time.monotonic()
                failed = fly_and_replay(built, where, configs, mm_catalog, max(args.jobs, 1),
                                        plan, args.keep_recordings, also)
                print(f"flown and replayed in {time.monotonic() - t0:.0f} s; failed: {failed}")
            print("\n######## the same trajectories on units that are NOT the data sheet's "
                  "twin (--mismatch) ########")
            mismatched = read_catalog(mm_catalog, built, model, kinds, args)
            print_beside(twin, mismatched, kinds)
            if args.baseline:
                print("\n######## the same recordings of the built units, wear read against "
                      "each unit's commissioned baseline (--baseline) ########")
                against = read_catalog(bl_catalog, built, model, kinds, args, errors=False)
                print_baseline_errors(bl_catalog, built, where, kinds)
                print_three(twin, mismatched, against, kinds)
        if not args.no_memory:
            in_memory(args.dictionary, [u for u in units if u.kind != HEALTHY],
                      args.bit_every, kinds, args.mean_life)
    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    print(f"\ntotal runtime {time.monotonic() - started:.0f} s wall; CPU "
          f"{time.process_time():.0f} s in this process (replay, scoring) + "
          f"{children.ru_utime + children.ru_stime:.0f} s in the flying processes; load "
          f"average {' '.join(f'{x:.2f}' for x in os.getloadavg())} (1, 5, 15 min)")
    return 0


MISMATCH_STREAM = 26
"""The built units and their commissioning flights draw from ``default_rng([seed, 26, ...])``:
a stream of their own, so ``--mismatch`` leaves every twin draw (units, flight seeds and
conditions) as a run without it makes them."""


def built_units(units: Sequence[Unit], seed: int) -> list[Unit]:
    """The run's units as built units (``--mismatch``): each drawn by
    :func:`mapr_daemon.testbed.mismatch.fleet` off the shipped data sheet (part-to-part
    tolerances and a model form the sheet does not carry), flying its twin's trajectory."""
    sheet = load_actuator(default_actuator_path())
    fleet_seed = int(np.random.default_rng([seed, MISMATCH_STREAM, 0]).integers(2**31))
    drawn = fleet(sheet, len(units), fleet_seed)
    print(f"--mismatch: built units drawn by mismatch.fleet(data sheet, {len(units)}, "
          f"{fleet_seed}); unit seeds " + ", ".join(
              f"{u.tail}={b.seed}" for u, b in zip(units, drawn, strict=True)))
    return [u.built_as(b) for u, b in zip(units, drawn, strict=True)]


Scores = tuple[list[UnitScore], list[UnitScore]]


def read_catalog(catalog: Path, units: Sequence[Unit], model: PrognosticModel,
                 kinds: Sequence[str], args: argparse.Namespace, errors: bool = True) -> Scores:
    """Score one run's catalog and print its figures: estimate errors (unless ``errors`` is
    False: a catalog whose wear the estimators did not read), false wear, what the BITs were
    diagnosed as, and the two tables; returns (true kind's, headline) scores."""
    conn = sqlite3.connect(catalog)
    mode_scores, head_scores = [], []
    configured = model.with_lives(
        {} if args.expected_life is None else {k: args.expected_life for k in kinds})
    if args.reassess:
        print("health re-assessed from the stored estimates under this configuration "
              "(not the stored health)")
    for u in (u for u in units if u.kind != HEALTHY):
        mode_pts, head_pts = reassessed_points(conn, u, configured) if args.reassess \
            else catalog_points(conn, u)
        mode_scores.append(score_points(u.tail, u.kind, u.path.eol_flight, mode_pts,
                                        LAMBDAS, ALPHA))
        head_scores.append(score_points(u.tail, u.kind, u.path.eol_flight, head_pts,
                                        LAMBDAS, ALPHA))
    if errors:
        print_errors(conn, units, model, kinds)
    print_prior_share(conn, units, configured if args.reassess else None)
    print_healthy(conn, units, configured if args.reassess else None)
    print_diagnoses(conn, units, kinds)
    conn.close()
    print_table("from the catalog: the TRUE kind's mode (health.modes[kind])", mode_scores,
                kinds)
    print_table("from the catalog: the headline (leading mode's RUL)", head_scores, kinds)
    return mode_scores, head_scores


SHARE_BINS = (0.0, 0.10, 0.25, 0.40, math.inf)
"""Edges of the ``prior_share`` bins :func:`print_prior_share` prints."""


def print_prior_share(conn: sqlite3.Connection, units: Sequence[Unit],
                      model: PrognosticModel | None) -> None:
    """The true kind's RUL against how much of the assumed life's spread its interval still
    spans (``prior_share``, :func:`~mapr_daemon.reasoner.prognosis.trend.prior_share`): per
    bin the points from a quarter of life on, the median stated/true RUL, the share within
    +-20 % of the truth and the 90 % interval's coverage; the headline withholds the RUL
    above :data:`~mapr_daemon.reasoner.prognosis.trend.LEANS` where no life is stated.
    ``model``: re-assessed under it (else the stored health; rows stored before the share
    existed are left out)."""
    pts: list[tuple[float, float, bool, bool]] = []
    for u in (u for u in units if u.kind != HEALTHY):
        eol = u.path.eol_flight
        healths = reassessed(conn, u, model) if model is not None else \
            [(b.flight, b.health) for b in load_bits(conn, tail=u.tail) if b.flight is not None]
        for flight, h in healths:
            f, row = flight - 1, (h.modes or {}).get(u.kind) or {}
            true = eol - f
            if f < 0.25 * eol or true <= 0 or "prior_share" not in row or "rul" not in row:
                continue
            share = math.inf if row["prior_share"] is None else float(row["prior_share"])
            rul, low, high = (_value(row, k) for k in ("rul", "low", "high"))
            low = 0.0 if math.isinf(low) else low
            pts.append((share, rul / true, abs(rul - true) <= 0.2 * true, low <= true <= high))
    if not pts:
        return
    a = np.array(pts, dtype=np.float64)
    print(f"\nthe true kind's RUL by how much of the assumed life's spread its interval still "
          f"spans (prior_share; the headline withholds it above {trend.LEANS:g} where no "
          "life is stated), points from a quarter of life on:")
    for lo, hi in itertools.pairwise(SHARE_BINS):
        m = (a[:, 0] >= lo) & ((a[:, 0] < hi) | np.isinf(hi))   # the last bin takes inf
        if m.any():
            print(f"  share {lo:.2f}-{hi:.2f}: {int(m.sum()):4d} points, median stated/true "
                  f"RUL {np.median(a[m, 1]):.2f}x, within +-20 % {100 * a[m, 2].mean():.0f} %, "
                  f"90 % interval coverage {100 * a[m, 3].mean():.0f} %")


def print_diagnoses(conn: sqlite3.Connection, units: Sequence[Unit],
                    kinds: Sequence[str]) -> None:
    """What each aging unit's BITs from a quarter of life on were diagnosed as: the true
    kind (alone or in a pair), a pair without it, another single fault, "unexplained" (an
    anomaly no known mode fits: no severity for the true kind, though its wear estimate is
    still stored and trended), or nothing."""
    print("\ndiagnoses of the aging units' BITs from a quarter of life on:")
    for k in kinds:
        tally = Counter[str]()
        for u in (u for u in units if u.kind == k):
            for b in load_bits(conn, tail=u.tail):
                if b.flight is None or b.flight - 1 < 0.25 * u.path.eol_flight:
                    continue
                if b.event_id is None:
                    tally["none"] += 1
                    continue
                fault, evidence = conn.execute("SELECT fault, evidence FROM events WHERE id=?",
                                               (b.event_id,)).fetchone()
                ev = json.loads(evidence)
                pair = ev.get("compound")
                named = [str(m["fault"]) for m in pair.get("faults", ())] \
                    if isinstance(pair, dict) else [fault]
                tally["unexplained" if "unexplained" in ev and not isinstance(pair, dict)
                      else ("true kind in a pair" if k in named else "another pair")
                      if isinstance(pair, dict) else
                      "true kind" if fault == k else f"other ({fault})"] += 1
        total = sum(tally.values())
        print(f"  {k:>14}: {total} BITs: " + (", ".join(
            f"{name} {n} ({100 * n / total:.0f} %)" for name, n in tally.most_common())
            if total else "none"))


def print_beside(twin: Scores, built: Scores, kinds: Sequence[str]) -> None:
    """The twin's and the built units' summaries, kind by kind, one above the other."""
    print("\n== beside: the data sheet's twin against built units (same trajectories, "
          "flight seeds and conditions) ==")
    for title, i in (("the TRUE kind's mode", 0), ("the headline", 1)):
        print(f"{title}:")
        for k in [*kinds, "all"]:
            for name, scores in (("twin", twin[i]), ("built", built[i])):
                line = kind_summary(k, [s for s in scores if k == "all" or s.kind == k])
                print(f"  {name:>5} {line.strip()}")


def in_memory(dictionary: Path, units: Sequence[Unit], bit_every: int,
              kinds: Sequence[str], mean_life: float = MEAN_LIFE) -> None:
    """The same units' paths through reasoner/training/rul_scoring.py (its own BITs and
    estimators)."""
    from mapr_daemon.reasoner.diagnosis.dictionary import Dictionary

    params = load_actuator(default_actuator_path())
    started = time.monotonic()
    observed = observe_units(Dictionary.load(dictionary), params,
                             [(u.kind, u.seed) for u in units], bit_every=bit_every,
                             mean_life=mean_life)
    scored = score(observed, params, use_prior=True, lambdas=LAMBDAS, alpha=ALPHA)
    scores = []
    for u, s in zip(units, scored, strict=True):
        pts = [Point(float(t), float(tr), float(e), float(lo), float(hi), None)
               for t, tr, e, lo, hi in zip(s.times, s.true_rul, s.est_rul, s.lower, s.upper,
                                           strict=True)]
        scores.append(score_points(u.tail, u.kind, s.eol, pts, LAMBDAS, ALPHA, leads=False))
    print_table(f"in memory (reasoner/training/rul_scoring.py, same trajectory seeds; "
                f"{time.monotonic() - started:.0f} s): point criterion", scores, kinds)
    beta = [v for s in scored for v in s.alpha_lambda.values()]
    print(f"in memory, alpha-lambda with its beta = 0.5 draw criterion: "
          f"{100 * sum(beta) / len(beta):.1f} % ({sum(beta)}/{len(beta)})")


# ---- built units commissioned with a baseline (--mismatch --baseline) ---------------------

def _commission_one(datasheet: str, records: list[BitRecord], folder: str
                    ) -> tuple[list[str], float]:
    """One built unit commissioned as ``mapr commission --no-dictionary`` does, in a flying
    process: its report lines and the CPU seconds it took."""
    from mapr_daemon.reasoner.commissioning.prior import default_tolerances_path, load_tolerances
    from mapr_daemon.reasoner.commissioning.workflow import commission as run_commission

    cpu = time.process_time()
    params = load_actuator(datasheet)
    lines: list[str] = []
    run_commission(params, datasheet, records,
                   load_tolerances(default_tolerances_path(), params), Path(folder), None,
                   lines.append)
    return lines, time.process_time() - cpu


def commission_baselines(units: Sequence[Unit], out: Path,
                         records: Mapping[str, list[BitRecord]], configs: Mapping[str, Path],
                         jobs: int) -> dict[str, Path]:
    """Each built unit commissioned on the BITs :func:`commission` cut for it
    (identification, learned discrepancy, anomaly detector, wear noise:
    :func:`mapr_daemon.reasoner.commissioning.workflow.commission` without a dictionary) in
    ``jobs`` processes, into ``OUT/TAIL/baseline/``; each tail's config is its
    :func:`commission` config plus ``assets[].commissioned`` naming that folder (same
    dictionary: the two paths differ by the baseline alone). A unit whose commissioning
    fails keeps its old config (said)."""
    datasheet = str(default_actuator_path())
    started = time.monotonic()
    out_configs: dict[str, Path] = {}
    with ProcessPoolExecutor(jobs) as pool:
        futures = {u.tail: pool.submit(_commission_one, datasheet, records.get(u.tail, []),
                                       str(out / u.tail / "baseline")) for u in units}
        for u in units:
            try:
                lines, cpu = futures[u.tail].result()
            except Exception as error:
                print(f"  {u.tail}: commissioning failed ({type(error).__name__}: {error}); "
                      "replayed without a baseline")
                out_configs[u.tail] = configs[u.tail]
                continue
            folder = (out / u.tail / "baseline").resolve()
            text = configs[u.tail].read_text(encoding="utf-8").replace(
                "    rt: 5\n", f"    rt: 5\n    commissioned: {folder}\n")
            path = out / u.tail / "mapr-baseline.yaml"
            path.write_text(text, encoding="utf-8")
            out_configs[u.tail] = path
            wear = [ln for ln in lines if ln.startswith("wear read")]
            print(f"  {u.tail} ({u.kind}): {len(records.get(u.tail, []))} BITs, {cpu:.0f} s "
                  f"CPU; {wear[0] if wear else 'no wear noise: ' + '; '.join(lines[-2:])} "
                  f"({time.monotonic() - started:.0f} s)", flush=True)
    return out_configs


def print_baseline_errors(catalog: Path, units: Sequence[Unit], out: Path,
                          kinds: Sequence[str]) -> None:
    """The stored baseline-read estimate of each unit's TRUE kind, less the unit's measured
    offset, against the true degradation: bias, gain (slope on the truth), error sd, the
    stated sd's rms and the share outside the stated 90 % band, per kind (worst unit beside);
    and on units that do not age, each kind's largest |z| (false wear)."""
    from mapr_daemon.reasoner.commissioning.baseline import Baseline

    params = load_actuator(default_actuator_path())
    conn = sqlite3.connect(catalog)
    print("\nper-BIT wear read against the unit's baseline, the TRUE kind (less the unit's "
          "measured offset; units of the failure threshold; stated sd = sd0 + sd1*h "
          "measured on its held-out commissioning BITs):")
    rows: dict[str, list[tuple[str, FloatArray, FloatArray, FloatArray]]] = {}
    for u in units:
        folder = out / u.tail / "baseline"
        try:
            wear = Baseline.load(folder).wear
        except Exception as error:   # a unit left uncommissioned: said
            print(f"  {u.tail}: no baseline ({type(error).__name__})")
            continue
        if wear is None:
            continue
        print(f"  {u.tail} ({u.kind}): read against the baseline: "
              f"{', '.join(wear.read_kinds) or 'none'}; sd at the threshold " + ", ".join(
                  f"{k} {v.sd0 + v.sd1:.2f}" for k, v in wear.kinds.items() if k in kinds))
        if u.kind == HEALTHY:
            zs: dict[str, list[float]] = {k: [] for k in wear.read_kinds}
            for b in load_bits(conn, tail=u.tail):
                for k in wear.read_kinds:
                    if k in b.wear:
                        kn = wear.kinds[k]
                        zs[k].append((b.wear[k] - kn.offset) / kn.sd0)
            print(f"  {u.tail} (does not age): largest |reading - offset| / sd0 per kind " +
                  ", ".join(f"{k} {max(np.abs(v)):.1f}" for k, v in zs.items() if v))
            continue
        if u.kind not in wear.read_kinds:   # its wear is the estimator's: printed above
            continue
        n = wear.kinds[u.kind]
        est, truth = [], []
        for b in load_bits(conn, tail=u.tail):
            if b.flight is None or u.kind not in b.wear:
                continue
            est.append(b.wear[u.kind] - n.offset)
            truth.append(degradation(params, u.kind, float(u.path.values[b.flight - 1])))
        h, e = np.array(truth), np.array(est)
        sd = n.sd0 + n.sd1 * np.clip(h, 0.0, 1.5)
        rows.setdefault(u.kind, []).append((u.tail, h, e, sd))
    conn.close()
    for k in kinds:
        for tail, h, e, sd in rows.get(k, []):
            err = e - h
            gain = float(np.polyfit(h, e, 1)[0]) if np.ptp(h) > 0 else math.nan
            out_share = float(np.mean(np.abs(err) > 1.645 * sd))
            stated = float(np.sqrt(np.mean(sd ** 2)))
            print(f"  {k:>14} {tail}: {h.size} BITs, bias {np.mean(err):+.3f}, gain "
                  f"{gain:.2f}, error sd {np.std(err):.3f} against stated {stated:.3f} "
                  f"(rms), outside the 90 % band {100 * out_share:.0f} %")


def print_three(twin: Scores, old: Scores, against: Scores, kinds: Sequence[str]) -> None:
    """The twin, the built units on the old path (dictionary calibrated, estimators) and on
    the baseline path, kind by kind, one above the other."""
    print("\n== beside: twin / built, old path (calibrated dictionary, estimators) / built, wear "
          "read against the commissioned baseline ==")
    for title, i in (("the TRUE kind's mode", 0), ("the headline", 1)):
        print(f"{title}:")
        for k in [*kinds, "all"]:
            for name, scores in (("twin", twin[i]), ("old", old[i]), ("base", against[i])):
                line = kind_summary(k, [s for s in scores if k == "all" or s.kind == k])
                print(f"  {name:>5} {line.strip()}")


# ---- whole flights with in-flight tracking (--whole-flights) -------------------------------

WHOLE_SCALE = 0.5
"""``--whole-flights``: each phase at half the 255 s profile's length (127.5 s of bus)."""
WHOLE_HEALTHY = 60
"""``--whole-flights``: flights of a unit that does not age (a PBIT on each at the default)."""
TEMPLATES: dict[bool, list[FlightTemplate]] = {}
"""The run's whole-flight templates (True: with a PBIT), set before the flying pool starts
so that its forked processes inherit them rather than receive one with every task."""
WholePlan = dict[str, list[tuple[int, int]]]
"""Per tail, each flight's (seed, template index), in the order of ``Unit.flights``."""


def whole_plan(units: Sequence[Unit], rng: np.random.Generator, n_templates: int) -> WholePlan:
    """Every flight's seed and whole-flight profile, drawn once so that the twin and the
    built unit fly the same flights."""
    return {u.tail: [(int(rng.integers(SEED_BASE, 2 * SEED_BASE)),
                      int(rng.integers(n_templates))) for _ in u.flights] for u in units}


def build_templates(n: int, scale: float, bit_every: int, rng: np.random.Generator,
                    jobs: int) -> dict[bool, list[FlightTemplate]]:
    """``n`` whole-flight profiles (seeds drawn from ``rng``) flown over the bus once each,
    with a PBIT and, when ``bit_every`` leaves flights without one, without."""
    seeds = [int(rng.integers(2**31)) for _ in range(n)]
    kinds = [True, False] if bit_every > 1 else [True]
    started = time.monotonic()
    with ProcessPoolExecutor(jobs) as pool:
        futures = {bit: [pool.submit(whole_template, s, scale, bit=bit) for s in seeds]
                   for bit in kinds}
        made = {bit: [f.result() for f in fs] for bit, fs in futures.items()}
    print(f"{n} whole-flight profiles (seeds {', '.join(map(str, seeds))}; scale {scale:g}: "
          f"{flight_seconds(made[True][0]):.1f} s of bus a flight) flown over the bus once "
          f"each{' with and without a PBIT' if len(kinds) > 1 else ' with a PBIT'} in "
          f"{time.monotonic() - started:.0f} s", flush=True)
    return made


def _fly_whole(path: str, unit: Unit, f: int, seed: int, template: int, bit: bool,
               index: int) -> str:
    b = unit.built
    record_flight(path, TEMPLATES[bit][template], unit.faults(f), seed=seed,
                  start=FIRST_DAY + timedelta(days=f, minutes=index), tail=unit.tail,
                  params=None if b is None else b.params, form=None if b is None else b.form)
    return path


def bits_only(config_text: str) -> str:
    """A replay configuration with the in-flight tracker off (``reasoner.inflight: false``)."""
    return config_text.replace("reasoner:\n", "reasoner:\n  inflight: false\n", 1)


def fly_and_replay_whole(units: Sequence[Unit], out: Path,
                         configs: Mapping[str, tuple[Path, Path]],
                         catalogs: tuple[Path, Path], jobs: int, plan: WholePlan,
                         bit_every: int, keep: bool) -> int:
    """Fly every flight of every unit whole (:data:`TEMPLATES`, a PBIT on every
    ``bit_every``-th) in ``jobs`` processes; replay each, in flight order per unit, into
    ``catalogs[0]`` with the tail's in-flight config and into ``catalogs[1]`` with its
    BITs-only config. Prints the replays' CPU per second of bus; returns the failures."""
    failed = done = 0
    total = sum(len(u.flights) for u in units)
    cpu = [0.0, 0.0]
    bus_s = 0.0
    started = time.monotonic()
    with ProcessPoolExecutor(jobs) as pool:
        futures: list[list[Future[str]]] = []
        for i, u in enumerate(units):
            (out / u.tail).mkdir(parents=True, exist_ok=True)
            futures.append([pool.submit(
                _fly_whole, str(out / u.tail / f"flight-{f + 1:04d}.ch10"), u, f, seed,
                template, f % bit_every == 0, i)
                for f, (seed, template) in zip(u.flights, plan[u.tail], strict=True)])
        for u, fs in zip(units, futures, strict=True):
            for f, fut in zip(u.flights, fs, strict=True):
                path = _flown(fut, u.tail, f)
                if path is None:
                    failed += 1
                    continue
                bus_s += flight_seconds(TEMPLATES[True][0])
                for k, (config, catalog) in enumerate(zip(configs[u.tail], catalogs,
                                                          strict=True)):
                    c0 = time.process_time()
                    rc, text = replay(path, config, catalog, u.tail, f + 1)
                    cpu[k] += time.process_time() - c0
                    if rc != 0:
                        print(f"  {u.tail} flight {f + 1} ({'BITs only' if k else 'in-flight'})"
                              f": mapr replay exit {rc}: {text.strip().splitlines()[-1:]}")
                        failed += 1
                if not keep:
                    Path(path).unlink(missing_ok=True)
                done += 1
            print(f"  {u.tail} ({u.kind}, EoL {u.path.eol_flight:.1f}): {len(u.flights)} whole "
                  f"flights replayed twice ({done}/{total}, {time.monotonic() - started:.0f} s)",
                  flush=True)
    if bus_s > 0:
        print(f"replay CPU per recording ({bus_s / max(done, 1):.1f} s of bus): in-flight on "
              f"{cpu[0] / max(done, 1):.2f} s ({bus_s / max(cpu[0], 1e-9):.0f}x real time), "
              f"BITs only {cpu[1] / max(done, 1):.2f} s ({bus_s / max(cpu[1], 1e-9):.0f}x); "
              "each replay includes its catalog writes and trend refit")
    return failed


def print_inflight(conn: sqlite3.Connection, units: Sequence[Unit], rebase: bool = False
                   ) -> None:
    """Per-flight in-flight friction change read back (the ``inflight`` table), in units of
    friction's failure threshold (``FAILURE - 1``), against the unit's true aging path (0 on
    a unit that does not age): error mean, sd and worst, the mean stated sd and how often
    the stated 90 % band (1.645 sd) holds the truth. The truth is the smooth path: the
    flight's own grease scatter (lognormal, the actuator file's ``friction_flight_sd``) is
    part of the error, as it is for the trend. ``rebase`` (``--readback --reassess``): each
    row's change and sds recomputed from its stored value and tracker sd by this checkout's
    :class:`~mapr_daemon.reasoner.inflight.baseline.Baseline`, in flight order."""
    params = load_actuator(default_actuator_path())
    scale = FAILURE["friction"] - 1.0
    print(f"\nin-flight friction change per flight (from the catalog, in units of the failure "
          f"threshold; the flight's grease scatter, sd {params.motor.friction_flight_sd:g} "
          f"of friction = {params.motor.friction_flight_sd / scale:.3f} here, is in the "
          "error):")
    for name, group in (("friction", [u for u in units if u.kind == "friction"]),
                        ("do not age", [u for u in units if u.kind == HEALTHY])):
        err, sd = [], []
        parts: list[tuple[float, float]] = []
        life: list[float] = []
        pending = rows = 0
        for u in group:
            base = Baseline()
            for r in load_inflight(conn, tail=u.tail):
                rows += 1
                p = r.parameters.get("friction", {})
                if rebase and "value" in p:
                    p = base.rebase({"friction": {"value": p["value"], "sd": p["sd"]}},
                                    r.flight)["friction"]
                change, s = p.get("change"), p.get("sd_change")
                if r.flight is None or change is None or s is None:
                    pending += 1
                    continue
                f = r.flight - 1
                true = 0.0 if u.kind == HEALTHY else \
                    degradation(params, "friction", float(u.path.values[f]))
                err.append(float(change) / scale - true)
                sd.append(float(s) / scale)
                parts.append((float(p.get("sd_flight") or math.nan) / scale,
                              float(p.get("sd_baseline") or math.nan) / scale))
                life.append(f / (len(u.flights) if u.kind == HEALTHY else u.path.eol_flight))
        if not err:
            print(f"  {name:>10}: {rows} rows, none with a change")
            continue
        e, d = np.array(err), np.array(sd)
        print(f"  {name:>10}: {e.size} flights ({pending} without a change: baseline "
              f"pending or not estimated); error mean {e.mean():+.3f} sd {e.std():.3f} worst "
              f"{np.abs(e).max():.3f}; stated sd mean {d.mean():.3f}; stated 90 % band holds "
              f"the truth in {100 * np.mean(np.abs(e) <= 1.645 * d):.0f} %")
        print_band(e, d, np.array(parts), np.array(life))


def print_band(err: FloatArray, sd: FloatArray, parts: FloatArray, life: FloatArray) -> None:
    """The stated sd's honesty (reasoner/inflight/scatter.py): error sd over the mean
    stated sd, the rms of error/stated (1 when honest), the 90 % band's coverage by third
    of the unit's life (``life``: each flight's fraction of it), and the stated sd's parts
    (the flight's own, the baseline's)."""
    z = err / sd
    thirds = [(life < 1 / 3), (life >= 1 / 3) & (life < 2 / 3), (life >= 2 / 3)]
    by = "/".join(f"{100 * np.mean(np.abs(z[i]) <= 1.645):.0f}" if i.any() else "-"
                  for i in thirds)
    print(f"{'':>14}error sd / stated sd mean {err.std() / max(sd.mean(), 1e-12):.2f}; rms of "
          f"error/stated {math.sqrt(float(np.mean(z * z))):.2f} (worst |error|/stated "
          f"{np.abs(z).max():.1f}); stated sd parts, mean: flight {np.nanmean(parts[:, 0]):.3f}, "
          f"baseline {np.nanmean(parts[:, 1]):.3f}; 90 % band coverage by third of life "
          f"{by} %")


def print_pair(fused: Scores, only: Scores, kinds: Sequence[str], cadence: str) -> None:
    """BITs only and BITs + in-flight (same recordings, same catalog reading), kind by kind."""
    print(f"\n== beside: {cadence}, BITs only against BITs + in-flight estimates (the same "
          "recordings replayed twice) ==")
    for title, i in (("the TRUE kind's mode", 0), ("the headline", 1)):
        print(f"{title}:")
        for k in [*kinds, "all"]:
            for name, scores in (("BITs", only[i]), ("+infl", fused[i])):
                line = kind_summary(k, [s for s in scores if k == "all" or s.kind == k])
                print(f"  {name:>5} {line.strip()}")


def score_both(catalogs: tuple[Path, Path], units: Sequence[Unit], model: PrognosticModel,
               kinds: Sequence[str], args: argparse.Namespace, label: str,
               cadence: str) -> Scores:
    """Score one set of units' two catalogs (tracker on, then ``reasoner.inflight: false``)
    side by side; the in-flight catalog's scores are returned."""
    print(f"\n######## {label}BITs + in-flight estimates ########")
    fused = read_catalog(catalogs[0], units, model, kinds, args)
    with sqlite3.connect(catalogs[0]) as conn:
        print_inflight(conn, units, args.reassess)
    print(f"\n######## {label}BITs only (the same recordings, reasoner.inflight: false) "
          "########")
    only = read_catalog(catalogs[1], units, model, kinds, args)
    print_pair(fused, only, kinds, cadence)
    return fused


def whole_main(args: argparse.Namespace, seed: int, out: Path, model: PrognosticModel,
               kinds: Sequence[str], rng: np.random.Generator, started: float) -> int:
    """``--whole-flights``: every flight of every unit flown whole (a PBIT at power-up on
    every ``--bit-every``-th), replayed with the in-flight tracker on and again BITs only
    (``reasoner.inflight: false``) into two catalogs, both scored; with ``--mismatch`` the
    same on built units, commissioned first."""
    global TEMPLATES
    healthy = WHOLE_HEALTHY if args.healthy_flights is None else args.healthy_flights
    units = [Unit(f"U{i + 1:02d}", k, int(rng.integers(SEED_BASE, 2 * SEED_BASE)), 1,
                  args.mean_life, healthy)
             for i, k in enumerate([*(k for k in kinds for _ in range(args.units_per_kind)),
                                    *[HEALTHY] * args.healthy_units])]
    cadence = f"PBIT every {'flight' if args.bit_every == 1 else f'{args.bit_every} flights'}"
    print(f"{len(units)} units ({args.units_per_kind} per kind of {', '.join(kinds)}, "
          f"{args.healthy_units} that do not age over {healthy} flights; mean life "
          f"{args.mean_life:g} flights, the fleet prior's {MEAN_LIFE:g}), every flight whole, "
          f"{cadence}: {sum(len(u.flights) for u in units)} recordings; unit seeds "
          + ", ".join(f"{u.tail}={u.seed}" for u in units))
    print("expected life stated in the configuration: none" if args.expected_life is None
          else f"expected life stated in the configuration: {args.expected_life:g} flights")
    lives = "" if args.expected_life is None else \
        "    expected_life_flights: {" + ", ".join(
            f"{k}: {args.expected_life:g}" for k in kinds) + "}\n"
    base_config = (f"reasoner:\n  dictionary: {args.dictionary.resolve()}\nassets:\n"
                   f"  - name: EMA1\n    rt: 5\n    prognosis: "
                   f"{args.prognosis.resolve()}\n{lives}")
    config, config_off = out / "mapr.yaml", out / "mapr-bits-only.yaml"
    config.write_text(base_config, encoding="utf-8")
    config_off.write_text(bits_only(base_config), encoding="utf-8")
    plan = whole_plan(units, rng, max(args.templates, 1))
    built = built_units(units, seed) if args.mismatch else []
    jobs = max(args.jobs, 1)
    catalogs = (out / "fleet.db", out / "fleet-bits-only.db")
    if not args.readback:
        TEMPLATES = build_templates(max(args.templates, 1), args.flight_scale, args.bit_every,
                                    np.random.default_rng([seed, WHOLE_STREAM]), jobs)
    fused: Scores | None = None
    if not args.built_only:
        if not args.readback:
            for c in catalogs:
                c.unlink(missing_ok=True)
            failed = fly_and_replay_whole(units, out,
                                          {u.tail: (config, config_off) for u in units},
                                          catalogs, jobs, plan, args.bit_every,
                                          args.keep_recordings)
            print(f"flown and replayed in {time.monotonic() - started:.0f} s; failed: {failed}")
        fused = score_both(catalogs, units, model, kinds, args, "", cadence)
    if built:
        where = out / "mismatch"
        where.mkdir(exist_ok=True)
        (where / "mapr.yaml").write_text(base_config, encoding="utf-8")
        mm = (where / "fleet.db", where / "fleet-bits-only.db")
        if not args.readback:
            t0 = time.monotonic()
            print(f"\ncommissioning {len(built)} built units on {args.commission_bits} healthy "
                  "BITs each (2 s BIT flights over the envelope, as without --whole-flights):")
            configs = commission(built, where, args.dictionary, base_config,
                                 args.commission_bits, jobs,
                                 np.random.default_rng([seed, MISMATCH_STREAM, 1]),
                                 args.keep_recordings)
            pairs: dict[str, tuple[Path, Path]] = {}
            for tail, c in configs.items():
                off = c.with_name(f"{c.stem}-bits-only.yaml")
                off.write_text(bits_only(c.read_text(encoding="utf-8")), encoding="utf-8")
                pairs[tail] = (c, off)
            print(f"commissioned in {time.monotonic() - t0:.0f} s; flying the same flights "
                  "whole on the built units:")
            for c in mm:
                c.unlink(missing_ok=True)
            t0 = time.monotonic()
            failed = fly_and_replay_whole(built, where, pairs, mm, jobs, plan,
                                          args.bit_every, args.keep_recordings)
            print(f"flown and replayed in {time.monotonic() - t0:.0f} s; failed: {failed}")
        mm_fused = score_both(mm, built, model, kinds, args, "built units (--mismatch): ",
                              f"built units, {cadence}")
        if fused is not None:
            print_beside(fused, mm_fused, kinds)
    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    print(f"\ntotal runtime {time.monotonic() - started:.0f} s wall; CPU "
          f"{time.process_time():.0f} s in this process (replays, scoring) + "
          f"{children.ru_utime + children.ru_stime:.0f} s in the flying processes; load "
          f"average {' '.join(f'{x:.2f}' for x in os.getloadavg())} (1, 5, 15 min)")
    return 0


WHOLE_STREAM = 29
"""The whole-flight profiles draw from ``default_rng([seed, 29])``: a stream of their own."""


if __name__ == "__main__":
    sys.exit(main())
