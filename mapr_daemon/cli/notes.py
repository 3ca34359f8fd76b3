"""Warnings of one ``mapr`` command on stderr: named, collapsed, silenced by ``-q``.

Every warning a subcommand gives (a damaged Chapter 10 packet, a skipped recording) reads
``mapr COMMAND: ...``, whether it is written with :func:`warn` or logged with
:mod:`logging` (``main`` installs :class:`NotesHandler` on the root logger). Warnings alike
(the same text once numbers are blanked out: the same problem at another file offset) are
printed :data:`SHOWN_ALIKE` times, then counted, and the count is printed when the command
ends: ``mapr decode: f.c10: packet at 4096: bad checksum (and 12 more like it)``. ``-q`` /
``--quiet`` silences warnings; errors (which end the command) are always printed.

Light on purpose (standard library only): imported to run any subcommand.
"""

from __future__ import annotations

import logging
import re
import sys
from typing import TextIO

SHOWN_ALIKE = 3
"""Warnings alike printed before the rest are only counted."""
_NUMBERS = re.compile(r"\d+")


class Notes:
    """One command's warnings: prefix ``mapr COMMAND:``, alike ones collapsed."""

    def __init__(self, command: str, *, quiet: bool = False, stream: TextIO | None = None
                 ) -> None:
        self.prefix = f"mapr {command}" if command else "mapr"
        self.quiet = quiet
        self.stream = stream
        self._alike: dict[str, int] = {}
        self._last: dict[str, str] = {}

    def warn(self, text: str) -> None:
        """Print ``text`` as a warning of this command, unless quiet or one of too many
        alike."""
        shape = _NUMBERS.sub("#", text)
        seen = self._alike.get(shape, 0) + 1
        self._alike[shape] = seen
        self._last[shape] = text
        if self.quiet or seen > SHOWN_ALIKE:
            return
        out = self.stream or sys.stderr
        out.write(f"{self.prefix}: {text}\n")

    def finish(self) -> None:
        """Say how many warnings alike were left out (each kind once)."""
        if self.quiet:
            return
        out = self.stream or sys.stderr
        for shape, seen in self._alike.items():
            if seen > SHOWN_ALIKE:
                more = seen - SHOWN_ALIKE
                out.write(f"{self.prefix}: {self._last[shape]} (and {more} more like it)\n")
        self._alike.clear()


class NotesHandler(logging.Handler):
    """Logged warnings of a subcommand, through its :class:`Notes`."""

    def __init__(self, notes: Notes) -> None:
        super().__init__(logging.WARNING)
        self.notes = notes

    def emit(self, record: logging.LogRecord) -> None:
        self.notes.warn(record.getMessage())


current = Notes("")
"""The running command's notes (set by :func:`mapr_daemon.cli.main.main`)."""


def warn(text: str) -> None:
    """A warning of the running command (``mapr COMMAND: text`` on stderr)."""
    current.warn(text)
