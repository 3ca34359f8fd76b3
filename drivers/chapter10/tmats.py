"""The TMATS setup record a MAPR recording starts with (IRIG 106 Chapter 9 attributes).

A Chapter 10 file opens with a computer-generated format 1 packet (data type 0x01, channel 0)
holding TMATS text: ``CODE:value;`` lines that tell other tools what each channel carries.
A recording by :class:`~drivers.chapter10.writer.Chapter10Writer` has two data sources, written
in the layout of IRIG 106-07 (the release the packet headers claim, data type version 0x03):

* a time channel (``R-1\\CDT-1:TIMEIN``) carrying Time Data Format 1 packets from the host
  clock (``R-1\\TSRC-1:I``, internal);
* one MIL-STD-1553 channel (``R-1\\CDT-2:1553IN``, Format 1 packets, ``R-1\\BTF-2:1``), tied by
  its data link name (``R-1\\CDLN-2``) to a B group that names the bus and says it is a 1553
  bus (``B-1\\BT-1:1553``).

``R-1\\TK1-n`` (track number) is the channel id each source's packets carry: it is how a
reader finds which channel is the 1553 bus. See docs/recording.md for every attribute.
"""

from __future__ import annotations

from dataclasses import dataclass
from datetime import datetime

IRIG106_RELEASE = "07"
"""The IRIG 106 release the recording follows (``G\\106``)."""
TMATS_VERSION = 7
"""The TMATS packet's version field for IRIG 106-07."""
BUS_LINK_NAME = "MAPR-1553"
"""The data link name tying the 1553 channel to its bus description (B group)."""


@dataclass(frozen=True, slots=True)
class RecordingSetup:
    """What the TMATS record describes: the channel ids, the recorder and the start."""

    bus_channel_id: int
    time_channel_id: int
    created: datetime
    """The recording's start (origination date ``G\\OD`` and the comment)."""
    recorder: str = "MAPR"
    """Program name and recorder id (``G\\PN``, ``R-1\\ID``, ``R-1\\RI1``)."""
    recorder_version: str = ""
    """Recorder model/version (``R-1\\RI2``), when known."""
    bus_name: str = "BUS1553-A/B"
    """The bus's name (``B-1\\BNA-1``): one dual-redundant bus, A and B in the block status."""
    tail: str = ""
    """The aircraft's tail number, as the test article (``G\\TA``; not written when empty):
    where ``mapr fleet --tail-tmats 'G\\TA'`` reads it."""


SEPARATORS = (";", "\n", "\r")
"""Characters a TMATS value cannot hold (they end an attribute or its line)."""

TAIL_ATTRIBUTE = "G\\TA"
"""The TMATS code the tail number is written under (the test article)."""


def tmats_attributes(setup: RecordingSetup) -> list[tuple[str, str]]:
    """The TMATS attributes, in the order they are written, as (code, value) pairs."""
    rec = setup.recorder
    general = [
        ("G\\PN", rec),
        ("G\\106", IRIG106_RELEASE),
        ("G\\OD", setup.created.strftime("%m-%d-%Y")),
        *([(TAIL_ATTRIBUTE, setup.tail)] if setup.tail else []),
        ("G\\DSI\\N", "1"),
        ("G\\DSI-1", rec),
        ("G\\DST-1", "STO"),
        ("G\\COM", f"MIL-STD-1553 bus monitor recording started "
                   f"{setup.created.strftime('%Y-%m-%d %H:%M:%S.%f')[:-4]}"),
    ]
    recorder = [
        ("R-1\\ID", rec),
        ("R-1\\RI1", rec),
        *([("R-1\\RI2", setup.recorder_version)] if setup.recorder_version else []),
        ("R-1\\N", "2"),
        ("R-1\\EV\\E", "F"),
        ("R-1\\IDX\\E", "F"),
    ]
    time_source = [
        ("R-1\\DSI-1", "TIME"),
        ("R-1\\TK1-1", str(setup.time_channel_id)),
        ("R-1\\CHE-1", "T"),
        ("R-1\\CDT-1", "TIMEIN"),
        ("R-1\\TTF-1", "1"),
        ("R-1\\TFMT-1", "I"),
        ("R-1\\TSRC-1", "I"),
    ]
    bus_source = [
        ("R-1\\DSI-2", BUS_LINK_NAME),
        ("R-1\\TK1-2", str(setup.bus_channel_id)),
        ("R-1\\CHE-2", "T"),
        ("R-1\\CDT-2", "1553IN"),
        ("R-1\\BTF-2", "1"),
        ("R-1\\CDLN-2", BUS_LINK_NAME),
        ("R-1\\BDLN-2", BUS_LINK_NAME),
    ]
    bus = [
        ("B-1\\DLN", BUS_LINK_NAME),
        ("B-1\\NBS\\N", "1"),
        ("B-1\\BID-1", "00000000"),
        ("B-1\\BNA-1", setup.bus_name),
        ("B-1\\BT-1", "1553"),
    ]
    return general + recorder + time_source + bus_source + bus


def tmats_text(setup: RecordingSetup) -> str:
    """The TMATS record as written: one ``CODE:value;`` per line, CR LF line ends."""
    for code, value in tmats_attributes(setup):
        if any(c in value for c in SEPARATORS):
            raise ValueError(f"TMATS value for {code} holds a separator: {value!r}")
    return "".join(f"{code}:{value};\r\n" for code, value in tmats_attributes(setup))


def parse_tmats(text: str) -> dict[str, str]:
    """Attributes of a TMATS text (``CODE:value;`` each), code -> value; a repeated code
    keeps its last value. Lines without a colon are skipped."""
    attributes: dict[str, str] = {}
    for statement in text.replace("\r", "").split(";"):
        code, sep, value = statement.strip().partition(":")
        if sep and code:
            attributes[code] = value
    return attributes
