"""Records -> per-parameter series: block counters, sample timing, counts, one-line rendering."""

from __future__ import annotations

import dataclasses
import random

import numpy as np
import pytest

from drivers.mil1553.record import MonitorRecord, TransferFormat
from mapr_daemon.icd.flags import FLAG_ABOVE_MAX, FLAG_AFTER_GAP
from mapr_daemon.icd.render import format_values
from mapr_daemon.icd.signals import SignalStream, collect

CHANNELS = ("dc_link_current", "phase_current_a", "phase_current_b", "phase_current_c",
            "dc_bus_voltage", "surface_position", "pwm_duty")
PERIOD_NS = 500_000


def fast_block(ema, counter, t_ns, first_sample=0.0):
    """A fast block whose samples are first_sample, +0.001, +0.002, +0.003 on every channel."""
    values = {"fast_overrun": 0, "fast_adc_fault": 0, "fast_seq": counter,
              "commutation_sector": ["S1", "S2", "S3", "S4"], "drive_direction": [1, 1, 0, 0]}
    for name in CHANNELS:
        values[name] = [first_sample + 0.001 * i for i in range(4)]
    return ema.build_record("ema_fast_block", values, t_ns)


def test_group_samples_are_timed_before_the_record(ema):
    decoded = ema.decode(fast_block(ema, 7, 10_000_000))
    s = decoded.values["phase_current_a"]
    # newest sample one period before the record, the others a period apart before it
    assert s.t_ns.tolist() == [8_000_000, 8_500_000, 9_000_000, 9_500_000]
    assert decoded.values["fast_seq"].t_ns.tolist() == [10_000_000]
    assert decoded.as_dict()["commutation_sector"] == ["S1", "S2", "S3", "S4"]


@pytest.mark.parametrize("chunk", [1, 2, 100])
def test_repeated_blocks_are_dropped_and_lost_blocks_flagged(ema, chunk):
    counters = [4094, 4095, 0, 0, 1, 4, 5]          # wraps at 4096, one repeat, two lost
    records = [fast_block(ema, c, 2_000_000 * (k + 1), 0.01 * k)
               for k, c in enumerate(counters)]
    series, stats = collect(ema, records, chunk=chunk, timebase="record")
    assert stats.repeated_blocks == 1
    assert stats.lost_blocks == 2
    s = series["phase_current_a"]
    assert len(s) == 4 * 6
    firsts = s.value[::4]
    assert firsts == pytest.approx([0.0, 0.01, 0.02, 0.04, 0.05, 0.06])   # block 3 dropped
    flagged = np.flatnonzero(s.flags & FLAG_AFTER_GAP)
    assert flagged.tolist() == [4 * 4]                  # first sample of the block after the hole
    assert series["fast_seq"].raw.tolist() == [4094, 4095, 0, 1, 4, 5]
    assert series["fast_seq"].flags.tolist() == [0, 0, 0, 0, FLAG_AFTER_GAP, 0]


def test_counter_timebase_removes_polling_jitter(ema):
    rng = random.Random(4)
    block_ns = 4 * PERIOD_NS
    records = []
    for k in range(300):
        # the terminal samples on its own steady grid; the bus controller polls late by 0-300 µs
        # (the table's latency is one period: record time - 4 periods = block's first sample)
        t_ns = 7_000_000 + (k + 1) * block_ns + rng.randrange(0, 300_000)
        records.append(fast_block(ema, k % 4096, t_ns))
    grid = 7_000_000 + np.arange(300 * 4) * PERIOD_NS
    jittery = collect(ema, records, timebase="record")[0]["dc_bus_voltage"].t_ns - grid
    assert jittery.min() >= 0 and jittery.max() - jittery.min() > 250_000
    for chunk in (7, 4096):
        steady = collect(ema, records, chunk=chunk)[0]["dc_bus_voltage"].t_ns - grid
        # never early, and once it has seen a few dozen blocks the spread shrinks from the
        # polling jitter to what the clock slack allows
        assert steady.min() >= 0
        settled = steady[4 * 50:]
        assert settled.max() - settled.min() < 30_000


