"""The loopback 1553 bus: a software bus controller and remote terminals, with a monitor tap.

It plays the aircraft in tests and demos (``open_monitor("loopback")``), and is the reference
every other backend is checked against (``tests/backends/backtoback.py``). docs/loopback.md
walks through it; in short::

    from drivers.backends.loopback import (Injection, LoopbackMonitor, RemoteTerminal,
                                           Schedule, bc_rt, mode, rt_bc, rt_rt)

    ema = RemoteTerminal(5, transmit={10: lambda t_ns: [0] * 29},
                         receive={1: lambda t_ns, data: None})
    schedule = Schedule(frame_ns=2_000_000, messages=(rt_bc(5, 10, 29), bc_rt(5, 1, 3),
                                                      mode(5, 2, every=10)))
    with LoopbackMonitor(terminals=[ema], schedule=schedule, frames=50,
                         injections=[Injection("parity", rt=5, sa=10)]) as monitor:
        for record in monitor:
            print(record.to_json())

Modules: :mod:`.terminal` (a remote terminal per the standard), :mod:`.schedule` (minor
frames, message helpers, the default traffic), :mod:`.injection` (error injection),
:mod:`.controller` (the bus controller and word timing), :mod:`.line` (words to samples or
word batches), :mod:`.backend` (the :class:`LoopbackMonitor` backend).
"""

from drivers.backends.loopback.backend import LoopbackMonitor
from drivers.backends.loopback.controller import BusController, SentMessage, Traffic
from drivers.backends.loopback.injection import (
    EXPECTED_ERRORS,
    INJECTION_KINDS,
    Injection,
    Injector,
)
from drivers.backends.loopback.schedule import (
    Schedule,
    ScheduledMessage,
    bc_rt,
    default_schedule,
    default_terminals,
    mode,
    rt_bc,
    rt_rt,
    schedule_from_slots,
)
from drivers.backends.loopback.terminal import RemoteTerminal, Reply

__all__ = [
    "EXPECTED_ERRORS", "INJECTION_KINDS", "BusController", "Injection", "Injector",
    "LoopbackMonitor", "RemoteTerminal", "Reply", "Schedule", "ScheduledMessage",
    "SentMessage", "Traffic", "bc_rt", "default_schedule", "default_terminals", "mode",
    "rt_bc", "rt_rt", "schedule_from_slots",
]
