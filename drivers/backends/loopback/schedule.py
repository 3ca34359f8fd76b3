"""The bus controller's schedule: minor frames and the messages due in each.

A :class:`Schedule` is a minor-frame period and a list of :class:`ScheduledMessage`; a message
runs in frame ``k`` when ``k % every == offset % every``. The helpers build the messages of
each transfer format without hand-packing command words::

    Schedule(frame_ns=2_000_000, messages=(
        bc_rt(5, 1, 3, data=[0x1234, 0, 7]),       # BC -> RT 5 SA 1, 3 words
        rt_bc(5, 10, 29),                          # RT 5 SA 10 -> BC, 29 words
        rt_rt(6, 2, 5, 3, 4, every=5, offset=1),   # RT 5 SA 3 -> RT 6 SA 2, every 5th frame
        mode(5, 2, every=10),                      # transmit status word
        mode(31, 1),                               # broadcast synchronize
    ))

Address 31 makes a message broadcast. :func:`schedule_from_slots` builds a schedule from plain
rows (an ICD's message table and rates, without importing the ICD package).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass

from drivers.backends.loopback.terminal import expected_receive_words
from drivers.mil1553.modecodes import MODE_CODES
from drivers.mil1553.words import CommandWord

DataSource = Sequence[int] | Callable[[int], Sequence[int]]
"""The BC's data for a receive command: fixed words, or ``callable(t_ns) -> words``."""


@dataclass(frozen=True, slots=True)
class ScheduledMessage:
    """One message of the schedule.

    ``rt``/``sa``/``transmit``/``count`` make the (first) command word; ``count`` is the word
    count (1-32) or, for subaddress 0 or 31, the mode code. An RT-RT transfer gives the
    receiving terminal as ``rt``/``sa`` (``transmit`` False) and the transmitting one as
    ``rt2``/``sa2``. ``data`` is the BC's data for receive commands (default: a counter
    pattern). ``bus`` is where the BC sends it first (0 = A, 1 = B).
    """

    rt: int
    sa: int
    transmit: bool
    count: int
    rt2: int | None = None
    sa2: int | None = None
    every: int = 1
    offset: int = 0
    data: DataSource | None = None
    bus: int = 0
    name: str = ""

    def __post_init__(self) -> None:
        if self.every < 1:
            raise ValueError(f"every={self.every}: must be at least 1")
        if self.bus not in (0, 1):
            raise ValueError(f"bus={self.bus}: must be 0 (A) or 1 (B)")
        if not self.is_mode and not 1 <= self.count <= 32:
            raise ValueError(f"word count {self.count} is outside 1-32")
        if self.rt2 is not None and (self.transmit or self.sa2 is None):
            raise ValueError("an RT-RT message needs transmit=False and sa2")
        self.commands()  # validates the fields

    @property
    def is_mode(self) -> bool:
        return self.sa in (0, 31)

    def commands(self) -> tuple[int, int | None]:
        """The command word(s): (first, transmit command of an RT-RT transfer or None)."""
        first = CommandWord(self.rt, self.transmit, self.sa, self.count % 32).value
        if self.rt2 is None or self.sa2 is None:
            return first, None
        return first, CommandWord(self.rt2, True, self.sa2, self.count % 32).value

    def bc_data(self, t_ns: int, sequence: int) -> list[int]:
        """The data words the BC sends (empty for transmit and mode codes without data)."""
        wanted = expected_receive_words(self.commands()[0]) if self.rt2 is None else 0
        if wanted == 0:
            return []
        if self.data is None:
            return [(sequence * 32 + i) & 0xFFFF for i in range(wanted)]
        words = list(self.data(t_ns) if callable(self.data) else self.data)
        if len(words) != wanted:
            raise ValueError(f"{self.label}: {len(words)} data words for a {wanted}-word "
                             "command")
        return [int(w) & 0xFFFF for w in words]

    def due(self, frame: int) -> bool:
        return frame % self.every == self.offset % self.every

    @property
    def label(self) -> str:
        if self.name:
            return self.name
        cmd, cmd2 = self.commands()
        text = str(CommandWord.from_value(cmd))
        return text if cmd2 is None else f"{text} <- {CommandWord.from_value(cmd2)}"


def bc_rt(rt: int, sa: int, wc: int, *, data: DataSource | None = None, every: int = 1,
          offset: int = 0, bus: int = 0, name: str = "") -> ScheduledMessage:
    """BC -> RT (rt 31: broadcast) with ``wc`` data words."""
    return ScheduledMessage(rt, sa, False, wc, data=data, every=every, offset=offset, bus=bus,
                            name=name)


