"""One simulated EMA remote terminal on the loopback bus: its plant, its blocks, its BIT.

An aircraft carries several EMAs on one bus, each at its own RT address. They all speak the
same interface (the messages of the shipped aileron EMA, RT 5 of
``configs/icd/ema-testbed.yaml``); the table tells them apart by name: a terminal's messages
are named ``<terminal>_<role>`` (``ema_fast_block``, ``elevator_fast_block``) and each of
its parameters carries the shipped EMA's name (``phase_current_a``), or that name prefixed
with the terminal's (``elevator_phase_current_a``: a table's parameter names are unique).
:class:`TerminalNames` resolves both, so the terminal code is written once with the shipped
names.

The plant advances in lockstep with bus time: when the bus controller polls a block at time
t, the terminal first runs the plant up to t, then hands over the samples the ICD's timing
rule says it latched (the newest one plant period before t). The plant runs at the rate of
the terminal's fast block (the ICD's ``sample_rate_hz``).

Built-in test: as a real servo drive does, the EMA stores its BIT motion (the actuator's
``bit:`` section) and runs it itself when the flight control computer sends
``INITIATED_BIT`` with a new request sequence number: the profile's first sample is the
first plant sample after the request arrives, the FCC's position command is ignored until
the profile ends, and the BIT result reports ``RUNNING`` then ``DONE``.

What a block carries is computed by functions of arrays (:func:`pick` and the ``*_values``
functions), one row per poll: a live terminal calls them with one row at each poll, and
:meth:`EmaTerminal.answer_all` with every poll of a flight at once, the plant run once over the
whole flight (its noise does not depend on how it is chunked, so the words are the same).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

from drivers.backends.loopback import RemoteTerminal
from drivers.mil1553.record import MonitorRecord, TransferFormat
from mapr_daemon.arrays import FloatArray
from mapr_daemon.ema.batch import RunSpec
from mapr_daemon.ema.bit import bit_profile
from mapr_daemon.ema.faults import FaultSet
from mapr_daemon.ema.form import ModelForm
from mapr_daemon.ema.params import ActuatorParams
from mapr_daemon.ema.plant import EmaBatch
from mapr_daemon.icd import Icd, Message
from mapr_daemon.icd.encode_columns import IntArray, encode_columns

HISTORY_S = 0.2
"""Sensor history the EMA keeps for its blocks (the slow block spans 50 ms)."""

FAST_CHANNELS = {"dc_link_current": "dc_link_current_a", "phase_current_a": "phase_a_current_a",
                 "phase_current_b": "phase_b_current_a", "phase_current_c": "phase_c_current_a",
                 "dc_bus_voltage": "dc_bus_voltage_v", "surface_position": "position_deg"}
POWER_CHANNELS = {"smps_input_voltage": "smps_input_voltage_v",
                  "smps_input_current": "smps_input_current_a", "smps_ripple_rms": "ripple_rms_v"}
SLOW_CHANNELS = {"motor_temperature": "motor_temperature_c",
                 "power_stage_temperature": "stage_temperature_c"}
"""Shipped ICD parameter name -> plant channel, per sample block."""
SWITCH_SLOW_CHANNELS = {"smps_high_side_temperature": "smps_high_side_temperature_c",
                        "smps_low_side_temperature": "smps_low_side_temperature_c",
                        "inverter_a_high_temperature": "inverter_a_high_temperature_c"}
"""Optional slow-block channels (configs/icd/ema-testbed-switch-temperatures.yaml): the EMA
sends those its table's slow block has."""

TRANSMIT_ROLES = ("fast_block", "power_block", "slow_block", "position_feedback", "bit_result")
RECEIVE_ROLES = ("position_command", "bit_request")

Latest = Callable[[str, int, int], FloatArray]
"""``latest(channel, count, step)``: per poll (rows), the newest ``count`` samples of a plant
channel (every ``step``-th, oldest first) a block carries; see :func:`pick`."""


@dataclasses.dataclass(frozen=True)
class Poll:
    """One bus transaction the EMA takes part in: a role of :data:`TRANSMIT_ROLES` (it
    answers) or :data:`RECEIVE_ROLES` (it receives ``data``), at bus time ``t_ns`` as the
    loopback terminal hands it over."""

    role: str
    t_ns: int
    data: tuple[int, ...] = ()


