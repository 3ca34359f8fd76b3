"""A synthetic fleet archive: several tails, successive flights, each a Chapter 10 file.

For tests and benches of fleet analysis (``mapr fleet``; ``mapr fleet-archive`` writes one).
Every flight is the testbed's aircraft (:mod:`.aircraft`) on the loopback bus, recorded by the
project's own Chapter 10 writer. A flight's file is an excerpt: ``flight_s`` seconds of bus
traffic, with the flight control computer asking for one built-in test at its start on every
``bit_every``-th flight (the BIT is what the reasoner decides on; the other flights carry
traffic only). Each file stands for a flight of ``flight_hours`` declared in the manifest.

The bus traffic is flown once per archive and kind of flight (with or without a BIT), word
level and unpaced (:class:`~.flight_template.FlightTemplate`); each flight is that traffic with
its EMA's answers recomputed for its actuator's health and seed, the plant run once over the
flight: the same file, byte for byte, as flying it over the bus, in a small part of the time.

Some tails' actuators age along :func:`mapr_daemon.ema.degradation.trajectory` (a kind drawn
per tail, its life drawn around ``life_flights``): flight ``n`` of such a tail is flown with the
trajectory's value at ``n`` seeded as an EMA fault. The others stay healthy.

Layout::

    ARCHIVE/fleet.json                 the manifest: tails, flights, truth
    ARCHIVE/TAIL/flight-NNNN.ch10      one recording per flight (NNNN from 0001)

Tail and flight are in the path and the manifest; the tail is also in each file's TMATS
record (``G\\TA``, what ``mapr fleet --tail-tmats 'G\\TA'`` reads). The manifest is JSON::

    {"seed": 7, "flight_hours": 1.5, "flight_s": 2.0, "bit_every": 1,
     "recordings": [{"path": "N101/flight-0001.ch10", "tail": "N101", "flight": 1,
                     "flight_hours": 1.5, "bit": true}, ...],
     "truth": {"N101": {"EMA1": {"kind": "esr", "values": [...], "nominal": 0.1,
                                 "threshold": 0.2, "eol_flight": 31.4}}, "N102": {}}}

``values[i]`` is the true parameter on flight ``i + 1``; ``eol_flight`` counts flights from 0
as the trajectory does (flight ``k`` of the path is trajectory index ``k - 1``).
"""

from __future__ import annotations

import dataclasses
import json
import math
from collections.abc import Callable, Iterable
from datetime import UTC, datetime, timedelta
from pathlib import Path
from typing import Any

import numpy as np

from drivers.chapter10.writer import Chapter10Writer
from drivers.monitor import open_monitor
from mapr_daemon.ema.degradation import Trajectory, trajectory
from mapr_daemon.ema.faults import FaultSet
from mapr_daemon.ema.form import ModelForm
from mapr_daemon.ema.params import (
    ActuatorParams,
    default_actuator_path,
    load_actuator,
    with_sample_rate,
)
from mapr_daemon.icd import load_icd
from mapr_daemon.pipeline.settings import DEFAULT_ICD
from mapr_daemon.testbed.aircraft import Aircraft
from mapr_daemon.testbed.backend import RATE_HZ
from mapr_daemon.testbed.flight_template import FlightTemplate
from mapr_daemon.testbed.profiles import steady_profile

MANIFEST = "fleet.json"
ASSET = "EMA1"
"""The testbed aircraft's one actuator (RT 5 in the shipped ICD)."""
FIRST_DAY = datetime(2026, 1, 5, 8, 0, tzinfo=UTC)
"""The start of every tail's first flight; flight ``n`` starts ``n - 1`` days later."""


@dataclasses.dataclass(frozen=True)
class FleetSpec:
    """What archive to make."""

    tails: int = 3
    flights: int = 3
    seed: int = 1
    degrading: float = 0.5
    """Share of tails whose actuator ages (rounded up; at least one when above 0)."""
    kinds: tuple[str, ...] = ("esr", "friction")
    """Aging kinds drawn for the degrading tails."""
    life_flights: float = 0.0
    """Mean life of a degrading actuator, in flights (0: 1.5 times ``flights``, so the
    archive shows most of the aging)."""
    bit_every: int = 1
    flight_s: float = 2.0
    flight_hours: float = 1.5
    condition: str = "cruise"

    def tail_name(self, index: int) -> str:
        return f"N{101 + index}"


def recording_path(tail: str, flight: int) -> str:
    """A recording's path relative to the archive root."""
    return f"{tail}/flight-{flight:04d}.ch10"


def generate(root: str | Path, spec: FleetSpec,
             map_tails: Callable[..., Iterable[TailArchive]] = map) -> dict[str, Any]:
    """Write the archive under ``root`` (created) and return its manifest (also written).

    ``map_tails`` maps :func:`generate_tail` over the tails (``Executor.map`` of a process
    pool writes tails in parallel; the archive is the same either way). The bus traffic is
    flown first, once for each kind of flight the archive holds (:func:`flight_templates`)."""
    out = Path(root)
    out.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(spec.seed)
    n_degrading = 0 if spec.degrading <= 0 else max(1, math.ceil(spec.degrading * spec.tails))
    degrading = set(rng.choice(spec.tails, size=min(n_degrading, spec.tails), replace=False)
                    .tolist())
    kinds = [spec.kinds[int(rng.integers(len(spec.kinds)))] if i in degrading else None
             for i in range(spec.tails)]
    templates = flight_templates(spec)
    tails = list(map_tails(generate_tail, [str(out)] * spec.tails, [spec] * spec.tails,
                           range(spec.tails), kinds, [templates] * spec.tails))
    recordings = [r for tail in tails for r in tail.recordings]
    truth = {tail.tail: tail.truth for tail in tails}
    manifest = {"seed": spec.seed, "tails": spec.tails, "flights": spec.flights,
                "flight_hours": spec.flight_hours, "flight_s": spec.flight_s,
                "bit_every": spec.bit_every, "recordings": recordings, "truth": truth}
    (out / MANIFEST).write_text(json.dumps(manifest, indent=1) + "\n", encoding="utf-8")
    return manifest