def rt_bc(rt: int, sa: int, wc: int, *, every: int = 1, offset: int = 0, bus: int = 0,
          name: str = "") -> ScheduledMessage:
    """RT -> BC with ``wc`` data words."""
    return ScheduledMessage(rt, sa, True, wc, every=every, offset=offset, bus=bus, name=name)


def rt_rt(rx_rt: int, rx_sa: int, tx_rt: int, tx_sa: int, wc: int, *, every: int = 1,
          offset: int = 0, bus: int = 0, name: str = "") -> ScheduledMessage:
    """RT ``tx_rt`` -> RT ``rx_rt`` (31: broadcast) with ``wc`` data words."""
    return ScheduledMessage(rx_rt, rx_sa, False, wc, rt2=tx_rt, sa2=tx_sa, every=every,
                            offset=offset, bus=bus, name=name)


def mode(rt: int, code: int, *, data: DataSource | None = None, transmit: bool | None = None,
         sa: int = 31, every: int = 1, offset: int = 0, bus: int = 0, name: str = ""
         ) -> ScheduledMessage:
    """A mode command; the T/R bit defaults to the table's legal one (give ``transmit`` to send
    an illegal one)."""
    tr = MODE_CODES[code].transmit if transmit is None else transmit
    return ScheduledMessage(rt, sa, tr, code, data=data, every=every, offset=offset, bus=bus,
                            name=name)


@dataclass(frozen=True, slots=True)
class Schedule:
    """Minor frames of ``frame_ns`` and the messages due in each."""

    messages: tuple[ScheduledMessage, ...]
    frame_ns: int = 2_000_000

    def __post_init__(self) -> None:
        if self.frame_ns < 100_000:
            raise ValueError(f"minor frame {self.frame_ns} ns is shorter than 100 µs")

    def frame(self, k: int) -> list[ScheduledMessage]:
        """The messages of minor frame ``k``, in schedule order."""
        return [m for m in self.messages if m.due(k)]


def schedule_from_slots(frame_us: float, rows: Iterable[Sequence[int]]) -> Schedule:
    """A schedule from plain rows ``(rt, transmit, sa, wc, every, offset)``, e.g. an ICD's
    messages and rates (``icd.schedule`` and ``icd.lookup`` give them)."""
    messages = tuple(ScheduledMessage(int(rt), int(sa), bool(tx), int(wc), every=int(every),
                                      offset=int(offset))
                     for rt, tx, sa, wc, every, offset in rows)
    return Schedule(messages, frame_ns=round(frame_us * 1000))


def _ramp(step: int, words: int) -> Callable[[int], list[int]]:
    """Data that changes with time, so a live dump shows it moving."""
    return lambda t_ns: [(t_ns // 1000 * step + i) & 0xFFFF for i in range(words)]


def default_schedule() -> Schedule:
    """Traffic in all ten transfer formats at a few rates (a 2 ms minor frame), for
    ``open_monitor("loopback")`` with no schedule given."""
    return Schedule(frame_ns=2_000_000, messages=(
        rt_bc(5, 10, 29, name="ema fast block"),
        bc_rt(5, 1, 3, data=_ramp(7, 3), every=5, name="ema position command"),
        rt_bc(5, 2, 4, every=5, offset=1, name="ema position feedback"),
        rt_bc(6, 1, 8, every=10, offset=2, name="air data"),
        rt_rt(5, 3, 6, 1, 8, every=10, offset=3, name="air data to ema"),
        mode(5, 2, every=25, offset=4),
        mode(5, 19, every=50, offset=5),
        mode(6, 17, data=[0x0001], every=50, offset=6),
        bc_rt(31, 4, 2, every=25, offset=7, name="broadcast time"),
        rt_rt(31, 5, 6, 2, 2, every=50, offset=8, name="broadcast air data"),
        mode(31, 1, every=50, offset=9),
        mode(31, 17, data=[0x00A5], every=50, offset=10),
    ))


def default_terminals() -> list[tuple[int, dict[int, Callable[[int], list[int]]]]]:
    """The terminals the default schedule talks to: (address, transmit callbacks)."""
    return [
        (5, {10: _ramp(1, 29), 2: _ramp(3, 4)}),
        (6, {1: _ramp(5, 8), 2: _ramp(11, 2)}),
    ]
