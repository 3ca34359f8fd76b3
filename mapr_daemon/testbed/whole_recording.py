"""Whole flights recorded as Chapter 10: the testbed aircraft flying taxi to taxi, on the bus.

The in-flight tracker reads the traffic between BITs, so a bench of it through the product
(``mapr replay``, ``mapr fleet``) needs recordings of whole flights, not the fleet archive's
2 s BIT excerpts (:mod:`.fleet`). :func:`whole_template` flies the testbed aircraft once over
the loopback bus along a whole flight (:func:`~.whole_flight.flight_profile`: taxi out with the
control check, JSBSim climb, cruise turns, cruise hold, approach, taxi in), the flight control
computer asking for a BIT at power-up (``t = 0``: a PBIT) when ``bit``;
:func:`record_flight` writes one flight of it with the EMA's faults, seed and, for a built
unit (:mod:`.mismatch`), its own parameters and model form
(:meth:`~.flight_template.FlightTemplate.flight`: the EMA's answers recomputed, the plant run
once over the flight). Flights made from one template share the aircraft's commands and air
data; what differs is the EMA: its health, its noise, its ambient and bus voltage drawn from
the seed, its grease's flight-to-flight scatter.

Cost (measured by hand on this machine's shared core at ``scale`` 0.1, 25.5 s of bus): a
template ~0.7-1.1 s of CPU per second of bus, once; a flight ~4.5 % of its length (the EMA's
answers ~3.5 %, the file ~1 %), so a 255 s flight ~11 s. ``scale`` shortens every phase
(:data:`~.whole_flight.PHASES_S`).

Example::

    tpl = whole_template(seed=3, scale=0.5, bit=True)
    record_flight("N101/flight-0001.ch10", tpl, FaultSet(), seed=7, start=FIRST_DAY, tail="N101")
"""

from __future__ import annotations

from datetime import datetime
from pathlib import Path

from drivers.chapter10.writer import Chapter10Writer
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
from mapr_daemon.testbed.backend import RATE_HZ
from mapr_daemon.testbed.flight_template import FlightTemplate
from mapr_daemon.testbed.whole_flight import flight_profile


def whole_template(seed: int, scale: float = 1.0, *, bit: bool = True) -> FlightTemplate:
    """The testbed aircraft's bus traffic over one whole flight (``seed``: the profile's
    draws), flown once with the data sheet's healthy EMA; a BIT requested at power-up when
    ``bit``."""
    params = with_sample_rate(load_actuator(default_actuator_path()), RATE_HZ)
    profile = flight_profile(RATE_HZ, seed=seed, scale=scale)
    return FlightTemplate(load_icd(DEFAULT_ICD), profile, params, profile.n_samples / RATE_HZ,
                          bit=bit)


def flight_seconds(template: FlightTemplate) -> float:
    """Seconds of bus a flight of ``template`` holds."""
    return template.profile.n_samples / RATE_HZ


def record_flight(path: str | Path, template: FlightTemplate, faults: FaultSet, *, seed: int,
                  start: datetime, tail: str = "", params: ActuatorParams | None = None,
                  form: ModelForm | None = None) -> None:
    """One flight of ``template`` with the EMA's ``faults`` seeded (a built unit: its own
    ``params`` and ``form``), written to ``path`` as Chapter 10 starting at ``start``; the
    tail number in its TMATS record when given."""
    own = None if params is None else with_sample_rate(params, RATE_HZ)
    records = template.flight(faults, seed, params=own, form=form)
    with Chapter10Writer(Path(path), start_time=start, tail=tail) as writer:
        writer.write(records)
