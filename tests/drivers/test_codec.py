"""Manchester-II codec: property tests over random words, rates, chunkings and impairments.

What a bus engineer relies on: within the receiver tolerances every word decodes exactly;
a corrupted word is never reported clean; the decoder never crashes and keeps decoding.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from drivers.mil1553.decoder import ManchesterDecoder, decode_capture
from drivers.mil1553.encoder import Impairments, WordFault, encode_words
from drivers.mil1553.wordbatch import (
    WORD_DTYPE,
    WordBatch,
    empty_words,
    error_names,
    make_words,
)

FAST = settings(max_examples=150, deadline=None,
                suppress_health_check=[HealthCheck.too_slow])


def random_words(seed: int, n: int, min_gap_ns: int = 20_050, both_buses: bool = True
                 ) -> WordBatch:
    """``n`` random words, contiguous or with gaps, on one or both buses."""
    rng = np.random.default_rng(seed)
    words = empty_words(n)
    gaps = rng.choice([min_gap_ns, min_gap_ns, max(22_000, min_gap_ns), 31_700, 60_000], n)
    words["t_ns"] = int(rng.integers(0, 3000)) + np.cumsum(gaps) - gaps[0]
    words["bus"] = rng.integers(0, 2, n) if both_buses else 0
    words["sync"] = rng.integers(0, 2, n)
    words["value"] = rng.integers(0, 65536, n)
    return words


def decode_in_chunks(samples: np.ndarray, rate: float, cuts: list[int]) -> WordBatch:
    decoder = ManchesterDecoder(rate)
    parts, start = [], 0
    for cut in sorted(set(cuts)):
        parts.append(decoder.feed(samples[start:cut]))
        start = cut
    parts.append(decoder.feed(samples[start:]))
    parts.append(decoder.flush())
    return np.concatenate(parts)


def assert_exact(decoded: WordBatch, sent: WordBatch, rate: float, time_tol_ns: float) -> None:
    sent = np.sort(sent, order="t_ns")
    assert decoded.size == sent.size, f"{decoded.size} words decoded, {sent.size} sent"
    assert decoded.dtype == WORD_DTYPE
    flagged = [error_names(int(e)) for e in decoded["errors"] if e]
    assert not flagged, flagged[:3]
    assert np.array_equal(decoded["value"], sent["value"])
    assert np.array_equal(decoded["sync"], sent["sync"])
    assert np.array_equal(decoded["bus"], sent["bus"])
    assert np.max(np.abs(decoded["t_ns"] - sent["t_ns"])) <= time_tol_ns + 1e9 / rate


@FAST
@given(seed=st.integers(0, 2**32 - 1), rate=st.floats(10e6, 50e6),
       jitter=st.floats(0, 120), dead_band=st.floats(0, 100), rate_error=st.floats(-1e-3, 1e-3),
       data=st.data())
def test_round_trip_within_tolerances_any_rate_any_chunking(
        seed: int, rate: float, jitter: float, dead_band: float, rate_error: float,
        data: st.DataObject) -> None:
    words = random_words(seed, 40)
    imp = Impairments(rate_error=rate_error, jitter_ns=jitter, dead_band_ns=dead_band, seed=seed)
    samples = encode_words(words, rate, impairments=imp)
    cuts = data.draw(st.lists(st.integers(0, samples.size), max_size=12))
    assert_exact(decode_in_chunks(samples, rate, cuts), words, rate, time_tol_ns=100)


@FAST
@given(seed=st.integers(0, 2**32 - 1), rate=st.floats(10e6, 50e6), data=st.data())
def test_chunked_decoding_equals_one_call(seed: int, rate: float, data: st.DataObject) -> None:
    """Streaming gives exactly the words one call on the whole capture gives, errors and
    noise bursts included, wherever the chunks split the capture."""
    rng = np.random.default_rng(seed)
    words = random_words(seed, 30, min_gap_ns=24_000)
    faults = [WordFault(parity=True) if rng.random() < 0.2 else WordFault()
              for _ in range(words.size)]
    imp = Impairments(jitter_ns=150, dead_band_ns=100, rate_error=1e-3, glitch_probability=0.3,
                      seed=seed)
    samples = encode_words(words, rate, impairments=imp, faults=faults)
    noise = np.random.default_rng(seed).integers(0, 16, 400, dtype=np.uint8)
    samples = np.concatenate([samples, noise, samples])
    cuts = data.draw(st.lists(st.integers(0, samples.size), max_size=20))
    whole = decode_capture(samples, rate)
    assert np.array_equal(decode_in_chunks(samples, rate, cuts), whole)


@FAST
@given(seed=st.integers(0, 2**32 - 1), rate=st.floats(10e6, 50e6), data=st.data())
def test_chunked_decoding_equals_one_call_on_back_to_back_words(
        seed: int, rate: float, data: st.DataObject) -> None:
    """A fully loaded bus under the worst-case stack: where a word ends and the next one's
    sync starts (or a sync-like pattern at the end of a word) must not depend on where a
    chunk ends, nor a noise burst's extent on where a chunk cuts through it."""
    rng = np.random.default_rng(seed)
    words = random_words(seed, 60, min_gap_ns=20_050)
    words["t_ns"] = 20_050 * np.arange(words.size) + rng.integers(0, 2000)
    imp = Impairments(jitter_ns=150, dead_band_ns=100, rate_error=1e-3, seed=seed)
    samples = encode_words(words, rate, impairments=imp)
    noise = rng.integers(0, 16, 2000, dtype=np.uint8)
    samples = np.concatenate([samples, noise, samples])
    cuts = data.draw(st.lists(st.integers(0, samples.size), min_size=5, max_size=60))
    whole = decode_capture(samples, rate)
    assert np.array_equal(decode_in_chunks(samples, rate, cuts), whole)