def test_stream_counts_what_it_could_not_decode(ema):
    mode = MonitorRecord(t_ns=1, bus="A", format=TransferFormat.MODE, command=5 << 11 | 1 << 10 | 2,
                         status=(5 << 11,))
    unknown_sa = MonitorRecord(t_ns=2, bus="A", format=TransferFormat.RT_BC,
                               command=5 << 11 | 1 << 10 | 20 << 5 | 1, data=(1,),
                               status=(5 << 11,))
    no_response = MonitorRecord(t_ns=3, bus="B", format=TransferFormat.RT_BC,
                                command=ema.message("ema_position_feedback").command,
                                errors=("no_response",))
    stray = MonitorRecord(t_ns=4, bus="A", format=TransferFormat.UNKNOWN, command=None,
                          data=(0x1234,), errors=("orphan_words",))
    good = fast_block(ema, 0, 5_000_000)
    stream = SignalStream(ema)
    out = stream.feed([mode, unknown_sa, no_response, stray, good])
    assert stream.stats.records == 5
    assert stream.stats.unmatched == 3
    assert stream.stats.empty == 1
    assert stream.stats.decoded == 1
    assert stream.stats.data_words == 29
    assert set(out) == {p.name for p in ema.message("ema_fast_block").all_parameters()}


def test_stream_keeps_only_the_parameters_asked_for(ema):
    stream = SignalStream(ema, parameters=["phase_current_a", "fast_seq"])
    assert set(stream.feed([fast_block(ema, 1, 5_000_000)])) == {"phase_current_a", "fast_seq"}
    with pytest.raises(KeyError):
        SignalStream(ema, parameters=["no_such_thing"])


def test_format_values_shows_units_labels_and_samples(ema):
    record = ema.build_record("ema_position_command", {
        "position_command": -12.5, "drive_enable": 1, "command_mode": "POSITION",
        "command_seq": 42, "rate_limit": 120.0}, 0)
    assert format_values(ema, record) == (
        "ema_position_command: position_command=-12.500 deg drive_enable=1 "
        "command_mode=POSITION command_seq=42 rate_limit=120.0 deg/s")
    line = format_values(ema, ema.build_record("ema_fast_block", {
        **{n: [1.5 + 0.001 * i for i in range(4)] for n in CHANNELS},
        "fast_overrun": 0, "fast_adc_fault": 0, "fast_seq": 3,
        "commutation_sector": ["S1", "S2", "S3", "S4"], "drive_direction": [1, 1, 0, 0]},
        5_000_000, strict=False))
    assert "phase_current_a=[1.500 1.501 1.502 1.503] A" in line
    assert "commutation_sector=[S1 S2 S3 S4]" in line
    # duty saturates at what its 12 bits hold (loose encoding) and is flagged, not hidden
    assert "pwm_duty=[1.0237!above_max 1.0237!above_max" in line


def test_format_values_flags_out_of_range_and_skips_unknown_records(ema):
    message = ema.message("ema_position_command")
    words = list(ema.encode("ema_position_command", {
        "position_command": 0, "drive_enable": 0, "command_mode": "STANDBY", "command_seq": 0,
        "rate_limit": 0}))
    words[0] = 31_000                                    # 31 deg: beyond the 30 deg limit
    record = MonitorRecord(t_ns=0, bus="A", format=TransferFormat.BC_RT,
                           command=message.command, data=tuple(words), status=(5 << 11,))
    assert "position_command=31.000!above_max deg" in format_values(ema, record)
    assert ema.decode(record).values["position_command"].flags[0] == FLAG_ABOVE_MAX
    mode = MonitorRecord(t_ns=0, bus="A", format=TransferFormat.MODE,
                         command=5 << 11 | 1 << 10 | 2, status=(5 << 11,))
    assert format_values(ema, mode) == ""


def test_batch_decoding_of_ragged_records_equals_one_by_one(ema):
    """Short and long records take the slow stacking path; results must not change."""
    values = {"position_feedback": 1.25, "surface_rate": -3.5, "ema_ready": 1, "ema_fault": 0,
              "at_stop": 0, "mode_echo": "HOLD", "feedback_seq": 9, "command_echo": 1.0}
    good = ema.build_record("ema_position_feedback", values, 1_000)
    short = dataclasses.replace(good, t_ns=2_000, data=good.data[:2], errors=("word_count_low",))
    long = dataclasses.replace(good, t_ns=3_000, data=(*good.data, 0xFFFF),
                               errors=("word_count_high",))
    batch = ema.decode_batch([good, short, long]).series
    for k, record in enumerate((good, short, long)):
        alone = ema.decode(record).values
        for name, s in alone.items():
            np.testing.assert_array_equal(batch[name].value[k:k + 1], s.value)
            np.testing.assert_array_equal(batch[name].flags[k:k + 1], s.flags)
    assert batch["surface_rate"].value[1] == -3.5 and np.isnan(batch["mode_echo"].value[1])
    assert batch["mode_echo"].flag_names(1) == ("missing", "record_error")
