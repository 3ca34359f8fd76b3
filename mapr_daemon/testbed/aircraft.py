"""The simulated aircraft on the loopback bus: flight control computer, EMAs and air data.

One source of truth: the message table (``configs/icd/ema-testbed.yaml``) gives the bus
controller's schedule and every word the terminals put on the bus, encoded with the same ICD
the monitor decodes with. The flight (a :class:`~mapr_daemon.ema.profile.Profile`, e.g.
a JSBSim flight) gives the surface command the flight control computer sends and the air data
the air-data computer reports; each EMA (:mod:`.ema_terminal`: its plant, with its faults
seeded, its sample blocks and its stored built-in test) answers its own command.

An aircraft flies one EMA (RT 5, the table's aileron) or several on one bus
(:meth:`Aircraft.add_ema`: the shipped table's elevator at RT 7), each with its own actuator
data sheet, faults, seed and BIT requests. The flight control computer commands each surface
with the flight's command and requests each EMA's BITs on its own schedule.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

from drivers.backends.loopback import RemoteTerminal, Schedule, ScheduledMessage
from mapr_daemon.ema.faults import FaultSet
from mapr_daemon.ema.form import ModelForm
from mapr_daemon.ema.params import ActuatorParams, default_actuator_path, load_actuator
from mapr_daemon.ema.profile import Profile
from mapr_daemon.icd import Icd
from mapr_daemon.testbed.ema_terminal import (
    FAST_CHANNELS,
    HISTORY_S,
    POWER_CHANNELS,
    SLOW_CHANNELS,
    EmaTerminal,
    TerminalNames,
    decode_data,
)

__all__ = [
    "FAST_CHANNELS",
    "HISTORY_S",
    "POWER_CHANNELS",
    "SLOW_CHANNELS",
    "AirDataTerminal",
    "Aircraft",
    "EmaTerminal",
    "FlightControlComputer",
    "decode_data",
    "isa",
]

G0 = 9.80665
R_AIR = 287.053
RHO0 = 1.225
def isa(altitude_m: float) -> tuple[float, float]:
    """Static pressure (Pa) and temperature (K) of the ISA troposphere at an altitude."""
    temperature = 288.15 - 0.0065 * altitude_m
    return 101_325.0 * (temperature / 288.15) ** (G0 / (R_AIR * 0.0065)), temperature


class AirDataTerminal:
    """The air-data computer: reports the flight's air data (ISA static pressure and
    temperature at the flight's altitude, calibrated airspeed from the density ratio)."""

    def __init__(self, icd: Icd, profile: Profile) -> None:
        self.icd = icd
        self.profile = profile
        self.sequence = 0

    def at(self, t_ns: int) -> dict[str, float]:
        p = self.profile
        k = min(int(t_ns / 1e9 / _period(p)), p.n_samples - 1)
        altitude = float(p.altitude_m[k])
        pressure, temperature = isa(altitude)
        density = float(p.density_kg_m3[k])
        tas = float(p.airspeed_mps[k])
        return {"pressure_altitude": altitude, "true_airspeed": tas,
                "calibrated_airspeed": tas * math.sqrt(density / RHO0),
                "static_pressure": pressure, "static_air_temperature": temperature - 273.15,
                "air_density": density, "dynamic_pressure": float(p.dynamic_pressure_pa[k])}

    def air_data(self, t_ns: int) -> list[int]:
        self.sequence += 1
        values: dict[str, Any] = {**self.at(t_ns), "baro_setting": 29.92, "adc_valid": 1,
                                  "pitot_heat": 1, "adc_fault": 0,
                                  "air_data_seq": self.sequence}
        return list(self.icd.encode("adc_air_data", values, strict=False))

    def air_data_to_ema(self, t_ns: int) -> list[int]:
        now = self.at(t_ns)
        return list(self.icd.encode("ema_air_data", {
            "ema_dynamic_pressure": now["dynamic_pressure"],
            "ema_true_airspeed": now["true_airspeed"]}, strict=False))


