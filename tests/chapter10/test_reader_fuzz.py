"""Damaged recordings, property-tested: `mapr decode` and `mapr replay` never stop on a bad
packet, and every packet the damage did not touch still comes out.

Damages (header fields rewritten with a valid header checksum, lengths included; 1553 body
fields (channel-specific word, message time stamp, block status, gap word, length) rewritten
with a valid data checksum; flipped bytes; zeroed runs; cuts) are drawn by hypothesis and
applied to the sample recording (when it is next to the repository) and to a recording the
project's own writer makes here, so the property is tested everywhere. The big campaign is
``bench/chapter10_fuzz.py``.
"""

from __future__ import annotations

import contextlib
import io
import json
import struct
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from drivers.chapter10.reader import Chapter10Reader
from mapr_daemon.cli import exitcodes
from mapr_daemon.cli.main import main
from mapr_daemon.testbed.c10damage import (
    BODY_FIELDS,
    FIELDS,
    Damage,
    PacketSpan,
    body_fields,
    intact_packets,
    many_packet_recording,
    packet_spans,
)

from .conftest import SAMPLE

_SETTINGS = {"deadline": None, "derandomize": True,
             "suppress_health_check": [HealthCheck.too_slow]}


@dataclass
class Recording:
    """An undamaged recording and, per 1553 packet offset, its messages as decoded."""

    data: bytes
    spans: list[PacketSpan]
    lines: dict[int, list[str]]


def _key(record_json: dict[str, Any]) -> str:
    """A decoded message without its times (they count from the first packet read, which
    a damage to the first packet moves)."""
    return json.dumps({k: v for k, v in record_json.items()
                       if k not in ("t_ns", "end_ns", "time")}, sort_keys=True)


def _recording(path: Path) -> Recording:
    reader = Chapter10Reader(path)
    lines = {batch.offset: [_key({**r.to_json(), "channel": r.extra["channel"]})
                            for r in batch.records]
             for batch in reader if batch.records}
    reader.close()
    data = path.read_bytes()
    return Recording(data, packet_spans(data), lines)


_CACHE: dict[str, Recording] = {}


def recording(which: str) -> Recording:
    if which not in _CACHE:
        if which == "sample":
            if not SAMPLE.is_file():
                pytest.skip(f"the sample Chapter 10 recording is not at {SAMPLE}")
            _CACHE[which] = _recording(SAMPLE)
        else:
            with tempfile.TemporaryDirectory() as tmp:
                path = Path(tmp) / "written.c10"
                many_packet_recording(path)
                _CACHE[which] = _recording(path)
    return _CACHE[which]


@st.composite
def damages(draw: st.DrawFn, rec: Recording) -> Damage:
    kind = draw(st.sampled_from(["field", "field", "body", "flip", "zeros", "truncate"]))
    size = len(rec.data)
    if kind == "body":
        span = draw(st.sampled_from([s for s in rec.spans if s.offset in rec.lines]))
        name, offset = draw(st.sampled_from(body_fields(rec.data, span)))
        fmt = BODY_FIELDS[name]
        (old,) = struct.unpack_from(fmt, rec.data, offset)
        top = (1 << 8 * struct.calcsize(fmt)) - 1
        value = draw(st.one_of(st.integers(0, 7), st.just(top),
                               st.integers(-40, 40).map(lambda d: (old + d) % (top + 1)),
                               st.integers(0, top)))
        return Damage("body", offset, value, name, span.offset)
    if kind == "field":
        span = draw(st.sampled_from(rec.spans))
        name = draw(st.sampled_from(sorted(FIELDS)))
        where, fmt = FIELDS[name]
        (old,) = struct.unpack_from(fmt, rec.data, span.offset + where)
        top = (1 << 8 * struct.calcsize(fmt)) - 1
        value = draw(st.one_of(st.integers(0, 7), st.just(top),
                               st.integers(-40, 40).map(lambda d: (old + d) % (top + 1)),
                               st.integers(0, top)))
        return Damage("field", span.offset, value, name)
    if kind == "flip":
        return Damage("flip", draw(st.integers(0, size - 1)), 1 << draw(st.integers(0, 7)))
    if kind == "zeros":
        return Damage("zeros", draw(st.integers(0, size - 1)), draw(st.integers(1, 64)))
    return Damage("truncate", draw(st.integers(0, size - 1)), 0)


def run_cli(*argv: str) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(list(argv))
    return code, out.getvalue(), err.getvalue()


def expected(rec: Recording, damage: Damage) -> list[str]:
    """The messages of the 1553 packets the damage left intact."""
    return [line for span in intact_packets(rec.spans, damage)
            for line in rec.lines.get(span.offset, [])]


