"""1553 words: fields, parity against the standard's vectors, mode codes, formatting."""

import numpy as np
import pytest

from drivers.mil1553.modecodes import MODE_CODES, direction_legal, mode_code
from drivers.mil1553.words import (
    COMMAND_FIELDS,
    COMMAND_LAYOUT,
    STATUS_FIELDS,
    CommandWord,
    StatusWord,
    field,
    parity_bit,
)

# Odd-parity bits from REFERENCE.md (the standard's examples).
PARITY_VECTORS = [(0x0000, 1), (0xFFFF, 1), (0x2C22, 0), (0x6901, 0), (0x7160, 1),
                  (0x8000, 0), (0x7FFF, 0), (0x5555, 1), (0xAAAA, 1)]


@pytest.mark.parametrize(("value", "bit"), PARITY_VECTORS)
def test_parity_bit_matches_the_standard(value: int, bit: int) -> None:
    assert parity_bit(value) == bit


def test_parity_vectorized_equals_scalar() -> None:
    values = np.arange(0, 65536, dtype=np.uint16)
    expected = np.array([(bin(v).count("1") + 1) & 1 for v in range(65536)])
    assert np.array_equal(parity_bit(values), expected)


def test_command_word_fields_and_text() -> None:
    word = CommandWord.from_value(0x2822)
    assert (word.rt, word.transmit, word.subaddress, word.count) == (5, False, 1, 2)
    assert str(word) == "RT05 R SA01 WC02"
    assert word.word_count == 2
    assert CommandWord(5, False, 1, 0).word_count == 32, "word count 0 means 32"
    assert str(CommandWord(5, True, 31, 2)) == "RT05 T MC02 (transmit status word)"
    assert CommandWord(31, False, 1, 1).is_broadcast


def test_command_word_build_uses_the_construct_layout() -> None:
    word = CommandWord(rt=5, transmit=True, subaddress=0, count=18)
    assert word.build() == word.value.to_bytes(2, "big")
    parsed = COMMAND_LAYOUT.parse(word.build())
    assert (parsed.rt, parsed.transmit, parsed.subaddress, parsed.count) == (5, True, 0, 18)


def test_command_word_rejects_out_of_range_fields() -> None:
    with pytest.raises(ValueError, match="rt=32"):
        CommandWord(32, False, 1, 1)


def test_status_word_every_bit() -> None:
    assert StatusWord.from_value(0x0400).message_error
    assert StatusWord.from_value(0x0200).instrumentation
    assert StatusWord.from_value(0x0100).service_request
    assert StatusWord.from_value(0x00E0).reserved == 7
    assert StatusWord.from_value(0x0010).broadcast_received
    assert StatusWord.from_value(0x0008).busy
    assert StatusWord.from_value(0x0004).subsystem_flag
    assert StatusWord.from_value(0x0002).dynamic_bus_control
    assert StatusWord.from_value(0x0001).terminal_flag
    for value in (0x0000, 0x2C0D, 0xFFFF, 0x07FF):
        assert StatusWord.from_value(value).value == value
    assert str(StatusWord.from_value(0x2C0D)) == "RT05 ME BUSY SSF TF"
    assert str(StatusWord.from_value(0x28A0)) == "RT05 RSV=0x5"


def test_vectorized_fields_match_the_typed_view() -> None:
    values = np.random.default_rng(3).integers(0, 65536, 5000).astype(np.uint16)
    for name in COMMAND_FIELDS:
        got = field(values, COMMAND_FIELDS, name)
        want = [int(getattr(CommandWord.from_value(int(v)), name)) for v in values]
        assert np.array_equal(got, want), name
    for name in STATUS_FIELDS:
        got = field(values, STATUS_FIELDS, name)
        want = [int(getattr(StatusWord.from_value(int(v)), name)) for v in values]
        assert np.array_equal(got, want), name


def test_mode_code_table() -> None:
    assert len(MODE_CODES) == 32
    assert not mode_code(2).has_data and not mode_code(2).broadcast_allowed
    assert mode_code(1).broadcast_allowed
    assert mode_code(17).has_data and not mode_code(17).transmit and mode_code(17).broadcast_allowed
    assert mode_code(16).has_data and mode_code(16).transmit and not mode_code(16).broadcast_allowed
    assert all(mode_code(c).reserved for c in (*range(9, 16), *range(22, 32)))
    assert not any(mode_code(c).reserved for c in (*range(0, 9), *range(16, 22)))
    assert all(mode_code(c).has_data == (c >= 16) for c in range(32))
    assert direction_legal(2, transmit=True) and not direction_legal(2, transmit=False)
    assert direction_legal(20, transmit=False) and not direction_legal(20, transmit=True)
    assert direction_legal(12, transmit=False) and direction_legal(12, transmit=True)
