"""Encode/decode round trips for every parameter type, at its edges, against hand-made words."""

from __future__ import annotations

import math
import struct

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from drivers.mil1553.record import MonitorRecord, TransferFormat
from mapr_daemon.icd import IcdRangeError, IcdValueError
from mapr_daemon.icd.flags import (
    FLAG_ABOVE_MAX,
    FLAG_BELOW_MIN,
    FLAG_INVALID,
    FLAG_MISSING,
    FLAG_NAN,
    FLAG_RECORD_ERROR,
)

# (parameter spec, value, expected data words): the words are the oracle, worked out by hand.
CASES = [
    # unsigned
    ("type: unsigned", 0, (0x0000, 0)),
    ("type: unsigned", 65535, (0xFFFF, 0)),
    ("type: unsigned, bits: [11, 4], lsb: 0.5, offset: 10", 10.0, (0x0000, 0)),
    ("type: unsigned, bits: [11, 4], lsb: 0.5, offset: 10", 137.5, (0x0FF0, 0)),
    ("type: unsigned, lsb: 0.001, unit: V, minimum: 0, maximum: 36", 36.0, (36000, 0)),
    # two's complement: sign edges
    ("type: twos, lsb: 0.001", -32.768, (0x8000, 0)),
    ("type: twos, lsb: 0.001", 32.767, (0x7FFF, 0)),
    ("type: twos, lsb: 0.001", -0.001, (0xFFFF, 0)),
    ("type: twos, lsb: 0.001", 0.0, (0x0000, 0)),
    ("type: twos, bits: [7, 0]", -128, (0x0080, 0)),
    ("type: twos, bits: [7, 0]", 127, (0x007F, 0)),
    ("type: twos, bits: [7, 0]", -1, (0x00FF, 0)),
    ("type: twos, bits: [14, 3]", -1, (0x7FF8, 0)),
    # BNR: msb_weight 90 -> LSB 90 / 2**14
    ("type: bnr, msb_weight: 90", 90.0, (0x4000, 0)),
    ("type: bnr, msb_weight: 90", -90.0, (0xC000, 0)),
    ("type: bnr, msb_weight: 90", -180.0, (0x8000, 0)),
    ("type: bnr, msb_weight: 90", 180.0 - 90.0 / 2**14, (0x7FFF, 0)),
    ("type: bnr, msb_weight: 16384, words: 2", 1.0, (0x0001, 0x0000)),
    ("type: bnr, msb_weight: 16384, words: 2", -1.0, (0xFFFF, 0x0000)),
    # BCD digits
    ("type: bcd", 0, (0x0000, 0)),
    ("type: bcd", 1234, (0x1234, 0)),
    ("type: bcd", 9999, (0x9999, 0)),
    ("type: bcd, bits: [11, 0]", 999, (0x0999, 0)),
    ("type: bcd, lsb: 0.01", 29.92, (0x2992, 0)),
    ("type: bcd, words: 2", 98765432, (0x9876, 0x5432)),
    # discretes and enumerations
    ("type: discrete, bits: 15", 1, (0x8000, 0)),
    ("type: discrete, bits: 0", True, (0x0001, 0)),
    ("type: discrete, bits: 7", 0, (0x0000, 0)),
    ("type: enum, bits: [3, 0], values: {0: A, 9: B, 15: C}", "B", (0x0009, 0)),
    ("type: enum, bits: [15, 12], values: {0: A, 9: B, 15: C}", "C", (0xF000, 0)),
    ("type: enum, bits: [15, 12], values: {0: A, 9: B, 15: C}", 9, (0x9000, 0)),
    # counters
    ("type: counter, bits: [11, 0]", 4095, (0x0FFF, 0)),
    ("type: counter", 0, (0x0000, 0)),
    # two-word values, both word orders
    ("type: unsigned, words: 2", 0x12345678, (0x1234, 0x5678)),
    ("type: unsigned, words: 2, word_order: lsw_first", 0x12345678, (0x5678, 0x1234)),
    ("type: twos, words: 2, bits: [23, 0]", -1, (0x00FF, 0xFFFF)),
    ("type: twos, words: 2, bits: [23, 0]", -(2**23), (0x0080, 0x0000)),
    ("type: twos, words: 2, bits: [19, 4]", -1, (0x000F, 0xFFF0)),
    # IEEE float32 over two words
    ("type: float32", 1.0, (0x3F80, 0x0000)),
    ("type: float32", -2.5, (0xC020, 0x0000)),
    ("type: float32", -0.0, (0x8000, 0x0000)),
    ("type: float32, word_order: lsw_first", 1.0, (0x0000, 0x3F80)),
    ("type: float32", struct.unpack(">f", b"\x7f\x7f\xff\xff")[0], (0x7F7F, 0xFFFF)),
    ("type: float32", struct.unpack(">f", b"\x00\x00\x00\x01")[0], (0x0000, 0x0001)),
    ("type: float32", math.inf, (0x7F80, 0x0000)),
    ("type: float32, lsb: 0.5, offset: 1", 3.0, (0x4080, 0x0000)),
]