def check_decode(rec: Recording, damage: Damage) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "damaged.c10"
        path.write_bytes(damage.apply(rec.data))
        code, out, err = run_cli("decode", str(path))
    assert "Traceback" not in err
    want = expected(rec, damage)
    if code == exitcodes.USAGE:  # no valid packet header left at all
        assert not intact_packets(rec.spans, damage), err
        return
    assert code == exitcodes.OK, err
    got = [_key(json.loads(line)) for line in out.splitlines()]
    got_messages = [g for g in got if '"kind": "arinc429"' not in g]
    missing = [line for line in want if line not in got_messages]
    assert not missing, f"{damage}: {len(missing)} intact messages lost\n{err}"


def check_replay(rec: Recording, damage: Damage) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "damaged.c10"
        path.write_bytes(damage.apply(rec.data))
        code, out, err = run_cli("replay", str(path), "--catalog", str(Path(tmp) / "c.db"),
                                 "--no-progress")
    if code == exitcodes.USAGE:
        assert not intact_packets(rec.spans, damage), err
        return
    if code == exitcodes.DATAERR:   # no 1553 data left: said in one line, as decode says it
        assert not expected(rec, damage) and "no MIL-STD-1553 data in the recording" in err
        return
    assert code == exitcodes.OK, err
    replayed = int(out.split("replay complete: ")[1].split(" messages")[0])
    assert replayed >= len(expected(rec, damage)), out


@pytest.mark.parametrize("which", ["written", "sample"])
def test_a_data_length_of_1_to_3_is_a_skipped_packet_not_a_traceback(which: str) -> None:
    rec = recording(which)
    first_1553 = next(s for s in rec.spans if s.offset in rec.lines)
    for length in (1, 2, 3):
        damage = Damage("field", first_1553.offset, length, "data_length")
        check_decode(rec, damage)
        check_replay(rec, damage)
        with tempfile.TemporaryDirectory() as tmp:
            path = Path(tmp) / "damaged.c10"
            path.write_bytes(damage.apply(rec.data))
            reader = Chapter10Reader(path)
            batches = list(reader)
            reader.close()
        assert first_1553.offset not in {b.offset for b in batches}
        assert f"offset {first_1553.offset}: data length {length} bytes leaves no room for " \
               "the channel-specific word" in " ".join(str(i) for i in reader.issues)


@pytest.mark.parametrize("which", ["written", "sample"])
def test_decode_reads_every_intact_packet_of_a_damaged_file(which: str) -> None:
    rec = recording(which)

    @settings(max_examples=80, **_SETTINGS)
    @given(damages(rec))
    def prop(damage: Damage) -> None:
        check_decode(rec, damage)

    prop()


@pytest.mark.parametrize("which", ["written", "sample"])
def test_replay_finishes_a_damaged_file(which: str) -> None:
    rec = recording(which)

    @settings(max_examples=15, **_SETTINGS)
    @given(damages(rec))
    def prop(damage: Damage) -> None:
        check_replay(rec, damage)

    prop()


@pytest.mark.parametrize("which", ["written", "sample"])
def test_a_packet_length_past_the_end_mid_file_loses_nothing_whole(which: str) -> None:
    rec = recording(which)
    # a 1553 packet with a packet after it, near enough to the end for a legal length to
    # run past it (the standard caps a packet at 512 KiB)
    first_1553 = next(s for s in rec.spans[:-1]
                      if s.offset in rec.lines and len(rec.data) - s.offset < 500_000)
    length = (len(rec.data) - first_1553.offset + 8) // 4 * 4
    damage = Damage("field", first_1553.offset, length, "packet_length")
    check_decode(rec, damage)
    check_replay(rec, damage)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "damaged.c10"
        path.write_bytes(damage.apply(rec.data))
        reader = Chapter10Reader(path)
        read = {b.offset for b in reader}
        reader.close()
    following = rec.spans[rec.spans.index(first_1553) + 1].offset
    # the packet is read up to the header that follows it: its whole messages are kept
    assert str(reader.issues[0]).startswith(
        f"offset {first_1553.offset}: packet (type 0x19, channel "
        f"{_channel(rec, first_1553)}) cut short by the packet header at offset {following} "
        f"({following - first_1553.offset} of {length} bytes): the ")
    assert str(reader.issues[0]).endswith(" it announces lost")
    assert set(rec.lines) <= read


def _channel(rec: Recording, span: PacketSpan) -> int:
    return int(struct.unpack_from("<H", rec.data, span.offset + 2)[0])
