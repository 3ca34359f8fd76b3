"""The simulated aircraft on the loopback bus: flight control computer, EMA and air data.

One source of truth: the message table (``configs/icd/ema-testbed.yaml``) gives the bus
controller's schedule and every word the terminals put on the bus, encoded with the same ICD
the monitor decodes with. The flight (a :class:`~mapr_daemon.ema.profile.Profile`, e.g.
a JSBSim flight) gives the surface command the flight control computer sends and the air data
the air-data computer reports; the EMA plant (:mod:`mapr_daemon.ema`) answers the command,
with its faults seeded, and its sensors fill the EMA's sample blocks.

The plant advances in lockstep with bus time: when the bus controller polls a block at time t,
the EMA terminal first runs the plant up to t, then hands over the samples the ICD's timing
rule says it latched (the newest one period before t).

Built-in test: as a real servo drive does, the EMA stores its BIT motion (the four-corner
profile of :func:`~mapr_daemon.ema.bit.bit_profile`, from the actuator file's ``bit:``
section) and runs it itself, at its own sample rate, when the flight control computer sends
``INITIATED_BIT`` with a new request sequence number: the profile's first sample is the first
plant sample after the request arrives, the FCC's position command is ignored until the
profile ends, and the BIT result reports ``RUNNING`` then ``DONE``. So the motion a monitor
sees on the bus is exactly the motion the reasoner's dictionary was simulated with, not the
FCC's 100 Hz staircase.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from drivers.backends.loopback import RemoteTerminal, Schedule, ScheduledMessage
from drivers.mil1553.record import MonitorRecord, TransferFormat
from mapr_daemon.ema.batch import RunSpec
from mapr_daemon.ema.bit import bit_profile
from mapr_daemon.ema.faults import FaultSet
from mapr_daemon.ema.params import ActuatorParams, default_actuator_path, load_actuator
from mapr_daemon.ema.plant import EmaBatch
from mapr_daemon.ema.profile import Profile
from mapr_daemon.icd import Icd, Message

G0 = 9.80665
R_AIR = 287.053
RHO0 = 1.225
HISTORY_S = 0.2
"""Sensor history the EMA keeps for its blocks (the slow block spans 50 ms)."""

FAST_CHANNELS = {"dc_link_current": "dc_link_current_a", "phase_current_a": "phase_a_current_a",
                 "phase_current_b": "phase_b_current_a", "phase_current_c": "phase_c_current_a",
                 "dc_bus_voltage": "dc_bus_voltage_v", "surface_position": "position_deg"}
POWER_CHANNELS = {"smps_input_voltage": "smps_input_voltage_v",
                  "smps_input_current": "smps_input_current_a", "smps_ripple_rms": "ripple_rms_v"}
SLOW_CHANNELS = {"motor_temperature": "motor_temperature_c",
                 "power_stage_temperature": "stage_temperature_c"}


def isa(altitude_m: float) -> tuple[float, float]:
    """Static pressure (Pa) and temperature (K) of the ISA troposphere at an altitude."""
    temperature = 288.15 - 0.0065 * altitude_m
    return 101_325.0 * (temperature / 288.15) ** (G0 / (R_AIR * 0.0065)), temperature


class EmaTerminal:
    """The EMA remote terminal: receives commands and air data, streams its sensors."""

    def __init__(self, icd: Icd, params: ActuatorParams, faults: FaultSet, *, seed: int,
                 dynamic_pressure: Callable[[float], float]) -> None:
        self.icd = icd
        self.plant = EmaBatch([RunSpec(params, faults, seed=seed)], powered=True)
        self.rate_hz = float(params.sensors.sample_rate_hz)
        self.dynamic_pressure = dynamic_pressure
        self.command_deg = 0.0
        self.enabled = True
        self.samples_done = 0
        self.history: dict[str, np.ndarray] = {}
        self.truth_position = 0.0
        self.counters: dict[str, int] = {}
        self.history_s = HISTORY_S
        self.bit_command = bit_profile(self.rate_hz, "ground", params.bit).command_deg
        """The stored BIT motion (the actuator's ``bit:`` section), one command per plant
        sample."""
        self.bit_start: int | None = None
        """Plant sample index of the running (or last) BIT's first profile sample."""
        self.bit_state = "IDLE"
        self.bit_seq: int | None = None
        self.bits_run = 0

    @property
    def bit_running(self) -> bool:
        return self.bit_state == "RUNNING"

    # --- the plant --------------------------------------------------------------------------
    def run_to(self, t_ns: int) -> None:
        """Advance the plant to bus time ``t_ns`` with the command it holds."""
        target = int(t_ns * self.rate_hz / 1e9)
        n = target - self.samples_done
        if n <= 0:
            return
        start_s = self.samples_done / self.rate_hz
        q = self.dynamic_pressure(start_s)
        block = self.plant.advance(n, command_deg=self._commands(n), dynamic_pressure_pa=q)
        keep = int(self.history_s * self.rate_hz)
        for name, values in block.channels.items():
            joined = np.concatenate([self.history.get(name, np.zeros(0)), values[0]])
            self.history[name] = joined[-keep:]
        self.samples_done = target
        self.truth_position = float(block.truth["position_true_deg"][0][-1])
        if self.bit_running and self.bit_start is not None and \
                self.samples_done >= self.bit_start + self.bit_command.size:
            self.bit_state = "DONE"

    def _commands(self, n: int) -> np.ndarray:
        """Position command for the next ``n`` plant samples: the FCC's, or the BIT's."""
        held = self.command_deg if self.enabled else 0.0
        commands = np.full(n, held)
        if self.bit_running and self.bit_start is not None:
            index = self.samples_done + np.arange(n) - self.bit_start
            inside = (index >= 0) & (index < self.bit_command.size)
            commands[inside] = self.bit_command[index[inside]]
        return commands

    def latest(self, name: str, count: int, step: int = 1) -> list[float]:
        """The newest ``count`` samples (every ``step``-th), oldest first, latched one sample
        period before now (the ICD's timing rule)."""
        series = self.history.get(name, np.zeros(1))
        series = series[:-1] if series.size > 1 else series
        picked = series[::-1][::step][:count][::-1]
        if picked.size < count:
            picked = np.concatenate([np.full(count - picked.size, picked[0] if picked.size
                                             else 0.0), picked])
        return [float(v) for v in picked]

    def _next(self, counter: str) -> int:
        self.counters[counter] = self.counters.get(counter, 0) + 1
        return self.counters[counter]

    # --- subaddress callbacks -----------------------------------------------------------------
    def receive_command(self, t_ns: int, data: Sequence[int], message: Message) -> None:
        self.run_to(t_ns)
        values = decode_data(self.icd, message, data, t_ns)
        self.command_deg = float(values["position_command"])
        self.enabled = bool(values["drive_enable"])

    def receive_bit_request(self, t_ns: int, data: Sequence[int], message: Message) -> None:
        """Start the stored BIT on a new ``INITIATED_BIT`` request (not while one runs)."""
        self.run_to(t_ns)
        values = decode_data(self.icd, message, data, t_ns)
        seq = int(values.get("bit_request_seq", 0))
        if values.get("bit_request") != "INITIATED_BIT" or seq == self.bit_seq:
            return
        self.bit_seq = seq
        if not self.bit_running:
            self.bit_start = self.samples_done
            self.bit_state = "RUNNING"
            self.bits_run += 1

    def fast_block(self, t_ns: int) -> list[int]:
        self.run_to(t_ns)
        values: dict[str, Any] = {icd_name: self.latest(plant_name, 4)
                                  for icd_name, plant_name in FAST_CHANNELS.items()}
        # The drive reports its own state: the Hall sector it commutates in, and its applied
        # PWM duty as the table carries it, sign-magnitude (direction bit + duty).
        values["commutation_sector"] = [round(v) for v in
                                        self.latest("commutation_sector", 4)]
        duty = self.latest("inverter_duty", 4)
        values["drive_direction"] = [int(v >= 0) for v in duty]
        values["pwm_duty"] = [min(1.0, abs(v)) for v in duty]
        values.update(fast_overrun=0, fast_adc_fault=0, fast_seq=self._next("fast"))
        return list(self.icd.encode("ema_fast_block", values, strict=False))

    def power_block(self, t_ns: int) -> list[int]:
        self.run_to(t_ns)
        values: dict[str, Any] = {icd_name: self.latest(plant_name, 4)
                                  for icd_name, plant_name in POWER_CHANNELS.items()}
        values["power_seq"] = self._next("power")
        return list(self.icd.encode("ema_power_block", values, strict=False))

    def slow_block(self, t_ns: int) -> list[int]:
        self.run_to(t_ns)
        step = max(1, round(self.rate_hz / 100.0))
        values: dict[str, Any] = {icd_name: self.latest(plant_name, 5, step)
                                  for icd_name, plant_name in SLOW_CHANNELS.items()}
        values["slow_seq"] = self._next("slow")
        return list(self.icd.encode("ema_slow_block", values, strict=False))

    def feedback(self, t_ns: int) -> list[int]:
        self.run_to(t_ns)
        position = self.latest("position_deg", 2)
        rate = (position[1] - position[0]) * self.rate_hz
        echo = self.command_deg
        if self.bit_running and self.bit_start is not None:
            index = min(max(self.samples_done - 1 - self.bit_start, 0), self.bit_command.size - 1)
            echo = float(self.bit_command[index])
        values = {"position_feedback": position[1], "surface_rate": rate, "ema_ready": 1,
                  "ema_fault": 0, "at_stop": int(abs(position[1]) > 29.5),
                  "mode_echo": "POSITION" if self.enabled or self.bit_running else "STANDBY",
                  "feedback_seq": self._next("feedback"), "command_echo": echo}
        return list(self.icd.encode("ema_position_feedback", values, strict=False))

    def bit_result(self, t_ns: int) -> list[int]:
        """The drive's own verdict is always a pass: diagnosing the motion is MAPR's job."""
        self.run_to(t_ns)
        values = {"bit_pass": 1, "smps_fault": 0, "inverter_fault": 0, "motor_fault": 0,
                  "position_sensor_fault": 0, "current_sensor_fault": 0, "overtemperature": 0,
                  "bit_state": self.bit_state, "bit_fault_code": 0}
        return list(self.icd.encode("ema_bit_result", values, strict=False))


def decode_data(icd: Icd, message: Message, data: Sequence[int], t_ns: int) -> dict[str, Any]:
    """The values in a message's data words, as a terminal that received them reads them."""
    record = MonitorRecord(t_ns=t_ns, bus="A", format=TransferFormat.BC_RT,
                           command=message.command, data=tuple(int(d) for d in data))
    decoded = icd.decode(record)
    return {} if decoded is None else decoded.as_dict()


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
    """The bus controller's data: the surface command from the flight, the BIT requests.

    ``bit_requests_s``: flight times at which the FCC asks the EMA for an initiated BIT, and
    ``bit_every_s`` a period at which it asks again after the last of them (None: never). Each
    request goes out in the first BIT request message (1 Hz) at or after its time, with a new
    sequence number.
    """

    def __init__(self, icd: Icd, profile: Profile, rate_limit_deg_s: float = 200.0,
                 bit_requests_s: Sequence[float] = (), bit_every_s: float | None = None) -> None:
        self.icd = icd
        self.profile = profile
        self.rate_limit = rate_limit_deg_s
        self.sequence = 0
        self.bit_requests_ns = sorted(round(t * 1e9) for t in bit_requests_s)
        self.bit_every_ns = None if bit_every_s is None else round(bit_every_s * 1e9)
        self.bit_sequence = 0

    def command(self, t_ns: int) -> list[int]:
        p = self.profile
        k = min(int(t_ns / 1e9 / _period(p)), p.n_samples - 1)
        self.sequence += 1
        return list(self.icd.encode("ema_position_command", {
            "position_command": float(p.command_deg[k]), "drive_enable": 1,
            "command_mode": "POSITION", "command_seq": self.sequence,
            "rate_limit": self.rate_limit}, strict=False))

    def bit_request(self, t_ns: int) -> list[int]:
        due = bool(self.bit_requests_ns) and self.bit_requests_ns[0] <= t_ns
        if due:
            last = self.bit_requests_ns[-1]
            self.bit_requests_ns = [t for t in self.bit_requests_ns if t > t_ns]
            if not self.bit_requests_ns and self.bit_every_ns:
                self.bit_requests_ns = [last + self.bit_every_ns * (1 + (t_ns - last) //
                                                                    self.bit_every_ns)]
            self.bit_sequence = (self.bit_sequence + 1) % 256
        return list(self.icd.encode("ema_bit_request", {
            "bit_request": "INITIATED_BIT" if due else "NONE",
            "bit_request_seq": self.bit_sequence}, strict=False))


class Aircraft:
    """The whole simulated aircraft for the loopback bus: its terminals and its schedule.

    >>> aircraft = Aircraft.build(profile, faults=FaultSet.of([...]))     # doctest: +SKIP
    >>> LoopbackMonitor(terminals=aircraft.terminals(), schedule=aircraft.schedule())
    """

    def __init__(self, icd: Icd, profile: Profile, params: ActuatorParams,
                 faults: FaultSet | None = None, seed: int = 0,
                 bit_requests_s: Sequence[float] = (), bit_every_s: float | None = None) -> None:
        self.icd = icd
        self.profile = profile
        self.adc = AirDataTerminal(icd, profile)
        self.fcc = FlightControlComputer(icd, profile, bit_requests_s=bit_requests_s,
                                         bit_every_s=bit_every_s)
        self.ema = EmaTerminal(icd, params, faults or FaultSet(), seed=seed,
                               dynamic_pressure=self._q)

    @classmethod
    def build(cls, icd: Icd, profile: Profile, *, actuator: str | None = None,
              faults: FaultSet | None = None, seed: int = 0,
              bit_requests_s: Sequence[float] = (),
              bit_every_s: float | None = None) -> Aircraft:
        params = load_actuator(actuator or default_actuator_path())
        return cls(icd, profile, params, faults, seed, bit_requests_s, bit_every_s)

    def _q(self, t_s: float) -> float:
        p = self.profile
        return float(p.dynamic_pressure_pa[min(int(t_s / _period(p)), p.n_samples - 1)])

    def terminals(self) -> list[RemoteTerminal]:
        ema_messages = {m.name: m for m in self.icd.messages if m.rt == 5}
        ema = RemoteTerminal(
            5, transmit={ema_messages["ema_fast_block"].subaddress: self.ema.fast_block,
                         ema_messages["ema_power_block"].subaddress: self.ema.power_block,
                         ema_messages["ema_slow_block"].subaddress: self.ema.slow_block,
                         ema_messages["ema_position_feedback"].subaddress: self.ema.feedback,
                         ema_messages["ema_bit_result"].subaddress: self.ema.bit_result},
            receive={ema_messages["ema_position_command"].subaddress:
                     lambda t, d: self.ema.receive_command(
                         t, d, ema_messages["ema_position_command"]),
                     ema_messages["ema_bit_request"].subaddress:
                     lambda t, d: self.ema.receive_bit_request(
                         t, d, ema_messages["ema_bit_request"]),
                     ema_messages["ema_air_data"].subaddress: lambda t, d: None})
        transmit = {self.icd.message("adc_air_data").subaddress: self.adc.air_data}
        source = self.icd.message("ema_air_data").source
        if source is not None:
            transmit[source[1]] = self.adc.air_data_to_ema
        return [ema, RemoteTerminal(6, transmit=transmit)]

    def schedule(self) -> Schedule:
        """The ICD's schedule as the flight control computer runs it."""
        if self.icd.schedule is None:
            raise ValueError(f"{self.icd.name}: the table has no schedule")
        data = {"ema_position_command": self.fcc.command, "ema_bit_request": self.fcc.bit_request}
        out = []
        for entry in self.icd.schedule.entries:
            m = self.icd.message(entry.message)
            source = m.source
            out.append(ScheduledMessage(
                m.rt, m.subaddress, m.transmit, m.word_count, every=entry.every,
                offset=entry.offset, data=data.get(m.name),
                rt2=None if source is None else source[0],
                sa2=None if source is None else source[1], name=m.name))
        return Schedule(tuple(out), frame_ns=round(self.icd.schedule.minor_frame_us * 1000))
