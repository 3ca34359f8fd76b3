"""A flight's bus traffic flown once, the EMA's answers recomputed for each actuator's health.

The flights of the synthetic fleet archive (:mod:`.fleet`) differ only in what the EMA says:
the bus controller's schedule, its commands, BIT requests and air data come from the flight
profile, never from what the EMA answers. :class:`FlightTemplate` flies the aircraft once over
the loopback bus (word level, unpaced) with a healthy EMA, keeping every record and every
transaction the EMA took part in (:class:`~.ema_terminal.Poll`); :meth:`FlightTemplate.flight`
then gives the records of that flight with the EMA's faults and seed, its answers computed by
:meth:`~.ema_terminal.EmaTerminal.answer_all` (the plant once over the whole flight, the blocks
encoded as columns) in place of the bus. The records are the same, word for word, as flying
the faulty EMA over the bus (tests/testbed/test_flight_template.py): a flight costs a plant run
and a file write instead of a Python call per bus word and per message.

Measured by ``mapr fleet-archive``, which prints its time: see docs/fleet.md.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence

from drivers.backends.loopback import RemoteTerminal
from drivers.mil1553.record import MonitorRecord
from drivers.monitor import open_monitor
from mapr_daemon.ema.faults import FaultSet
from mapr_daemon.ema.form import ModelForm
from mapr_daemon.ema.params import ActuatorParams
from mapr_daemon.ema.profile import Profile
from mapr_daemon.icd import Icd, Message
from mapr_daemon.testbed.aircraft import Aircraft
from mapr_daemon.testbed.ema_terminal import RECEIVE_ROLES, TRANSMIT_ROLES, Poll


class FlightTemplate:
    """One flight of the testbed aircraft (``profile`` for ``seconds`` of bus, a BIT requested
    at its start when ``bit``), recorded once (see the module docstring)."""

    def __init__(self, icd: Icd, profile: Profile, params: ActuatorParams, seconds: float, *,
                 bit: bool) -> None:
        self.icd, self.profile, self.params, self.bit = icd, profile, params, bit
        aircraft = self._aircraft(FaultSet(), seed=0)
        polls: list[Poll] = []
        terminals = aircraft.terminals()
        _note_polls(next(t for t in terminals if t.address == aircraft.ema.rt),
                    aircraft.ema.names.messages, polls)
        self.records: tuple[MonitorRecord, ...] = tuple(
            _fly(aircraft, terminals, seconds))
        self.polls: tuple[Poll, ...] = tuple(polls)
        self.answers = _answers(self.records, aircraft)
        """Per transmit role, the indices of the records that carry the EMA's answers to it,
        in the order of its polls."""
        for role, indices in self.answers.items():
            asked = sum(p.role == role for p in self.polls)
            if asked != len(indices):   # a retried or lost message: the bus was not clean
                raise RuntimeError(f"{role}: {asked} polls but {len(indices)} records")

    def _aircraft(self, faults: FaultSet, seed: int, params: ActuatorParams | None = None,
                  form: ModelForm | None = None) -> Aircraft:
        return Aircraft(self.icd, self.profile, self.params if params is None else params,
                        faults, seed=seed, bit_requests_s=(0.0,) if self.bit else (), form=form)

    def flight(self, faults: FaultSet, seed: int, *, params: ActuatorParams | None = None,
               form: ModelForm | None = None) -> list[MonitorRecord]:
        """The flight's records with the EMA's ``faults`` seeded and its plant's noise seeded
        by ``seed`` (as ``Aircraft(..., faults, seed=seed)`` flown over the bus). A built unit
        that is not the template's (:mod:`.mismatch`: its own ``params``, at the template's
        sample rate, and model ``form``) answers in place of the template's EMA: the bus
        controller's traffic does not depend on what the EMA is."""
        words = self._aircraft(faults, seed, params, form).ema.answer_all(self.polls)
        records = list(self.records)
        for role, indices in self.answers.items():
            rows = words[role].tolist()
            for row, index in zip(rows, indices, strict=True):
                records[index] = dataclasses.replace(records[index], data=tuple(row))
        return records


def _note_polls(terminal: RemoteTerminal, messages: dict[str, Message],
                polls: list[Poll]) -> None:
    """Wrap the EMA terminal's subaddress callbacks so that each call is noted in ``polls``."""
    transmit = {messages[r].subaddress: r for r in TRANSMIT_ROLES}
    receive = {messages[r].subaddress: r for r in RECEIVE_ROLES}

    def answering(role: str, callback: Callable[[int], Sequence[int]]
                  ) -> Callable[[int], Sequence[int]]:
        def noted(t_ns: int) -> Sequence[int]:
            polls.append(Poll(role, t_ns))
            return callback(t_ns)
        return noted

    def receiving(role: str, callback: Callable[[int, tuple[int, ...]], None]
                  ) -> Callable[[int, tuple[int, ...]], None]:
        def noted(t_ns: int, data: tuple[int, ...]) -> None:
            polls.append(Poll(role, t_ns, tuple(data)))
            callback(t_ns, data)
        return noted

    terminal.transmit = {sa: answering(transmit[sa], cb) if sa in transmit else cb
                         for sa, cb in terminal.transmit.items()}
    terminal.receive = {sa: receiving(receive[sa], cb) if sa in receive else cb
                        for sa, cb in terminal.receive.items()}


def _fly(aircraft: Aircraft, terminals: list[RemoteTerminal],
         seconds: float) -> list[MonitorRecord]:
    """The aircraft's records over ``seconds`` of the loopback bus, word level, unpaced."""
    schedule = aircraft.schedule()
    frames = round(seconds * 1e9 / schedule.frame_ns)
    records: list[MonitorRecord] = []
    with open_monitor("loopback", terminals=terminals, schedule=schedule, frames=frames,
                      realtime=False, bit_level=False) as monitor:
        while True:
            record = monitor.recv(timeout=0.0)
            if record is not None:
                records.append(record)
            elif monitor.ended:
                return records


def _answers(records: Sequence[MonitorRecord], aircraft: Aircraft) -> dict[str, list[int]]:
    by_command = {aircraft.ema.names.messages[role].command: role for role in TRANSMIT_ROLES}
    out: dict[str, list[int]] = {role: [] for role in TRANSMIT_ROLES}
    for index, record in enumerate(records):
        role = None if record.command is None else by_command.get(record.command)
        if role is not None:
            out[role].append(index)
    return out