def pick(series: FloatArray, first: int, done: IntArray, held: IntArray, count: int,
         step: int = 1) -> FloatArray:
    """``(len(done), count)``: for each poll, the samples a block carries when the plant has
    run ``done`` samples and the terminal holds the last ``held`` of them (its history): the
    newest ``count`` (every ``step``-th, oldest first) latched one sample period before the
    poll (the ICD's timing rule), the oldest repeated when the history is shorter, zeros when
    it is empty. ``series[i]`` is plant sample ``first + i``."""
    done = np.asarray(done, dtype=np.int64)
    held = np.asarray(held, dtype=np.int64)
    newest = np.where(held > 1, done - 2, done - 1)   # one sample back, but never none
    lowest = done - held
    back = step * np.arange(count - 1, -1, -1)
    index = newest[:, None] - back[None, :]
    oldest = newest - step * ((newest - lowest) // step)
    index = np.where(index >= lowest[:, None], index, oldest[:, None])
    if series.size == 0:
        return np.zeros((done.size, count))
    out: FloatArray = series[np.clip(index - first, 0, series.size - 1)]
    return np.where((held > 0)[:, None], out, 0.0)


def fast_values(latest: Latest, seq: IntArray) -> dict[str, Any]:
    """The fast block's values, one row per poll (``seq``: its sequence numbers)."""
    values: dict[str, Any] = {icd_name: latest(plant_name, 4, 1)
                              for icd_name, plant_name in FAST_CHANNELS.items()}
    # The drive reports its own state: the Hall sector it commutates in, and its applied
    # PWM duty as the table carries it, sign-magnitude (direction bit + duty).
    values["commutation_sector"] = np.round(latest("commutation_sector", 4, 1)).astype(int)
    duty = latest("inverter_duty", 4, 1)
    values["drive_direction"] = (duty >= 0).astype(int)
    values["pwm_duty"] = np.minimum(1.0, np.abs(duty))
    values.update(fast_overrun=0, fast_adc_fault=0, fast_seq=seq)
    return values


def power_values(latest: Latest, seq: IntArray) -> dict[str, Any]:
    values: dict[str, Any] = {icd_name: latest(plant_name, 4, 1)
                              for icd_name, plant_name in POWER_CHANNELS.items()}
    values["power_seq"] = seq
    return values


def slow_values(latest: Latest, seq: IntArray, rate_hz: float,
                optional: Sequence[str] = ()) -> dict[str, Any]:
    """Temperatures at 100 Hz from the plant's rate; ``optional``: the
    :data:`SWITCH_SLOW_CHANNELS` the table's slow block carries."""
    step = max(1, round(rate_hz / 100.0))
    values: dict[str, Any] = {icd_name: latest(plant_name, 5, step)
                              for icd_name, plant_name in SLOW_CHANNELS.items()}
    values.update({icd_name: latest(SWITCH_SLOW_CHANNELS[icd_name], 5, step)
                   for icd_name in optional})
    values["slow_seq"] = seq
    return values


def feedback_values(latest: Latest, seq: IntArray, rate_hz: float, echo: FloatArray,
                    mode: npt.NDArray[np.str_]) -> dict[str, Any]:
    """Position, rate (from the last two samples), the command echoed and the mode."""
    position = latest("position_deg", 2, 1)
    return {"position_feedback": position[:, 1],
            "surface_rate": (position[:, 1] - position[:, 0]) * rate_hz, "ema_ready": 1,
            "ema_fault": 0, "at_stop": (np.abs(position[:, 1]) > 29.5).astype(int),
            "mode_echo": mode, "feedback_seq": seq, "command_echo": echo}


def bit_result_values(state: npt.NDArray[np.str_]) -> dict[str, Any]:
    """The drive's own verdict is always a pass: diagnosing the motion is MAPR's job."""
    return {"bit_pass": 1, "smps_fault": 0, "inverter_fault": 0, "motor_fault": 0,
            "position_sensor_fault": 0, "current_sensor_fault": 0, "overtemperature": 0,
            "bit_state": state, "bit_fault_code": 0}


def _row(values: dict[str, Any]) -> dict[str, Any]:
    """One poll's values from one-row arrays, as the per-message encoder takes them."""
    return {k: v[0].tolist() if isinstance(v, np.ndarray) else v for k, v in values.items()}


class TerminalNames:
    """The ICD names of one EMA terminal's messages and parameters (see the module doc).

    Raises :class:`KeyError` naming what is missing when the RT has no terminal or lacks a
    message of the EMA interface.
    """

    def __init__(self, icd: Icd, rt: int) -> None:
        terminal = next((t for t in icd.terminals if t.address == rt), None)
        if terminal is None:
            raise KeyError(f"{icd.name}: no terminal at RT {rt}")
        self.rt = rt
        self.prefix = f"{terminal.name}_"
        self.messages: dict[str, Message] = {}
        self.parameters: set[str] = set()
        for m in icd.messages:
            if m.rt == rt and m.name.startswith(self.prefix):
                self.messages[m.name[len(self.prefix):]] = m
                self.parameters.update(p.name for p in m.all_parameters())
        missing = [r for r in (*TRANSMIT_ROLES, *RECEIVE_ROLES) if r not in self.messages]
        if missing:
            raise KeyError(f"{icd.name}: RT {rt} ({terminal.name}) has no message "
                           + ", ".join(self.prefix + r for r in missing))

    def param(self, shipped: str) -> str:
        """This terminal's name for the shipped EMA's parameter ``shipped``."""
        return shipped if shipped in self.parameters else self.prefix + shipped

    def shipped(self, name: str) -> str:
        """The shipped EMA's name for this terminal's parameter ``name``."""
        if name not in self.parameters or not name.startswith(self.prefix):
            return name
        bare = name[len(self.prefix):]
        return name if bare in self.parameters else bare

    def values(self, shipped: dict[str, Any]) -> dict[str, Any]:
        """A message's values keyed by this terminal's names."""
        return {self.param(k): v for k, v in shipped.items()}


def decode_data(icd: Icd, message: Message, data: Sequence[int], t_ns: int) -> dict[str, Any]:
    """The values in a message's data words, as a terminal that received them reads them."""
    record = MonitorRecord(t_ns=t_ns, bus="A", format=TransferFormat.BC_RT,
                           command=message.command, data=tuple(int(d) for d in data))
    decoded = icd.decode(record)
    return {} if decoded is None else decoded.as_dict()


class EmaTerminal:
    """An EMA remote terminal: receives commands and BIT requests, streams its sensors.

    ``params`` are the plant's parameters (a data sheet, or a built unit's own values);
    ``form`` its model form (:class:`~mapr_daemon.ema.form.ModelForm`: the laws and loads a
    data sheet does not carry; default the plant as the file describes it), and
    ``ambient_c`` / ``bus_v`` this flight's ambient temperature and mean aircraft-bus voltage
    (default: drawn by the plant from the file's flight-to-flight spread), as
    :class:`~mapr_daemon.ema.batch.RunSpec` takes them. With none of the three given, the
    plant is the one it always was, bit for bit.
    """

    def __init__(self, icd: Icd, params: ActuatorParams, faults: FaultSet, *, seed: int,
                 dynamic_pressure: Callable[[float], float], rt: int = 5,
                 form: ModelForm | None = None, ambient_c: float | None = None,
                 bus_v: float | None = None) -> None:
        self.icd = icd
        self.names = TerminalNames(icd, rt)
        slow = {p.name for p in self.names.messages["slow_block"].all_parameters()}
        self.slow_optional = tuple(k for k in SWITCH_SLOW_CHANNELS if self.names.param(k) in slow)
        """The optional channels this EMA's slow block carries (its switch temperatures)."""
        self.plant = EmaBatch([RunSpec(params, faults, seed=seed, ambient_c=ambient_c,
                                       bus_v=bus_v, form=form or ModelForm())], powered=True)
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
        self._planned: list[tuple[FloatArray, float]] | None = None
        """While :meth:`answer_all` walks a flight: the plant's chunks, not yet run."""

    @property
    def rt(self) -> int:
        return self.names.rt

    @property
    def bit_running(self) -> bool:
        return self.bit_state == "RUNNING"

    # --- the plant --------------------------------------------------------------------------
    def run_to(self, t_ns: int) -> None:
        """Advance the plant to bus time ``t_ns`` with the command it holds (while
        :meth:`answer_all` plans a flight, only note the commands)."""
        target = int(t_ns * self.rate_hz / 1e9)
        n = target - self.samples_done
        if n <= 0:
            return
        commands = self._commands(n)
        q = self.dynamic_pressure(self.samples_done / self.rate_hz)
        if self._planned is not None:
            self._planned.append((commands, q))
        else:
            self._advance(commands, q)
        self.samples_done = target
        if self.bit_running and self.bit_start is not None and \
                self.samples_done >= self.bit_start + self.bit_command.size:
            self.bit_state = "DONE"

    def _advance(self, commands: FloatArray, q: float) -> None:
        block = self.plant.advance(commands.size, command_deg=commands, dynamic_pressure_pa=q)
        keep = int(self.history_s * self.rate_hz)
        for name, values in block.channels.items():
            joined = np.concatenate([self.history.get(name, np.zeros(0)), values[0]])
            self.history[name] = joined[-keep:]
        self.truth_position = float(block.truth["position_true_deg"][0][-1])

    def _commands(self, n: int) -> np.ndarray:
        """Position command for the next ``n`` plant samples: the FCC's, or the BIT's."""
        held = self.command_deg if self.enabled else 0.0
        commands = np.full(n, held)
        if self.bit_running and self.bit_start is not None:
            index = self.samples_done + np.arange(n) - self.bit_start
            inside = (index >= 0) & (index < self.bit_command.size)
            commands[inside] = self.bit_command[index[inside]]
        return commands

    def latest(self, name: str, count: int, step: int = 1) -> FloatArray:
        """``(1, count)``: the newest ``count`` samples (every ``step``-th), oldest first,
        latched one sample period before now (the ICD's timing rule; :func:`pick`)."""
        series = self.history.get(name, np.zeros(0))
        return pick(series, self.samples_done - series.size,
                    np.array([self.samples_done]), np.array([series.size]), count, step)

    def _next(self, counter: str) -> int:
        self.counters[counter] = self.counters.get(counter, 0) + 1
        return self.counters[counter]

    def _encode(self, role: str, values: dict[str, Any]) -> list[int]:
        name = self.names.messages[role].name
        return list(self.icd.encode(name, self.names.values(values), strict=False))

    def _received(self, role: str, t_ns: int, data: Sequence[int]) -> dict[str, Any]:
        decoded = decode_data(self.icd, self.names.messages[role], data, t_ns)
        return {self.names.shipped(k): v for k, v in decoded.items()}

    # --- subaddress callbacks -----------------------------------------------------------------
    def receive_command(self, t_ns: int, data: Sequence[int]) -> None:
        self.run_to(t_ns)
        values = self._received("position_command", t_ns, data)
        self.command_deg = float(values["position_command"])
        self.enabled = bool(values["drive_enable"])

    def receive_bit_request(self, t_ns: int, data: Sequence[int]) -> None:
        """Start the stored BIT on a new ``INITIATED_BIT`` request (not while one runs)."""
        self.run_to(t_ns)
        values = self._received("bit_request", t_ns, data)
        seq = int(values.get("bit_request_seq", 0))
        if values.get("bit_request") != "INITIATED_BIT" or seq == self.bit_seq:
            return
        self.bit_seq = seq
        if not self.bit_running:
            self.bit_start = self.samples_done
            self.bit_state = "RUNNING"
            self.bits_run += 1

    def _echo(self) -> float:
        """The command the feedback echoes: the FCC's, or the running BIT's."""
        if self.bit_running and self.bit_start is not None:
            index = min(max(self.samples_done - 1 - self.bit_start, 0), self.bit_command.size - 1)
            return float(self.bit_command[index])
        return self.command_deg

    def _mode(self) -> str:
        return "POSITION" if self.enabled or self.bit_running else "STANDBY"

    def fast_block(self, t_ns: int) -> list[int]:
        self.run_to(t_ns)
        return self._encode("fast_block", _row(fast_values(
            self.latest, np.array([self._next("fast")]))))

    def power_block(self, t_ns: int) -> list[int]:
        self.run_to(t_ns)
        return self._encode("power_block", _row(power_values(
            self.latest, np.array([self._next("power")]))))

    def slow_block(self, t_ns: int) -> list[int]:
        self.run_to(t_ns)
        return self._encode("slow_block", _row(slow_values(
            self.latest, np.array([self._next("slow")]), self.rate_hz, self.slow_optional)))

    def feedback(self, t_ns: int) -> list[int]:
        self.run_to(t_ns)
        return self._encode("position_feedback", _row(feedback_values(
            self.latest, np.array([self._next("feedback")]), self.rate_hz,
            np.array([self._echo()]), np.array([self._mode()]))))

    def bit_result(self, t_ns: int) -> list[int]:
        self.run_to(t_ns)
        return self._encode("bit_result", _row(bit_result_values(np.array([self.bit_state]))))

    # --- a whole flight at once -------------------------------------------------------------
    def answer_all(self, polls: Sequence[Poll]) -> dict[str, IntArray]:
        """Every answer of a flight's ``polls`` (in bus order, from a fresh terminal): per
        transmit role, the ``(k, word_count)`` data words of its ``k`` polls in order, the
        same words the terminal gives poll by poll (tests/testbed/test_flight_template.py).

        The polls are walked once without the plant, noting each command it would be given
        and each answer's state (samples done, sequence number, echo, mode, BIT state);
        then the plant runs once over the whole flight and every block of a role is computed
        and encoded as columns (:func:`~mapr_daemon.icd.encode_columns.encode_columns`)."""
        self._planned = []
        answered: dict[str, list[tuple[int, int, float, str, str]]] = {
            role: [] for role in TRANSMIT_ROLES}
        receive = {"position_command": self.receive_command,
                   "bit_request": self.receive_bit_request}
        try:
            for poll in polls:
                if poll.role in receive:
                    receive[poll.role](poll.t_ns, poll.data)
                    continue
                self.run_to(poll.t_ns)
                answered[poll.role].append((self.samples_done, self._next(poll.role),
                                            self._echo(), self._mode(), self.bit_state))
            planned = self._planned
        finally:
            self._planned = None
        series = self._run_planned(planned)
        keep = int(self.history_s * self.rate_hz)
        out: dict[str, IntArray] = {}
        for role, rows in answered.items():
            if not rows:
                continue
            done = np.array([r[0] for r in rows], dtype=np.int64)
            seq = np.array([r[1] for r in rows], dtype=np.int64)
            held = np.minimum(done, keep)

            def latest(name: str, count: int, step: int, done: IntArray = done,
                       held: IntArray = held) -> FloatArray:
                return pick(series.get(name, np.zeros(0)), 0, done, held, count, step)

            values = self._values(role, latest, seq, rows)
            message = self.names.messages[role]
            out[role] = encode_columns(message, self.names.values(values), len(rows))
        return out

    def _values(self, role: str, latest: Latest, seq: IntArray,
                rows: list[tuple[int, int, float, str, str]]) -> dict[str, Any]:
        """A transmit role's values over the polls ``rows`` noted by :meth:`answer_all`."""
        if role == "fast_block":
            return fast_values(latest, seq)
        if role == "power_block":
            return power_values(latest, seq)
        if role == "slow_block":
            return slow_values(latest, seq, self.rate_hz, self.slow_optional)
        if role == "position_feedback":
            return feedback_values(latest, seq, self.rate_hz, np.array([r[2] for r in rows]),
                                   np.array([r[3] for r in rows]))
        return bit_result_values(np.array([r[4] for r in rows]))

    def _run_planned(self, planned: list[tuple[FloatArray, float]]) -> dict[str, FloatArray]:
        """The plant over every planned chunk in one call: each channel's whole series."""
        if not planned:
            return {}
        commands = np.concatenate([c for c, _ in planned])
        q = np.concatenate([np.full(c.size, q) for c, q in planned])
        block = self.plant.advance(commands.size, command_deg=commands[None, :],
                                   dynamic_pressure_pa=q[None, :])
        self.truth_position = float(block.truth["position_true_deg"][0][-1])
        return {name: values[0] for name, values in block.channels.items()}

    def terminal(self) -> RemoteTerminal:
        """This EMA as a loopback remote terminal (any other message it receives, such as
        RT-RT air data, is accepted and ignored)."""
        m = self.names.messages
        transmit = {m["fast_block"].subaddress: self.fast_block,
                    m["power_block"].subaddress: self.power_block,
                    m["slow_block"].subaddress: self.slow_block,
                    m["position_feedback"].subaddress: self.feedback,
                    m["bit_result"].subaddress: self.bit_result}
        receive: dict[int, Callable[[int, Sequence[int]], None]] = {
            msg.subaddress: _ignore for msg in m.values() if not msg.transmit}
        receive[m["position_command"].subaddress] = self.receive_command
        receive[m["bit_request"].subaddress] = self.receive_bit_request
        return RemoteTerminal(self.rt, transmit=transmit, receive=receive)


def _ignore(t_ns: int, data: Sequence[int]) -> None:
    """A received message the EMA model does not use."""