@dataclasses.dataclass(frozen=True)
class TailArchive:
    """One tail's part of the manifest."""

    tail: str
    recordings: list[dict[str, Any]]
    truth: dict[str, Any]


def flight_templates(spec: FleetSpec) -> dict[bool, FlightTemplate]:
    """The archive's flights, flown once over the bus: with a BIT at the start (True) and,
    when ``bit_every`` leaves flights without one, without (False)."""
    icd = load_icd(DEFAULT_ICD)
    params = with_sample_rate(load_actuator(default_actuator_path()), RATE_HZ)
    profile = steady_profile(RATE_HZ, spec.condition, duration_s=max(spec.flight_s, 1.0))
    kinds = {(flight - 1) % spec.bit_every == 0 for flight in range(1, spec.flights + 1)}
    return {bit: FlightTemplate(icd, profile, params, spec.flight_s, bit=bit)
            for bit in sorted(kinds, reverse=True)}


def generate_tail(root: str, spec: FleetSpec, index: int, kind: str | None,
                  templates: dict[bool, FlightTemplate] | None = None) -> TailArchive:
    """Every flight of tail ``index`` (aging along ``kind``, None: healthy) under ``root``,
    from the archive's ``templates`` (None: flown here, :func:`flight_templates`)."""
    out = Path(root)
    templates = flight_templates(spec) if templates is None else templates
    params = with_sample_rate(load_actuator(default_actuator_path()), RATE_HZ)
    life = spec.life_flights or 1.5 * spec.flights
    tail = spec.tail_name(index)
    path: Trajectory | None = None
    if kind is not None:
        path = trajectory(params, kind, max(spec.flights, 2), seed=spec.seed * 1000 + index,
                          mean_life_flights=life)
    recordings = []
    (out / tail).mkdir(exist_ok=True)
    for flight in range(1, spec.flights + 1):
        faults = FaultSet() if path is None else FaultSet.of([path.fault(flight - 1)])
        bit = (flight - 1) % spec.bit_every == 0
        name = recording_path(tail, flight)
        start = FIRST_DAY + timedelta(days=flight - 1, minutes=index)
        records = templates[bit].flight(faults, seed=spec.seed * 100_000 + index * 1000
                                        + flight)
        with Chapter10Writer(out / name, start_time=start, tail=tail) as writer:
            writer.write(records)
        recordings.append({"path": name, "tail": tail, "flight": flight,
                           "flight_hours": spec.flight_hours, "bit": bit,
                           "start": start.isoformat()})
    return TailArchive(tail, recordings, {} if path is None else
                       {ASSET: _truth(path, spec.flights)})


def fly_flight(path: str | Path, faults: FaultSet, *, seed: int, start: datetime,
               bit: bool = True, flight_s: float = 2.0, condition: str = "cruise",
               params: ActuatorParams | None = None, form: ModelForm | None = None,
               ambient_c: float | None = None, bus_v: float | None = None) -> None:
    """One flight of the testbed aircraft, ``faults`` seeded in its EMA, recorded to ``path``.

    The flight the archive above is made of, one at a time: ``flight_s`` seconds of bus
    traffic at the named flight ``condition``, the flight control computer asking for a BIT at
    its start when ``bit``. For benches that choose each flight's fault and condition
    themselves (a run-to-failure unit's BIT flights, flown in parallel one task per flight).
    ``seed`` seeds the aircraft; the bus's own noise is seeded from it too.

    By default the EMA is the shipped data sheet's twin. A built unit that is not
    (:mod:`.mismatch`: its own ``params`` and model ``form``) is flown by passing both
    (``faults`` then hold the unit's own values); ``ambient_c`` and ``bus_v`` fix the
    flight's ambient temperature and mean bus voltage instead of the plant's draw around the
    file's values (e.g. commissioning BITs flown over the envelope). With none of these the
    flight is the one it always was, bit for bit."""
    params = with_sample_rate(params or load_actuator(default_actuator_path()), RATE_HZ)
    profile = steady_profile(RATE_HZ, condition, duration_s=max(flight_s, 1.0))
    aircraft = Aircraft(load_icd(DEFAULT_ICD), profile, params, faults, seed=seed,
                        bit_requests_s=(0.0,) if bit else (), form=form, ambient_c=ambient_c,
                        bus_v=bus_v)
    _fly(aircraft, Path(path), flight_s, start, seed=seed)


def _truth(path: Trajectory, flights: int) -> dict[str, Any]:
    return {"kind": path.kind, "values": [float(v) for v in path.values[:flights]],
            "nominal": path.nominal, "threshold": path.threshold,
            "eol_flight": None if math.isinf(path.eol_flight) else path.eol_flight}


def _fly(aircraft: Aircraft, path: Path, seconds: float, start: datetime, seed: int,
         tail: str = "") -> None:
    """One flight's traffic, word level and unpaced, into a Chapter 10 file (the tail number
    in its TMATS record when given)."""
    schedule = aircraft.schedule()
    frames = round(seconds * 1e9 / schedule.frame_ns)
    monitor = open_monitor("loopback", terminals=aircraft.terminals(), schedule=schedule,
                           frames=frames, realtime=False, bit_level=False, seed=seed)
    with monitor, Chapter10Writer(path, start_time=start, tail=tail) as writer:
        while True:
            record = monitor.recv(timeout=0.0)
            if record is not None:
                writer.write((record,))
            elif monitor.ended:
                break
