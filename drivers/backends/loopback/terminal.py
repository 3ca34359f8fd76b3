"""A remote terminal of the loopback bus, answering commands as MIL-STD-1553B says it must.

The bus controller hands a terminal each valid command word addressed to it (its own address,
or 31 for broadcast) with the data words it received; the terminal updates its state and
returns its :class:`Reply` (status word and data words) or ``None`` when it stays silent.
Where the reply goes on the bus, and when, is the controller's business.

Subaddress data comes from callbacks, so any model can play the terminal::

    rt = RemoteTerminal(5, transmit={1: lambda t_ns: [1, 2, 3]},
                        receive={2: lambda t_ns, data: print(data)})

Behaviour (section 4.4 of the standard; choices where it leaves room are marked *choice*):

- Status word: address, then message error, instrumentation, service request, broadcast
  received, busy, subsystem flag, dynamic bus control acceptance, terminal flag. The flags
  ``instrumentation``, ``service_request``, ``busy``, ``subsystem_flag`` and ``terminal_flag``
  are attributes a model sets; message error, broadcast received and DBCA are the terminal's.
- Reset: every valid command except mode codes 2 (transmit status word) and 18 (transmit last
  command) first clears message error, broadcast received and DBCA, so a broadcast's
  broadcast-received bit (or the message error of a message the terminal refused to answer)
  is seen by the BC through mode code 2 or 18, as the standard intends.
- A receive command with an invalid data word or the wrong number of data words sets message
  error and sends no status at all.
- Illegal commands (a mode code with the wrong T/R bit, a non-broadcast mode code sent to
  address 31, a reserved mode code, a broadcast transmit command, and with
  ``strict_subaddresses`` a subaddress without a callback): message error set, status word
  only, no data (*choice*: the standard's optional illegal-command handling, which is what a
  monitor can check); no status for broadcast ones.
- Busy (*choice*: applies to subaddress traffic; mode codes are answered): a transmit command
  gets the status word only, a receive command's data is discarded.
- Mode codes: 0 answers status with DBCA set only if ``accepts_bus_control``; 1 and 17 call
  ``on_sync``; 2 returns the status word unchanged; 3 counts a self test; 4/5 shut down and
  restore the transmitter on the *other* bus; 6/7 inhibit and restore the terminal flag; 8
  resets the terminal (transmitters, inhibit, latched bits); 16 sends the vector word; 18 the
  last command word before it; 19 the BIT word; 20/21 record the selected transmitter given
  in the data word (*choice*: in a dual-redundant system codes 4/5 govern buses A and B, so
  20/21 do not silence them).
- A terminal whose transmitter on a bus is shut down still hears commands there but never
  answers on it.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

from drivers.mil1553.modecodes import MODE_CODES, direction_legal
from drivers.mil1553.words import BROADCAST_RT, MODE_SUBADDRESSES

TransmitCallback = Callable[[int], Sequence[int]]
"""``callable(t_ns) -> data words`` for a transmit subaddress (exactly the word count)."""
ReceiveCallback = Callable[[int, tuple[int, ...]], None]
"""``callable(t_ns, data)`` for a receive subaddress."""
WordSource = int | Callable[[int], int]
"""A fixed word, or ``callable(t_ns) -> word`` (vector word, BIT word)."""
SyncCallback = Callable[[int, int | None], None]
"""``callable(t_ns, data word or None)`` for mode codes 1 and 17."""

ME, INSTRUMENTATION, SERVICE_REQUEST = 0x0400, 0x0200, 0x0100
BROADCAST_RECEIVED, BUSY, SUBSYSTEM_FLAG, DBCA, TERMINAL_FLAG = 0x10, 0x08, 0x04, 0x02, 0x01


@dataclass(frozen=True, slots=True)
class Reply:
    """What a terminal puts on the bus: its status word, then its data words."""

    status: int
    data: tuple[int, ...] = ()


def _word(source: WordSource, t_ns: int) -> int:
    return (source(t_ns) if callable(source) else source) & 0xFFFF


def expected_receive_words(command: int) -> int:
    """Data words the BC sends after ``command`` (the terminal's receive count)."""
    transmit, sa, count = command >> 10 & 1, command >> 5 & 31, command & 31
    if sa in MODE_SUBADDRESSES:
        return 1 if MODE_CODES[count].has_data and not transmit else 0
    return 0 if transmit else (count or 32)


class RemoteTerminal:
    """One remote terminal (address 0-30) with its status-word state and mode codes."""

    def __init__(self, address: int, *,
                 transmit: Mapping[int, TransmitCallback] | None = None,
                 receive: Mapping[int, ReceiveCallback] | None = None,
                 vector: WordSource = 0, bit_word: WordSource = 0,
                 on_sync: SyncCallback | None = None,
                 accepts_bus_control: bool = False, strict_subaddresses: bool = False,
                 response_gap_ns: int | None = None) -> None:
        if not 0 <= address <= 30:
            raise ValueError(f"RT address {address} is outside 0-30 (31 is broadcast)")
        for sa in [*(transmit or {}), *(receive or {})]:
            if not 1 <= sa <= 30:
                raise ValueError(f"subaddress {sa} is outside 1-30")
        self.address = address
        self.transmit = dict(transmit or {})
        self.receive = dict(receive or {})
        self.vector = vector
        self.bit_word = bit_word
        self.on_sync = on_sync
        self.accepts_bus_control = accepts_bus_control
        self.strict_subaddresses = strict_subaddresses
        self.response_gap_ns = response_gap_ns
        """This terminal's response gap (mid-crossing to mid-crossing); None: the bus's."""
        # Flags a model sets.
        self.busy = False
        self.service_request = False
        self.subsystem_flag = False
        self.terminal_flag = False
        self.instrumentation = False
        # The terminal's own state.
        self.message_error = False
        self.broadcast_received = False
        self.dynamic_bus_control = False
        self.terminal_flag_inhibited = False
        self.shutdown: set[int] = set()
        """Buses (0 = A, 1 = B) whose transmitter is shut down."""
        self.selected_shutdown: set[int] = set()
        self.last_command: int | None = None
        self.self_tests = 0
        self.resets = 0

    # --- status word ---------------------------------------------------------------------
    def status_word(self) -> int:
        """The status word as it stands now."""
        bits = self.address << 11
        for on, bit in ((self.message_error, ME), (self.instrumentation, INSTRUMENTATION),
                        (self.service_request, SERVICE_REQUEST),
                        (self.broadcast_received, BROADCAST_RECEIVED), (self.busy, BUSY),
                        (self.subsystem_flag, SUBSYSTEM_FLAG), (self.dynamic_bus_control, DBCA),
                        (self.terminal_flag and not self.terminal_flag_inhibited,
                         TERMINAL_FLAG)):
            if on:
                bits |= bit
        return bits

    def _reset_status(self) -> None:
        self.message_error = False
        self.broadcast_received = False
        self.dynamic_bus_control = False

    def transmits_on(self, bus: int) -> bool:
        return bus not in self.shutdown

    def is_illegal(self, command: int) -> bool:
        """Whether this terminal treats ``command`` as illegal (see the module doc)."""
        rt, transmit, sa, count = command >> 11, bool(command >> 10 & 1), command >> 5 & 31, \
            command & 31
        broadcast = rt == BROADCAST_RT
        if sa in MODE_SUBADDRESSES:
            row = MODE_CODES[count]
            return row.reserved or not direction_legal(count, transmit) or \
                (broadcast and not row.broadcast_allowed)
        if broadcast and transmit:
            return True
        table: Mapping[int, object] = self.transmit if transmit else self.receive
        return self.strict_subaddresses and sa not in table

    # --- a command -----------------------------------------------------------------------
    def command(self, command: int, data: Sequence[int] = (), *, data_valid: bool = True,
                bus: int = 0, t_ns: int = 0) -> Reply | None:
        """Handle a valid command word addressed to this terminal (or broadcast).

        ``data`` are the data words the terminal received after it (for a receive command),
        ``data_valid`` False when any of them was invalid (parity, Manchester, bit count, sync).
        Returns the reply, or None when the terminal stays silent.
        """
        rt, transmit, sa, count = command >> 11, bool(command >> 10 & 1), command >> 5 & 31, \
            command & 31
        if rt not in (self.address, BROADCAST_RT):
            raise ValueError(f"command {command:#06x} is not for RT {self.address}")
        broadcast = rt == BROADCAST_RT
        mode = sa in MODE_SUBADDRESSES
        illegal = self.is_illegal(command)
        if not data_valid or len(data) != expected_receive_words(command):
            # An invalid message: message error, and no status word at all.
            self._reset_status()
            self.last_command = command
            self.message_error = True
            return None
        if mode and count in (2, 18) and not illegal:
            # These two leave the status word alone.
            words: tuple[int, ...] = ()
            if count == 18:
                words = (self.last_command or 0,)
            else:
                self.last_command = command
            return self._answer(Reply(self.status_word(), words), bus, broadcast)
        self._reset_status()
        self.last_command = command
        if broadcast:
            self.broadcast_received = True
        if illegal:
            self.message_error = True
            return self._answer(Reply(self.status_word()), bus, broadcast)
        if mode:
            reply_data = self._mode(count, tuple(data), bus, t_ns)
        elif self.busy:
            reply_data = ()  # busy: status only; received data is discarded
        elif transmit:
            reply_data = self._transmit_data(sa, count or 32, t_ns)
        else:
            callback = self.receive.get(sa)
            if callback is not None:
                callback(t_ns, tuple(int(d) & 0xFFFF for d in data))
            reply_data = ()
        return self._answer(Reply(self.status_word(), reply_data), bus, broadcast)

    def _answer(self, reply: Reply, bus: int, broadcast: bool) -> Reply | None:
        if broadcast or not self.transmits_on(bus):
            return None
        return reply

    def _transmit_data(self, sa: int, words: int, t_ns: int) -> tuple[int, ...]:
        callback = self.transmit.get(sa)
        if callback is None:
            return (0,) * words
        data = tuple(int(d) & 0xFFFF for d in callback(t_ns))
        if len(data) != words:
            raise ValueError(f"RT {self.address} SA {sa}: the transmit callback gave "
                             f"{len(data)} words for a {words}-word command")
        return data

    def _mode(self, code: int, data: tuple[int, ...], bus: int, t_ns: int) -> tuple[int, ...]:
        """Carry out a legal mode code; returns the data word(s) to send."""
        if code == 0:
            self.dynamic_bus_control = self.accepts_bus_control
        elif code in (1, 17):
            if self.on_sync is not None:
                self.on_sync(t_ns, data[0] if data else None)
        elif code == 3:
            self.self_tests += 1
        elif code == 4:
            self.shutdown.add(1 - bus)
        elif code == 5:
            self.shutdown.discard(1 - bus)
        elif code == 6:
            self.terminal_flag_inhibited = True
        elif code == 7:
            self.terminal_flag_inhibited = False
        elif code == 8:
            self.shutdown.clear()
            self.selected_shutdown.clear()
            self.terminal_flag_inhibited = False
            self.resets += 1
        elif code == 16:
            return (_word(self.vector, t_ns),)
        elif code == 19:
            return (_word(self.bit_word, t_ns),)
        elif code == 20:
            self.selected_shutdown.add(data[0])
        elif code == 21:
            self.selected_shutdown.discard(data[0])
        return ()