def _decode(icd, words, errors=()):
    record = MonitorRecord(t_ns=123, bus="A", format=TransferFormat.RT_BC, command=0x0C20 | 2,
                           data=tuple(words), status=(0x0800,), errors=tuple(errors))
    decoded = icd.decode(record)
    assert decoded is not None
    return decoded.values["p"]


@pytest.mark.parametrize(("spec", "value", "words"), CASES)
def test_encode_gives_the_expected_words(one_parameter, spec, value, words):
    icd = one_parameter(spec)
    assert icd.encode("m", {"p": value}) == words


@pytest.mark.parametrize(("spec", "value", "words"), CASES)
def test_decode_gives_the_value_back(one_parameter, spec, value, words):
    icd = one_parameter(spec)
    s = _decode(icd, words)
    p = s.parameter
    assert s.t_ns.tolist() == [123]
    assert s.flags[0] == 0
    if isinstance(value, str):
        assert s.text(0) == value
    elif p.type.value == "float32":
        assert s.value[0] == value and math.copysign(1, s.value[0]) == math.copysign(1, value)
    else:
        assert s.value[0] == pytest.approx(float(value), abs=abs(p.scale) * 1e-6)


def test_float32_nan_round_trips_and_is_flagged(one_parameter):
    icd = one_parameter("type: float32")
    words = icd.encode("m", {"p": math.nan})
    assert words == (0x7FC0, 0x0000)
    s = _decode(icd, words)
    assert math.isnan(s.value[0])
    assert s.flags[0] == FLAG_NAN


def test_float32_nan_outside_limits_is_refused_when_strict(one_parameter):
    icd = one_parameter("type: float32, minimum: 0, maximum: 2")
    with pytest.raises(IcdRangeError):
        icd.encode("m", {"p": math.nan})
    assert icd.encode("m", {"p": math.nan}, strict=False) == (0x7FC0, 0x0000)


@pytest.mark.parametrize(("spec", "word", "flag"), [
    ("type: twos, lsb: 0.001, minimum: -30, maximum: 30", 30001, FLAG_ABOVE_MAX),
    ("type: twos, lsb: 0.001, minimum: -30, maximum: 30", 0x10000 - 30001, FLAG_BELOW_MIN),
    ("type: unsigned, lsb: 0.1, minimum: 10, maximum: 20", 99, FLAG_BELOW_MIN),
    ("type: bcd", 0x12A4, FLAG_INVALID),
    ("type: bcd", 0xF000, FLAG_INVALID),
    ("type: enum, bits: [1, 0], values: {0: A, 1: B}", 3, FLAG_INVALID),
])
def test_decode_flags_values_it_must_not_pass_silently(one_parameter, spec, word, flag):
    s = _decode(one_parameter(spec), (word, 0))
    assert s.flags[0] == flag


def test_values_at_the_limits_are_not_flagged(one_parameter):
    icd = one_parameter("type: twos, lsb: 0.001, minimum: -30, maximum: 30")
    for value in (-30.0, 30.0):
        assert _decode(icd, icd.encode("m", {"p": value})).flags[0] == 0


def test_bad_bcd_digit_decodes_as_nan(one_parameter):
    s = _decode(one_parameter("type: bcd"), (0x12A4, 0))
    assert math.isnan(s.value[0])


def test_unknown_enum_code_keeps_the_code(one_parameter):
    s = _decode(one_parameter("type: enum, bits: [1, 0], values: {0: A, 1: B}"), (3, 0))
    assert s.value[0] == 3
    assert s.text(0) == "3"


def test_missing_words_and_record_errors_are_flagged(one_parameter):
    icd = one_parameter("type: unsigned, words: 2")
    s = _decode(icd, (0x1234,))
    assert s.flags[0] == FLAG_MISSING and math.isnan(s.value[0])
    s = _decode(icd, (0x1234, 0x5678), errors=("parity",))
    assert s.flags[0] == FLAG_RECORD_ERROR and s.value[0] == 0x12345678


