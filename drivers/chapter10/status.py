"""The MS1553F1 block status word (IRIG 106 Chapter 10), both ways.

Each 1553 message in a Chapter 10 MIL-STD-1553 Format 1 packet carries a 16-bit block status
word. Its bits, as the standard numbers them (bit 0 least significant)::

    13  BID  bus B (0 = bus A)          9  TM  response time-out
    12  ME   message error              5  LE  word count error
    11  RR   RT-to-RT transfer          4  SE  sync type error
    10  FE   format error               3  WE  invalid word error

MAPR names errors more finely (:data:`~drivers.mil1553.record.MESSAGE_ERROR_NAMES`), so the
mapping is lossy. Writing (:func:`block_status_for`):

=================  ===========================================================================
bit                set when the record carries
=================  ===========================================================================
TM                 ``no_response``
LE                 ``word_count_low``, ``word_count_high``
SE                 ``sync``
WE                 ``word_error``, ``manchester``, ``parity``, ``bit_count_low``,
                   ``bit_count_high``
FE                 ``illegal_format``, ``reserved_mode_code``, ``non_contiguous_data``,
                   ``superseded``, ``orphan_words``, ``babbling``
ME                 any error name except ``time_tags_unavailable``
(ME only)          ``early_response``, ``late_response``, ``wrong_rt_address``,
                   ``reserved_status_bits``, ``intermessage_gap_short``, ``both_buses_active``
=================  ===========================================================================

The names in the last row have no bit of their own: the first four can be found again from
the words and the gap word when the message is read back (the Chapter 10 reader does so), the
last two describe the traffic around the message and are lost.

Reading (:func:`errors_for`) gives one name per flag: TM -> ``no_response``, SE -> ``sync``,
WE -> ``word_error``, FE -> ``illegal_format``, LE -> ``word_count_low``. Whether a word count
error is low or high depends on the words stored, so :func:`errors_for_words` takes the word
counts expected and found and names ``word_count_high`` when there are more words than the
command calls for. ME alone adds no name.
"""

from __future__ import annotations

from drivers.mil1553.record import MonitorRecord, TransferFormat

BUS_B = 1 << 13
"""BID: the message was on bus B."""
MESSAGE_ERROR = 1 << 12
"""ME: the recorder found an error in the message."""
RT_TO_RT = 1 << 11
"""RR: an RT-to-RT transfer (two command words first)."""
FORMAT_ERROR = 1 << 10
"""FE: a format error in the message."""
RESPONSE_TIMEOUT = 1 << 9
"""TM: a terminal did not respond in time."""
WORD_COUNT_ERROR = 1 << 5
"""LE: more or fewer words than the command calls for."""
SYNC_TYPE_ERROR = 1 << 4
"""SE: a word with the wrong sync type."""
INVALID_WORD_ERROR = 1 << 3
"""WE: a word with a Manchester, bit-count or parity error."""

ERROR_BITS: dict[str, int] = {
    "no_response": RESPONSE_TIMEOUT,
    "word_count_low": WORD_COUNT_ERROR,
    "word_count_high": WORD_COUNT_ERROR,
    "sync": SYNC_TYPE_ERROR,
    "word_error": INVALID_WORD_ERROR,
    "manchester": INVALID_WORD_ERROR,
    "parity": INVALID_WORD_ERROR,
    "bit_count_low": INVALID_WORD_ERROR,
    "bit_count_high": INVALID_WORD_ERROR,
    "illegal_format": FORMAT_ERROR,
    "reserved_mode_code": FORMAT_ERROR,
    "non_contiguous_data": FORMAT_ERROR,
    "superseded": FORMAT_ERROR,
    "orphan_words": FORMAT_ERROR,
    "babbling": FORMAT_ERROR,
}
"""Our error names that set a flag of their own (besides ME)."""

NOT_MESSAGE_ERRORS = frozenset({"time_tags_unavailable"})
"""Names that describe the monitor, not the message: they do not set ME."""

_NAMES_READ = (
    (RESPONSE_TIMEOUT, "no_response"),
    (FORMAT_ERROR, "illegal_format"),
    (WORD_COUNT_ERROR, "word_count_low"),
    (SYNC_TYPE_ERROR, "sync"),
    (INVALID_WORD_ERROR, "word_error"),
)

_RT_TO_RT_FORMATS = (TransferFormat.RT_RT, TransferFormat.BCAST_RT_RT)


def block_status_for(record: MonitorRecord) -> int:
    """The block status word a Chapter 10 recorder writes for ``record``.

    >>> from drivers.mil1553.record import MonitorRecord, TransferFormat
    >>> hex(block_status_for(MonitorRecord(0, "B", TransferFormat.RT_BC, 0x0C22,
    ...                                    errors=("no_response",))))
    '0x3200'
    """
    word = BUS_B if record.bus == "B" else 0
    if record.format in _RT_TO_RT_FORMATS:
        word |= RT_TO_RT
    for name in record.errors:
        word |= ERROR_BITS.get(name, 0)
        if name not in NOT_MESSAGE_ERRORS:
            word |= MESSAGE_ERROR
    return word


def errors_for(block_status: int) -> tuple[str, ...]:
    """Our error names for a block status word, sorted (LE read as ``word_count_low``; see
    :func:`errors_for_words` to tell low from high).

    >>> errors_for(0x3200)
    ('no_response',)
    """
    return tuple(sorted(name for bit, name in _NAMES_READ if block_status & bit))


def errors_for_words(block_status: int, *, expected_words: int, stored_words: int
                     ) -> tuple[str, ...]:
    """Like :func:`errors_for`, but a word count error is ``word_count_high`` when the
    message holds more words than its command(s) call for (``stored_words`` >
    ``expected_words``, both counting every word on the bus), else ``word_count_low``."""
    names = set(errors_for(block_status))
    if block_status & WORD_COUNT_ERROR and stored_words > expected_words:
        names.discard("word_count_low")
        names.add("word_count_high")
    return tuple(sorted(names))


def is_bus_b(block_status: int) -> bool:
    """True when the message was on bus B."""
    return bool(block_status & BUS_B)


def is_rt_to_rt(block_status: int) -> bool:
    """True when the message is an RT-to-RT transfer."""
    return bool(block_status & RT_TO_RT)
