"""Every validation error names the file, the line and the field, and says what is wrong.

Each case edits one line of a valid table; ``#!`` marks the line the error must point at.
"""

from __future__ import annotations

import pytest

from mapr_daemon.errors import ConfigError, IcdError
from mapr_daemon.icd import loads_icd

BASE = """\
spec: 1
name: t
terminals:
  - {address: 1, name: rt1}
  - {address: 2, name: rt2}
messages:
  - name: m1
    rt: rt1
    tr: T
    sa: 1
    wc: 2
    rate_hz: 50
    parameters:
      - {name: a, word: 0, type: unsigned}
      - {name: b, word: 1, bits: [7, 0], type: twos, lsb: 0.5, minimum: -10, maximum: 10}
  - name: m2
    rt: rt2
    tr: R
    sa: 2
    wc: 9
    rate_hz: 0
    parameters:
      - {name: seq, word: 0, type: counter}
    group:
      start: 1
      samples: 4
      stride: 2
      sample_rate_hz: 1000
      counter: seq
      channels:
        - {name: x, word: 0, type: twos}
        - {name: y, word: 1, type: unsigned}
schedule:
  minor_frame_us: 10000
  minor_frames: 2
  messages:
    - {message: m1, every: 2}
"""

B = "      - {name: b, word: 1, bits: [7, 0], type: twos, lsb: 0.5, minimum: -10, maximum: 10}"

# (id, line to replace, replacement with #! on the line the error names, field, problem)
CASES = [
    ("overlapping bits", B, B.replace("word: 1", "word: 0") + "  #!", "m1.b.bits",
     "overlaps 'a'"),
    ("overlap in a two-word value", "      - {name: a, word: 0, type: unsigned}\n" + B,
     "      - {name: a, word: 0, words: 2, type: unsigned}\n" + B + "  #!", "m1.b.bits",
     "bit 0 of word 1 overlaps 'a'"),
    ("word past the word count", B, B.replace("word: 1", "word: 2") + "  #!", "m1.b.word",
     "past the word count 2"),
    ("two-word value past the word count", B,
     "      - {name: b, word: 1, words: 2, type: unsigned}  #!", "m1.b.word",
     "word 2 is past the word count"),
    ("group past the word count", "      samples: 4", "      samples: 5  #!",
     "m2.group.samples", "past the word count 9"),
    ("channel past the sample", "        - {name: y, word: 1, type: unsigned}",
     "        - {name: y, word: 2, type: unsigned, words: 1}  #!",
     "messages[1].group.channels[1].word", "word 2 is past the sample's 2 words"),
    ("duplicate parameter name", "        - {name: y, word: 1, type: unsigned}",
     "        - {name: a, word: 1, type: unsigned}  #!", "m2.a.name",
     "already used in m1 on line 14"),
    ("duplicate message name", "  - name: m2", "  - name: m1  #!", "m1.name",
     "message name 'm1' already used on line 7"),
    ("duplicate terminal address", "  - {address: 2, name: rt2}",
     "  - {address: 1, name: rt2}  #!", "terminals.address", "address 1 already used"),
    ("duplicate terminal name", "  - {address: 2, name: rt2}",
     "  - {address: 2, name: rt1}  #!", "terminals.name", "name 'rt1' already used"),
    ("subaddress used twice", "    sa: 2", "    sa: 1  #!\n    source: {rt: rt2, sa: 3}",
     "", ""),  # placeholder replaced below
    ("RT-RT source subaddress used twice", "    sa: 2",
     "    sa: 2\n    source: {rt: rt1, sa: 1}  #!", "m2.source.sa",
     "RT01 T SA01 is already used by message 'm1'"),
    ("mode-code subaddress 0", "    sa: 1", "    sa: 0  #!", "messages[0].sa",
     "subaddress 0 is reserved for mode codes"),
    ("mode-code subaddress 31", "    sa: 2", "    sa: 31  #!", "messages[1].sa",
     "subaddress 31 is reserved for mode codes"),
    ("maximum cannot fit", B, B.replace("maximum: 10", "maximum: 64") + "  #!",
     "messages[0].parameters[1].maximum", "64.0 cannot fit in 8 bits of twos"),
    ("negative minimum for unsigned", "      - {name: a, word: 0, type: unsigned}",
     "      - {name: a, word: 0, type: unsigned, minimum: -1}  #!",
     "messages[0].parameters[0].minimum", "-1.0 cannot fit"),
    ("enum code cannot fit", "      - {name: a, word: 0, type: unsigned}",
     "      - {name: a, word: 0, bits: [1, 0], type: enum, values: {0: A, 4: B}}  #!",
     "messages[0].parameters[0].values", "code 4 cannot fit in 2 bit(s)"),
    ("discrete wider than a bit", "      - {name: a, word: 0, type: unsigned}",
     "      - {name: a, word: 0, bits: [9, 8], type: discrete}  #!",
     "messages[0].parameters[0].bits", "a discrete is one bit"),
    ("BCD not whole digits", "      - {name: a, word: 0, type: unsigned}",
     "      - {name: a, word: 0, bits: [5, 0], type: bcd}  #!",
     "messages[0].parameters[0].bits", "multiple of 4 bits"),
    ("float32 in one word", "      - {name: a, word: 0, type: unsigned}",
     "      - {name: a, word: 0, words: 1, type: float32}  #!",
     "messages[0].parameters[0].words", "a float32 takes two words"),
    ("bits outside the word", "      - {name: a, word: 0, type: unsigned}",
     "      - {name: a, word: 0, bits: [16, 0], type: unsigned}  #!",
     "messages[0].parameters[0].bits", "not a range within bits 15..0"),
    ("enum label twice", "      - {name: a, word: 0, type: unsigned}",
     "      - {name: a, word: 0, type: enum, values: {0: A, 1: A}}  #!",
     "messages[0].parameters[0].values", "label 'A' is used twice"),
    ("bnr without msb weight", "      - {name: a, word: 0, type: unsigned}",
     "      - {name: a, word: 0, type: bnr, lsb: 0.1}  #!",
     "messages[0].parameters[0].lsb", "scaled by msb_weight"),
    ("limits on a discrete", "      - {name: a, word: 0, type: unsigned}",
     "      - {name: a, word: 0, bits: 3, type: discrete, maximum: 1}  #!",
     "messages[0].parameters[0].maximum", "a discrete parameter has no maximum"),
    ("unknown field", "    rate_hz: 50", "    rate_hz: 50\n    descripton: typo  #!",
     "messages[0].descripton", "unknown field"),
    ("missing field", "    wc: 2\n", "", "messages[0].wc", "is required"),
    ("wrong kind of value", "    wc: 2", "    wc: two  #!", "messages[0].wc",
     "must be an integer"),
    ("word count out of range", "    wc: 2", "    wc: 33  #!", "messages[0].wc",
     "33 is outside 1..32"),
    ("unknown type", "      - {name: a, word: 0, type: unsigned}",
     "      - {name: a, word: 0, type: float64}  #!", "messages[0].parameters[0].type",
     "unknown type 'float64'"),
    ("unknown terminal", "    rt: rt1", "    rt: rt9  #!", "messages[0].rt",
     "no terminal named 'rt9'"),
    ("source on a transmit message", "    rate_hz: 50",
     "    rate_hz: 50\n    source: {rt: rt2, sa: 4}  #!", "messages[0].source",
     "only a receive (tr: R) message"),
    ("spec version", "spec: 1", "spec: 2  #!", "spec", "unsupported version 2"),
    ("group counter is not a counter", "      counter: seq", "      counter: x  #!",
     "m2.group.counter", "'x' is not a counter parameter"),
    ("schedule names an unknown message", "    - {message: m1, every: 2}",
     "    - {message: m1, every: 2}\n    - {message: m9, every: 1}  #!", "schedule.message",
     "no message named 'm9'"),
    ("schedule rate differs from the message's", "    - {message: m1, every: 2}",
     "    - {message: m1, every: 1}  #!", "schedule.m1.every",
     "runs at 100 Hz but the message declares rate_hz 50"),
    ("every does not divide the major frame", "  minor_frames: 2",
     "  minor_frames: 3", "schedule.m1.every", "every 2 does not divide the 3"),
    ("periodic message not scheduled", "    rate_hz: 0", "    rate_hz: 10  #!",
     "m2.rate_hz", "periodic (10 Hz) but not in the schedule"),
    ("duplicate YAML key", "    tr: T", "    tr: T\n    tr: R  #!", None,
     "duplicate key 'tr'"),
    ("YAML syntax", "  - {address: 2, name: rt2}", "  - {address: 2, name: rt2", None,
     "invalid YAML: expected ',' or '}'"),
]
# A subaddress used twice: m2 moved onto RT01 T SA01, where m1 already is.
CASES[10] = ("subaddress used twice", "    rt: rt2\n    tr: R\n    sa: 2",
             "    rt: rt1\n    tr: T\n    sa: 1  #!", "m2.sa",
             "RT01 T SA01 is already used by message 'm1' (line 7)")