def _period(profile: Profile) -> float:
    return float(profile.time_s[1] - profile.time_s[0]) if profile.n_samples > 1 else 1.0



class FlightControlComputer:
    """The bus controller's data for one EMA: its surface command from the flight, its BIT
    requests.

    ``bit_requests_s``: flight times at which the FCC asks the EMA for an initiated BIT, and
    ``bit_every_s`` a period at which it asks again after the last of them (None: never). Each
    request goes out in the EMA's first BIT request message (1 Hz) at or after its time, with
    a new sequence number. ``names``: the EMA's names in the table (default RT 5's).
    """

    def __init__(self, icd: Icd, profile: Profile, rate_limit_deg_s: float = 200.0,
                 bit_requests_s: Sequence[float] = (), bit_every_s: float | None = None,
                 names: TerminalNames | None = None) -> None:
        self.icd = icd
        self.profile = profile
        self.names = TerminalNames(icd, 5) if names is None else names
        self.rate_limit = rate_limit_deg_s
        self.sequence = 0
        self.bit_requests_ns = sorted(round(t * 1e9) for t in bit_requests_s)
        self.bit_every_ns = None if bit_every_s is None else round(bit_every_s * 1e9)
        self.bit_sequence = 0

    def _encode(self, role: str, values: dict[str, Any]) -> list[int]:
        name = self.names.messages[role].name
        return list(self.icd.encode(name, self.names.values(values), strict=False))

    def command(self, t_ns: int) -> list[int]:
        p = self.profile
        k = min(int(t_ns / 1e9 / _period(p)), p.n_samples - 1)
        self.sequence += 1
        return self._encode("position_command", {
            "position_command": float(p.command_deg[k]), "drive_enable": 1,
            "command_mode": "POSITION", "command_seq": self.sequence,
            "rate_limit": self.rate_limit})

    def bit_request(self, t_ns: int) -> list[int]:
        due = bool(self.bit_requests_ns) and self.bit_requests_ns[0] <= t_ns
        if due:
            last = self.bit_requests_ns[-1]
            self.bit_requests_ns = [t for t in self.bit_requests_ns if t > t_ns]
            if not self.bit_requests_ns and self.bit_every_ns:
                self.bit_requests_ns = [last + self.bit_every_ns * (1 + (t_ns - last) //
                                                                    self.bit_every_ns)]
            self.bit_sequence = (self.bit_sequence + 1) % 256
        return self._encode("bit_request", {
            "bit_request": "INITIATED_BIT" if due else "NONE",
            "bit_request_seq": self.bit_sequence})


