"""The TMATS setup record of a recording: the attributes other tools look for."""

from __future__ import annotations

from datetime import datetime
from pathlib import Path

import pytest

from drivers.chapter10.tmats import (
    BUS_LINK_NAME,
    RecordingSetup,
    parse_tmats,
    tmats_attributes,
    tmats_text,
)

SETUP = RecordingSetup(bus_channel_id=7, time_channel_id=8,
                       created=datetime(2026, 7, 4, 12, 30, 15, 250000),
                       recorder_version="MAPR 0.1.0")
SAMPLE = Path(__file__).resolve().parents[2] / ".." / "shared" / "data" / "chapter10" / \
    "sample.c10"


def test_the_1553_and_time_sources_carry_their_channel_ids() -> None:
    attributes = parse_tmats(tmats_text(SETUP))
    assert attributes["R-1\\N"] == "2"
    assert (attributes["R-1\\TK1-1"], attributes["R-1\\CDT-1"]) == ("8", "TIMEIN")
    assert (attributes["R-1\\TK1-2"], attributes["R-1\\CDT-2"]) == ("7", "1553IN")
    assert attributes["R-1\\CHE-1"] == attributes["R-1\\CHE-2"] == "T"
    assert attributes["R-1\\BTF-2"] == "1"
    assert attributes["R-1\\TTF-1"] == "1"


def test_the_bus_group_describes_a_1553_bus_linked_to_the_channel() -> None:
    attributes = parse_tmats(tmats_text(SETUP))
    assert attributes["R-1\\CDLN-2"] == attributes["B-1\\DLN"] == BUS_LINK_NAME
    assert attributes["B-1\\BT-1"] == "1553"
    assert attributes["B-1\\NBS\\N"] == "1"


def test_general_information_names_the_release_date_and_recorder() -> None:
    attributes = parse_tmats(tmats_text(SETUP))
    assert attributes["G\\106"] == "07"
    assert attributes["G\\OD"] == "07-04-2026"
    assert attributes["G\\DSI\\N"] == "1"
    assert attributes["G\\DSI-1"] == attributes["R-1\\ID"] == "MAPR"
    assert attributes["R-1\\RI2"] == "MAPR 0.1.0"
    assert "2026-07-04 12:30:15.25" in attributes["G\\COM"]


def test_every_statement_is_one_crlf_terminated_line() -> None:
    text = tmats_text(SETUP)
    lines = text.split("\r\n")
    assert lines[-1] == ""
    assert len(lines) - 1 == len(tmats_attributes(SETUP))
    assert all(line.count(":") >= 1 and line.endswith(";") for line in lines[:-1])
    text.encode("ascii")


def test_a_value_with_a_separator_is_refused() -> None:
    bad = RecordingSetup(bus_channel_id=1, time_channel_id=2, created=SETUP.created,
                         recorder_version="v1;G\\PN:evil")
    with pytest.raises(ValueError, match="separator"):
        tmats_text(bad)


def test_parse_reads_a_real_recorders_tmats() -> None:
    """The parser reads the sample recording's setup record the same way: its 1553
    channels are found by CDT and TK1."""
    if not SAMPLE.exists():
        pytest.skip(f"sample recording not found at {SAMPLE}")
    from chapter10 import C10
    first = next(iter(C10(str(SAMPLE))))
    attributes = parse_tmats(first.data.decode("ascii", errors="replace"))
    buses = sorted(int(attributes[f"R-1\\TK1-{n}"]) for n in range(1, int(attributes["R-1\\N"])
                                                                     + 1)
                   if attributes.get(f"R-1\\CDT-{n}") == "1553IN")
    assert buses == [2, 3, 4, 5]