@pytest.mark.parametrize(("spec", "value"), [
    ("type: twos, lsb: 0.001, minimum: -30, maximum: 30", 30.0001),
    ("type: twos, lsb: 0.001, minimum: -30, maximum: 30", -30.0001),
    ("type: twos, lsb: 0.001", 32.768),
    ("type: unsigned", -1),
    ("type: unsigned", 65536),
    ("type: bcd", 10000),
    ("type: bcd", -1),
    ("type: counter, bits: [3, 0]", 16),
    ("type: discrete, bits: 0", 2),
    ("type: enum, bits: [1, 0], values: {0: A, 1: B}", 2),
    ("type: float32", 1e39),
])
def test_strict_encode_refuses_out_of_range(one_parameter, spec, value):
    icd = one_parameter(spec)
    with pytest.raises(IcdRangeError) as caught:
        icd.encode("m", {"p": value})
    assert caught.value.parameter == "p"
    assert str(caught.value).startswith("p: ")


@pytest.mark.parametrize(("spec", "value", "words"), [
    ("type: twos, lsb: 0.001, minimum: -30, maximum: 30", 31.0, (31000, 0)),
    ("type: twos, lsb: 0.001", 40.0, (0x7FFF, 0)),
    ("type: twos, lsb: 0.001", -40.0, (0x8000, 0)),
    ("type: unsigned", -5, (0, 0)),
    ("type: bcd", 123456, (0x9999, 0)),
    ("type: counter, bits: [3, 0]", 17, (1, 0)),
    ("type: float32", -1e39, (0xFF80, 0x0000)),
])
def test_loose_encode_saturates(one_parameter, spec, value, words):
    assert one_parameter(spec).encode("m", {"p": value}, strict=False) == words


@pytest.mark.parametrize(("spec", "values"), [
    ("type: unsigned", {}),
    ("type: unsigned", {"p": 1, "q": 2}),
    ("type: unsigned", {"p": "high"}),
    ("type: unsigned", {"p": math.nan}),
    ("type: twos", {"p": math.inf}),
    ("type: discrete, bits: 0", {"p": 0.5}),
    ("type: enum, bits: [1, 0], values: {0: A, 1: B}", {"p": "C"}),
])
def test_encode_refuses_missing_unknown_and_wrong_kinds(one_parameter, spec, values):
    with pytest.raises(IcdValueError):
        one_parameter(spec).encode("m", values, strict=False)


# --- properties: any raw field decodes to a value that encodes back to the same bits ----------

INTEGER_SPECS = [
    "type: unsigned, bits: [13, 2], lsb: 0.003, offset: -4.5",
    "type: twos, lsb: 0.001",
    "type: twos, bits: [9, 1], lsb: 0.37, offset: 100",
    "type: bnr, msb_weight: 90",
    "type: bnr, words: 2, msb_weight: 16384",
    "type: twos, words: 2, bits: [27, 4], lsb: 1.0e-5, word_order: lsw_first",
    "type: unsigned, words: 2, lsb: 0.25",
]


@settings(max_examples=60, deadline=None)
@given(spec=st.sampled_from(INTEGER_SPECS), w0=st.integers(0, 0xFFFF), w1=st.integers(0, 0xFFFF))
def test_any_raw_field_round_trips(one_parameter, spec, w0, w1):
    icd = one_parameter(spec)
    p = icd.message("m").parameters[0]
    s = _decode(icd, (w0, w1))
    words = icd.encode("m", {"p": float(s.value[0])})
    assert _decode(icd, words).raw[0] == s.raw[0]
    # the encoded words carry exactly the parameter's bits of the original words
    mask = ((1 << p.width) - 1) << p.lsb
    msw, lsw = p.word_indices() * (3 - p.words)
    original = (w0, w1)
    combined = (original[msw] << 16 | original[lsw]) if p.words == 2 else original[msw]
    again = (words[msw] << 16 | words[lsw]) if p.words == 2 else words[msw]
    assert again == combined & mask


@settings(max_examples=60, deadline=None)
@given(bits=st.integers(0, 0xFFFFFFFF))
def test_any_float32_bit_pattern_round_trips(one_parameter, bits):
    icd = one_parameter("type: float32")
    s = _decode(icd, (bits >> 16, bits & 0xFFFF))
    value = float(s.value[0])
    if math.isnan(value):
        assert s.flags[0] == FLAG_NAN
    else:
        assert icd.encode("m", {"p": value}) == (bits >> 16, bits & 0xFFFF)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.integers(0, 9), min_size=4, max_size=4))
def test_any_bcd_digits_round_trip(one_parameter, digits):
    icd = one_parameter("type: bcd")
    number = int("".join(map(str, digits)))
    word = int("".join(map(str, digits)), 16)
    assert icd.encode("m", {"p": number}) == (word, 0)
    assert _decode(icd, (word, 0)).value[0] == number
