"""The EMA testbed table: its schedule, its bus load, and traffic that decodes to what was sent."""

from __future__ import annotations

import numpy as np
import pytest

from mapr_daemon.icd import ParamType
from mapr_daemon.icd.signals import collect
from mapr_daemon.icd.traffic import pattern_value, pattern_values, schedule_records

# Hand count, 10 µs response and 10 µs gap: words x 20 µs + responses x 10 + 10 µs.
EXPECTED_US = {
    "ema_fast_block": (500, 31 * 20 + 10 + 10),       # cmd, status, 29 data
    "ema_power_block": (500, 15 * 20 + 10 + 10),      # cmd, status, 13 data
    "ema_position_command": (100, 5 * 20 + 10 + 10),  # cmd, 3 data, status
    "ema_position_feedback": (100, 6 * 20 + 10 + 10),
    "adc_air_data": (50, 14 * 20 + 10 + 10),
    "ema_slow_block": (20, 13 * 20 + 10 + 10),
    "ema_air_data": (10, 6 * 20 + 2 * 10 + 10),       # 2 cmds, 2 statuses, 2 data
    "ema_bit_request": (1, 3 * 20 + 10 + 10),
    "ema_bit_result": (1, 4 * 20 + 10 + 10),
}


def test_the_table_describes_the_testbed(ema):
    assert {t.name: t.address for t in ema.terminals} == {"ema": 5, "adc": 6}
    for name in ("position_command", "position_feedback", "dc_link_current",
                 "phase_current_a", "phase_current_b", "phase_current_c", "dc_bus_voltage",
                 "surface_position", "motor_temperature", "smps_input_voltage",
                 "smps_input_current", "power_stage_temperature", "smps_ripple_rms",
                 "pressure_altitude", "calibrated_airspeed", "true_airspeed",
                 "static_pressure", "static_air_temperature", "air_density",
                 "dynamic_pressure"):
        _, parameter = ema.parameter(name)
        assert parameter.unit, name
        assert parameter.minimum is not None and parameter.maximum is not None
    command, _ = ema.parameter("position_command")
    feedback, _ = ema.parameter("position_feedback")
    assert (command.rt, command.tr) == (5, "R") and (feedback.rt, feedback.tr) == (5, "T")
    assert command.subaddress != feedback.subaddress
    assert ema.parameter("bit_request")[0].tr == "R"


def test_every_periodic_message_is_scheduled_at_its_rate(ema):
    schedule = ema.schedule
    rates = {e.message: schedule.rate_hz(e) for e in schedule.entries}
    assert rates == {m.name: m.rate_hz for m in ema.messages}
    assert rates == {name: rate for name, (rate, _) in EXPECTED_US.items()}


def test_bus_load_matches_a_hand_count(ema):
    load = ema.bus_load()
    expected = sum(rate * us for rate, us in EXPECTED_US.values()) / 1e6
    assert load.load == pytest.approx(expected)
    assert load.load == pytest.approx(0.52828)
    assert load.busiest_frame_us == 640 + 320 + 300    # fast, power, air data in frame 2
    assert load.peak_frame_load < 0.75
    assert load.data_words_per_s == 500 * 29 + 500 * 13 + 100 * 3 + 100 * 4 + 50 * 12 \
        + 20 * 11 + 10 * 2 + 1 + 2


def test_fast_channels_get_2_khz(ema):
    for name in ("ema_fast_block", "ema_power_block"):   # every channel the reasoner compares
        message = ema.message(name)
        assert message.group.sample_rate_hz == 2000
        assert message.group.samples * message.rate_hz == 2000


def _values_at_limits(message, which):
    """Values of every parameter of ``message`` at its minimum (0), maximum (1) or middle."""
    def one(p):
        if p.type is ParamType.ENUM:
            labels = sorted(p.labels.items())
            return labels[0 if which == 0 else -1][1]
        if p.type in (ParamType.DISCRETE, ParamType.COUNTER):
            return 0 if which == 0 else (1 << p.width) - 1
        lo = p.minimum if p.minimum is not None else p.raw_min * p.scale + p.offset
        hi = p.maximum if p.maximum is not None else p.raw_max * p.scale + p.offset
        return (lo, hi, (lo + hi) / 2)[which]
    values = {p.name: one(p) for p in message.parameters}
    if message.group:
        values.update({c.name: [one(c)] * message.group.samples for c in message.group.channels})
    return values


@pytest.mark.parametrize("which", [0, 1, 2], ids=["minimum", "maximum", "middle"])
def test_every_message_round_trips_at_its_limits(ema, which):
    for message in ema.messages:
        values = _values_at_limits(message, which)
        record = ema.build_record(message.name, values, 5_000_000)
        decoded = ema.decode(record)
        assert decoded is not None and decoded.message is message
        for name, series in decoded.values.items():
            p = series.parameter
            assert not series.flags.any(), (name, series.flags)
            sent = values[name] if isinstance(values[name], list) else [values[name]]
            for i, v in enumerate(sent):
                if isinstance(v, str):
                    assert series.text(i) == v
                elif p.type is ParamType.FLOAT32:
                    assert series.value[i] == pytest.approx(v, rel=1e-7)
                else:
                    assert series.value[i] == pytest.approx(v, abs=abs(p.scale) / 2 + 1e-9)


def test_rt_to_rt_records_decode_from_either_command(ema):
    record = ema.build_record("ema_air_data",
                              {"ema_dynamic_pressure": 392.1, "ema_true_airspeed": 25.0}, 0)
    assert record.rt == 5 and record.rt2 == 6 and record.sa2 == 2
    assert ema.match(record).name == "ema_air_data"
    assert ema.lookup(6, "T", 2).name == "ema_air_data"
    assert ema.decode(record).value("ema_dynamic_pressure") == pytest.approx(392.1)


def test_one_second_of_schedule_traffic_decodes_to_what_the_terminals_sent(ema):
    """Ten major frames' worth of records, encoded by the table, decode back to the pattern."""
    records = list(schedule_records(ema, pattern_values, frames=500, start_ns=3_000_000_000))
    assert len(records) == sum(rate for rate, _ in EXPECTED_US.values())
    series, stats = collect(ema, records, chunk=300)
    assert stats.unmatched == stats.empty == stats.repeated_blocks == stats.lost_blocks == 0
    assert stats.data_words == ema.bus_load().data_words_per_s
    for name, s in series.items():
        p = s.parameter
        assert not s.flags.any(), name
        if name in ("fast_seq", "power_seq", "slow_seq"):   # block counters: checked by the stream
            continue
        expected = np.array([pattern_value(p, int(t)) for t in s.t_ns])
        if p.type is ParamType.ENUM:
            assert [s.text(i) for i in range(len(s))] == list(expected), name
        else:
            # rounding to the LSB, plus the pattern's slope over 1 µs of timing slack
            span = (p.maximum - p.minimum) if p.maximum is not None else 16.0
            slope_us = span * 0.45 * 2 * np.pi * 1.7 * 1e-6
            slack = abs(p.scale) / 2 + slope_us if p.type is not ParamType.FLOAT32 else 1e-6
            assert np.allclose(s.value, expected.astype(float), rtol=1e-6, atol=slack), name
    fast = series["phase_current_a"]
    assert len(fast) == 2000
    assert np.abs(np.diff(fast.t_ns) - 500_000).max() < 1_000    # uniform 2 kHz within 1 µs
    assert len(series["smps_ripple_rms"]) == 2000
    assert len(series["motor_temperature"]) == 100
    assert len(series["position_command"]) == 100