class Aircraft:
    """The whole simulated aircraft for the loopback bus: its terminals and its schedule.

    The constructor flies one EMA (``params``, ``faults``, ``seed``, BIT requests, at RT
    ``rt``, 5 by default; optionally a built unit's model ``form`` and this flight's
    ``ambient_c`` and ``bus_v``, see :class:`~.ema_terminal.EmaTerminal`); :meth:`add_ema`
    adds another at its own RT. :attr:`emas` and
    :attr:`fccs` list them in that order; :attr:`ema` and :attr:`fcc` are the first.

    >>> aircraft = Aircraft.build(profile, faults=FaultSet.of([...]))     # doctest: +SKIP
    >>> LoopbackMonitor(terminals=aircraft.terminals(), schedule=aircraft.schedule())
    """

    def __init__(self, icd: Icd, profile: Profile, params: ActuatorParams,
                 faults: FaultSet | None = None, seed: int = 0,
                 bit_requests_s: Sequence[float] = (), bit_every_s: float | None = None,
                 *, rt: int = 5, form: ModelForm | None = None,
                 ambient_c: float | None = None, bus_v: float | None = None) -> None:
        self.icd = icd
        self.profile = profile
        self.adc = AirDataTerminal(icd, profile)
        self.emas: list[EmaTerminal] = []
        self.fccs: list[FlightControlComputer] = []
        self.add_ema(rt, params, faults, seed=seed, bit_requests_s=bit_requests_s,
                     bit_every_s=bit_every_s, form=form, ambient_c=ambient_c, bus_v=bus_v)

    @classmethod
    def build(cls, icd: Icd, profile: Profile, *, actuator: str | None = None,
              faults: FaultSet | None = None, seed: int = 0,
              bit_requests_s: Sequence[float] = (),
              bit_every_s: float | None = None) -> Aircraft:
        params = load_actuator(actuator or default_actuator_path())
        return cls(icd, profile, params, faults, seed, bit_requests_s, bit_every_s)

    def add_ema(self, rt: int, params: ActuatorParams, faults: FaultSet | None = None, *,
                seed: int = 0, bit_requests_s: Sequence[float] = (),
                bit_every_s: float | None = None, form: ModelForm | None = None,
                ambient_c: float | None = None, bus_v: float | None = None) -> EmaTerminal:
        """Fly another EMA at remote terminal ``rt`` (its messages in the table, see
        :class:`~.ema_terminal.TerminalNames`), with its own data sheet, faults, seed and BIT
        requests (and optionally model form and flight condition, as
        :class:`~.ema_terminal.EmaTerminal` takes them). Raises KeyError when the table lacks
        the RT or one of its messages, and ValueError when the RT is already flown."""
        if any(e.rt == rt for e in self.emas):
            raise ValueError(f"RT {rt} already carries an EMA")
        ema = EmaTerminal(self.icd, params, faults or FaultSet(), seed=seed,
                          dynamic_pressure=self._q, rt=rt, form=form, ambient_c=ambient_c,
                          bus_v=bus_v)
        self.emas.append(ema)
        self.fccs.append(FlightControlComputer(self.icd, self.profile,
                                               bit_requests_s=bit_requests_s,
                                               bit_every_s=bit_every_s, names=ema.names))
        return ema

    @property
    def ema(self) -> EmaTerminal:
        return self.emas[0]

    @property
    def fcc(self) -> FlightControlComputer:
        return self.fccs[0]

    def _q(self, t_s: float) -> float:
        p = self.profile
        return float(p.dynamic_pressure_pa[min(int(t_s / _period(p)), p.n_samples - 1)])

    def terminals(self) -> list[RemoteTerminal]:
        transmit = {self.icd.message("adc_air_data").subaddress: self.adc.air_data}
        source = self.icd.message("ema_air_data").source
        if source is not None:
            transmit[source[1]] = self.adc.air_data_to_ema
        return [*(ema.terminal() for ema in self.emas), RemoteTerminal(6, transmit=transmit)]

    def schedule(self) -> Schedule:
        """The ICD's schedule as the flight control computer runs it; the messages of an RT
        that carries no EMA on this flight are left out (the bus controller does not poll a
        terminal that is not fitted)."""
        if self.icd.schedule is None:
            raise ValueError(f"{self.icd.name}: the table has no schedule")
        data: dict[str, Callable[[int], list[int]]] = {}
        for fcc in self.fccs:
            data[fcc.names.messages["position_command"].name] = fcc.command
            data[fcc.names.messages["bit_request"].name] = fcc.bit_request
        fitted = {6, *(ema.rt for ema in self.emas)}
        out = []
        for entry in self.icd.schedule.entries:
            m = self.icd.message(entry.message)
            if m.rt not in fitted:
                continue
            source = m.source
            out.append(ScheduledMessage(
                m.rt, m.subaddress, m.transmit, m.word_count, every=entry.every,
                offset=entry.offset, data=data.get(m.name),
                rt2=None if source is None else source[0],
                sa2=None if source is None else source[1], name=m.name))
        return Schedule(tuple(out), frame_ns=round(self.icd.schedule.minor_frame_us * 1000))
