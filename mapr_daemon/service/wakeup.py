"""What wakes the daemon's main loop: signals (a self-pipe) and queued bus work (a doorbell).

The main loop sleeps in ``select()`` on both until there is something to do or its next timer
(STATUS, statistics, watchdog) is due, so it neither polls nor sleeps through a signal:

* :class:`SignalPipe` installs handlers for SIGTERM, SIGINT and SIGHUP and hands their
  numbers to ``signal.set_wakeup_fd``: the interpreter's C-level handler writes each signal's
  number into a non-blocking socket the moment it arrives, which makes ``select()`` return;
  :meth:`SignalPipe.received` reads them back in order. The Python-level handlers do nothing
  (the work happens in the loop, outside any handler), and replacing SIGINT's default means
  Ctrl-C stops the daemon like SIGTERM does instead of raising KeyboardInterrupt somewhere.
* :class:`Doorbell` is rung by the bus reader after it queues an item (or drops one), so new
  records are handled as soon as they come, not at the next poll.

``set_wakeup_fd`` works only in the main thread; :class:`SignalPipe` raises ValueError
elsewhere (as :func:`signal.signal` does).
"""

from __future__ import annotations

import contextlib
import signal
import socket
from collections.abc import Iterable
from types import FrameType

HANDLED = (signal.SIGTERM, signal.SIGINT, signal.SIGHUP)


def _ignore(signum: int, frame: FrameType | None) -> None:
    """The Python-level handler: nothing; the signal's number is already in the pipe."""


class SignalPipe:
    """Delivers ``signals`` through a self-pipe the main loop can ``select()`` on."""

    def __init__(self, signals: Iterable[signal.Signals] = HANDLED) -> None:
        self._read, self._write = socket.socketpair()
        for end in (self._read, self._write):
            end.setblocking(False)
        self._previous_fd = signal.set_wakeup_fd(self._write.fileno(),
                                                 warn_on_full_buffer=False)
        self._previous: dict[signal.Signals, object] = {}
        try:
            for sig in signals:
                self._previous[sig] = signal.signal(sig, _ignore)
        except BaseException:
            self.close()
            raise

    def fileno(self) -> int:
        return self._read.fileno()

    def received(self) -> list[signal.Signals]:
        """The signals that arrived since the last call, oldest first."""
        out: list[signal.Signals] = []
        while True:
            try:
                data = self._read.recv(256)
            except (BlockingIOError, InterruptedError):
                return out
            if not data:
                return out
            out += [signal.Signals(number) for number in data
                    if number in signal.valid_signals()]

    def close(self) -> None:
        """Restore the previous handlers and wakeup fd; idempotent."""
        for sig, handler in self._previous.items():
            signal.signal(sig, handler)  # type: ignore[arg-type]
        self._previous.clear()
        if self._read.fileno() != -1:
            signal.set_wakeup_fd(self._previous_fd)
        self._read.close()
        self._write.close()


class Doorbell:
    """A socket pair: any thread may :meth:`ring`; the main loop ``select()``\\ s on it and
    :meth:`clear`\\ s it before taking the work, so a ring is never lost."""

    def __init__(self) -> None:
        self._read, self._write = socket.socketpair()
        for end in (self._read, self._write):
            end.setblocking(False)

    def fileno(self) -> int:
        return self._read.fileno()

    def ring(self) -> None:
        """Wake the loop (never blocks: a full socket is already a pending ring)."""
        with contextlib.suppress(BlockingIOError, OSError):
            self._write.send(b"\x01")

    def clear(self) -> None:
        with contextlib.suppress(BlockingIOError, InterruptedError):
            while self._read.recv(4096):
                pass

    def close(self) -> None:
        self._read.close()
        self._write.close()
