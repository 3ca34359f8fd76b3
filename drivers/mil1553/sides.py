"""What ``--rt``, ``--tr`` and ``--sa`` select: one terminal's side of a message.

Every message the bus carries names one or two terminals, each by a command word: a BC-RT
transfer its receiving terminal (``R``), an RT-BC transfer its transmitting one (``T``), a
mode code its terminal, and an RT-RT transfer two of them, the receive command's terminal
(``R``) and the transmit command's (``T``), each with its own subaddress. A *side* is one
command word's (terminal, T/R, subaddress); a filter on terminal, direction and subaddress
matches a message when **one of its sides matches all three at once**.

So ``--rt 2 --tr T`` keeps every message in which RT 2 transmits, RT-RT transfers included
(and ``--rt 2 --tr R`` no longer keeps an RT-RT transfer in which RT 2 only transmits);
``--rt 5 --sa 2`` keeps a message in which RT 5's own subaddress is 2, never one in which RT 5
receives from subaddress 2 of another terminal. This is also how the per-RT/SA statistics
count (:func:`drivers.rtstats.key_of_command`: an RT-RT transfer under both of its command
words), so ``mapr decode --rt 2 --tr T`` prints as many messages as ``--stats`` lists under
``RT02 T``.

One definition, used by :class:`drivers.monitor.MonitorFilter` (records), ``mapr decode``'s
filter (records and Chapter 10 column batches, :func:`sides_mask`) and the statistics views.
"""

from __future__ import annotations

from collections.abc import Collection

import numpy as np
import numpy.typing as npt

Mask = npt.NDArray[np.bool_]
I64 = npt.NDArray[np.int64]


def side_matches(command: int | None, rts: Collection[int] | None,
                 sas: Collection[int] | None, transmit: bool | None) -> bool:
    """True when the side named by ``command`` (a command word's value) is one of ``rts``,
    one of ``sas`` and in direction ``transmit`` (None: any, for each); a missing command
    word (a stray data word) has no side and matches only a filter asking for nothing."""
    if command is None:
        return rts is None and sas is None and transmit is None
    if rts is not None and command >> 11 & 31 not in rts:
        return False
    if sas is not None and command >> 5 & 31 not in sas:
        return False
    return transmit is None or bool(command >> 10 & 1) == transmit


def message_matches(command: int | None, command2: int | None,
                    rts: Collection[int] | None, sas: Collection[int] | None,
                    transmit: bool | None) -> bool:
    """True when one side of a message (``command``, or ``command2`` for an RT-RT
    transfer's transmit command) matches all of ``rts``, ``sas`` and ``transmit``."""
    if rts is None and sas is None and transmit is None:
        return True
    return side_matches(command, rts, sas, transmit) or (
        command2 is not None and side_matches(command2, rts, sas, transmit))


def sides_mask(command: I64, command2: I64, rts: Collection[int] | None,
               sas: Collection[int] | None, transmit: bool | None) -> Mask:
    """:func:`message_matches` over columns (``command2`` is -1 where there is none)."""

    def side(words: I64) -> Mask:
        keep = words >= 0
        if rts is not None:
            keep &= np.isin(words >> 11 & 31, np.fromiter(rts, np.int64))
        if sas is not None:
            keep &= np.isin(words >> 5 & 31, np.fromiter(sas, np.int64))
        if transmit is not None:
            keep &= (words >> 10 & 1) == int(transmit)
        return keep

    if rts is None and sas is None and transmit is None:
        return np.ones(command.shape, np.bool_)
    return side(command) | side(command2)