def _expected_line(text: str, default: int) -> int:
    for number, line in enumerate(text.splitlines(), start=1):
        if "#!" in line:
            return number
    return default


def _load(text: str) -> IcdError:
    with pytest.raises(IcdError) as caught:
        loads_icd(text, "bad.yaml")
    return caught.value


def test_the_base_table_is_valid():
    icd = loads_icd(BASE, "base.yaml")
    assert [m.name for m in icd.messages] == ["m1", "m2"]


@pytest.mark.parametrize(("old", "new", "field", "problem"),
                         [c[1:] for c in CASES], ids=[c[0] for c in CASES])
def test_validation_error_names_file_line_and_field(old, new, field, problem):
    assert old in BASE
    text = BASE.replace(old, new, 1)
    if field == "schedule.m1.every" and "minor_frames: 3" in text:
        expected = text.splitlines().index("    - {message: m1, every: 2}") + 1
    elif problem == "is required":
        expected = 7            # the message mapping that lacks it
    elif problem.startswith("invalid YAML"):
        expected = 6            # where the parser found the mapping unclosed
    else:
        expected = _expected_line(text, default=-1)
    error = _load(text)
    assert isinstance(error, ConfigError)
    assert error.path == "bad.yaml"
    assert error.line == expected
    assert error.field == field
    prefix = f"bad.yaml:{expected}: " + (f"{field}: " if field else "")
    message = str(error)
    assert message.startswith(prefix), message
    assert problem in message
    assert "\n" not in message


def test_minor_frame_overflow_says_which_frame_and_messages():
    text = BASE.replace("  minor_frame_us: 10000", "  minor_frame_us: 100").replace(
        "    rate_hz: 50", "    rate_hz: 5000")
    # m1 takes 4 words (80 µs) + 10 µs response + 10 µs gap = 100 µs: it just fits ...
    assert loads_icd(text, "fits.yaml").bus_load().peak_frame_load == 1.0
    text = text.replace("    wc: 2", "    wc: 3")
    error = _load(text)     # ... and one more word does not
    assert error.field == "schedule.minor_frame_us"
    assert "minor frame 0 needs 120 µs of bus time, more than its 100 µs (m1)" in str(error)