def test_a_chunk_ending_just_past_a_word_does_not_change_it() -> None:
    """Found on the benchmark's capture (bench/codec.py, worst case): a chunk ending 25.5 µs
    after a word's sync once cut the grid fit of the next word's sync short, which then
    went unrecognized, and the word was flagged ``bit_count_high``."""
    n = 24_962
    words = empty_words(n)
    words["t_ns"] = np.arange(n) * 20_030
    words["bus"] = (np.arange(n) // 32) % 2
    words["sync"] = np.arange(n) % 32 == 0
    words["value"] = np.random.default_rng(1).integers(0, 65536, n)
    imp = Impairments(jitter_ns=150, dead_band_ns=100, rate_error=1e-3, seed=3)
    samples = encode_words(words, 10e6, impairments=imp)[780_000:792_000]
    whole = decode_capture(samples, 10e6)
    assert np.array_equal(decode_in_chunks(samples, 10e6, [6_432]), whole)


@FAST
@given(seed=st.integers(0, 2**32 - 1), rate=st.floats(16e6, 50e6),
       rate_error=st.sampled_from([-1e-3, 1e-3]))
def test_worst_case_stack_is_exact_from_16_msps(seed: int, rate: float, rate_error: float) -> None:
    """Every crossing independently at up to +/-150 ns, a 100 ns dead band, 0.1 % rate."""
    words = random_words(seed, 60)
    imp = Impairments(rate_error=rate_error, jitter_ns=150, dead_band_ns=100, seed=seed)
    assert_exact(decode_capture(encode_words(words, rate, impairments=imp), rate), words, rate,
                 time_tol_ns=120)


FAULTS = [
    (WordFault(parity=True), "parity"),
    *[(WordFault(no_transition=b), "manchester") for b in (0, 1, 5, 15, 16)],
    *[(WordFault(bit_count=n), "bit_count_low") for n in (-1, -2, -5)],
    *[(WordFault(bit_count=n), "bit_count_high") for n in (1, 2)],
]


@FAST
@given(seed=st.integers(0, 2**32 - 1), rate=st.floats(10e6, 50e6),
       jitter=st.floats(0, 120), dead_band=st.floats(0, 100),
       choice=st.lists(st.integers(0, len(FAULTS)), min_size=30, max_size=30))
def test_every_injected_fault_is_flagged_with_its_class(
        seed: int, rate: float, jitter: float, dead_band: float, choice: list[int]) -> None:
    words = random_words(seed, 30, min_gap_ns=24_000)
    faults = [FAULTS[c][0] if c < len(FAULTS) else WordFault() for c in choice]
    imp = Impairments(jitter_ns=jitter, dead_band_ns=dead_band, rate_error=5e-4, seed=seed)
    decoded = decode_capture(encode_words(words, rate, impairments=imp, faults=faults), rate)
    for word, c in zip(words, choice, strict=True):
        near = decoded[np.abs(decoded["t_ns"] - word["t_ns"]) < 400]
        near = near[near["bus"] == word["bus"]]
        assert near.size == 1, f"word at {word['t_ns']} decoded {near.size} times"
        errors = error_names(int(near["errors"][0]))
        if c < len(FAULTS):
            assert FAULTS[c][1] in errors, f"{FAULTS[c][0]} flagged as {errors}"
        elif not errors:
            assert near["value"][0] == word["value"]


def clean_words_match_what_was_sent(words: WordBatch, faults: list[WordFault],
                                    decoded: WordBatch, faulted_may_be_clean: bool) -> None:
    for row in decoded[decoded["errors"] == 0]:
        k = np.flatnonzero((np.abs(words["t_ns"] - row["t_ns"]) < 400) &
                           (words["bus"] == row["bus"]))
        assert k.size == 1, f"clean word at {row['t_ns']} ns was never sent"
        sent = words[k[0]]
        assert faulted_may_be_clean or not faults[k[0]].any, f"{faults[k[0]]} reported clean"
        assert (row["value"], row["sync"]) == (sent["value"], sent["sync"])


def faulted_words(seed: int, fault_rate: float) -> tuple[WordBatch, list[WordFault]]:
    rng = np.random.default_rng(seed)
    words = random_words(seed, 40, min_gap_ns=24_000)
    faults = [FAULTS[int(rng.integers(len(FAULTS)))][0] if rng.random() < fault_rate
              else WordFault() for _ in range(words.size)]
    return words, faults


@FAST
@given(seed=st.integers(0, 2**32 - 1), rate=st.floats(10e6, 50e6),
       jitter=st.floats(0, 150), dead_band=st.floats(0, 100), fault_rate=st.floats(0, 0.5))
def test_a_corrupted_word_is_never_reported_clean(
        seed: int, rate: float, jitter: float, dead_band: float, fault_rate: float) -> None:
    words, faults = faulted_words(seed, fault_rate)
    imp = Impairments(jitter_ns=jitter, dead_band_ns=dead_band, rate_error=-1e-3, seed=seed)
    decoded = decode_capture(encode_words(words, rate, impairments=imp, faults=faults), rate)
    clean_words_match_what_was_sent(words, faults, decoded, faulted_may_be_clean=False)


@FAST
@given(seed=st.integers(0, 2**32 - 1), rate=st.floats(10e6, 50e6),
       jitter=st.floats(0, 150), dead_band=st.floats(0, 100), glitches=st.floats(0, 0.5),
       fault_rate=st.floats(0, 0.5))
def test_with_glitches_a_clean_word_is_always_the_word_sent(
        seed: int, rate: float, jitter: float, dead_band: float, glitches: float,
        fault_rate: float) -> None:
    """Below 20 MS/s a one-sample glitch can fall where a missing transition should be and
    restore it; what must never happen is a clean word with another value than was sent."""
    words, faults = faulted_words(seed, fault_rate)
    imp = Impairments(jitter_ns=jitter, dead_band_ns=dead_band, rate_error=-1e-3,
                      glitch_probability=glitches, seed=seed)
    decoded = decode_capture(encode_words(words, rate, impairments=imp, faults=faults), rate)
    clean_words_match_what_was_sent(words, faults, decoded,
                                    faulted_may_be_clean=rate < 20e6)


def test_glitches_are_removed_from_20_msps() -> None:
    words = random_words(7, 200)
    imp = Impairments(glitch_probability=1.0, seed=7)
    for rate in (20e6, 24e6, 50e6):
        assert_exact(decode_capture(encode_words(words, rate, impairments=imp), rate), words,
                     rate, time_tol_ns=60)


def test_inverted_sync_decodes_as_the_other_sync_type() -> None:
    """A word with the wrong sync is a valid word of the other type: the message level
    (which expects a command or a data word there) is where it gets flagged."""
    words = make_words([(1000, 0, 1, 0x2822), (40_000, 1, 0, 0x1234)])
    faults = [WordFault(inverted_sync=True), WordFault(inverted_sync=True)]
    decoded = decode_capture(encode_words(words, 10e6, faults=faults), 10e6)
    assert list(decoded["sync"]) == [0, 1]
    assert list(decoded["value"]) == [0x2822, 0x1234]


@settings(max_examples=60, deadline=None)
@given(blob=st.binary(min_size=0, max_size=20_000), rate=st.floats(10e6, 50e6))
def test_random_bytes_never_crash_and_decoding_goes_on(blob: bytes, rate: float) -> None:
    good = make_words([(0, 0, 1, 0x2822), (20_000, 0, 0, 0xBEEF)])
    tail = encode_words(good, rate)
    decoder = ManchesterDecoder(rate)
    junk = decoder.feed(np.frombuffer(blob, dtype=np.uint8))
    # Two quiet microseconds... then real traffic must still come through.
    quiet = np.zeros(int(3e-6 * rate), dtype=np.uint8)
    rest = np.concatenate([decoder.feed(quiet), decoder.feed(tail), decoder.flush()])
    assert junk.dtype == WORD_DTYPE
    clean = rest[rest["errors"] == 0]
    assert [int(v) for v in clean["value"][-2:]] == [0x2822, 0xBEEF]


def test_truncated_capture_flags_the_cut_word() -> None:
    words = make_words([(1000, 0, 1, 0x2822), (30_000, 0, 0, 0x5555)])
    samples = encode_words(words, 10e6)
    cut = samples[: int(41e-6 * 10e6)]  # the second word stops after ~11 of its 20 µs
    decoded = decode_capture(cut, 10e6)
    assert decoded.size == 2
    assert error_names(int(decoded["errors"][0])) == []
    assert "bit_count_low" in error_names(int(decoded["errors"][1]))


def test_both_buses_in_one_stream() -> None:
    words = make_words([(1000, 0, 1, 0x2822), (1500, 1, 1, 0x4C41), (21_000, 0, 0, 0xAAAA)])
    decoded = decode_capture(encode_words(words, 24e6), 24e6)
    assert [(int(b), int(v)) for b, v in zip(decoded["bus"], decoded["value"], strict=True)] == \
        [(0, 0x2822), (1, 0x4C41), (0, 0xAAAA)]


@pytest.mark.parametrize("value", [0x8000, 0x7FFF, 0x0000, 0xFFFF, 0x5555, 0xAAAA])
@pytest.mark.parametrize("rate", [10e6, 12e6, 24e6, 50e6])
def test_the_standards_symmetry_patterns(value: int, rate: float) -> None:
    words = make_words([(1000, 0, 1, value), (21_000, 0, 0, value), (50_000, 1, 0, value)])
    decoded = decode_capture(encode_words(words, rate), rate)
    assert_exact(decoded, words, rate, time_tol_ns=0)
