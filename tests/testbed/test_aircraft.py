"""The simulated aircraft on the loopback bus: the ICD's schedule, terminals that encode with
the ICD, and a monitor that decodes what they encoded — at the bit level."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np
import pytest

from drivers.backends.loopback import LoopbackMonitor
from mapr_daemon.ema.params import default_actuator_path, load_actuator, with_sample_rate
from mapr_daemon.icd import collect, load_icd
from mapr_daemon.testbed.aircraft import Aircraft
from mapr_daemon.testbed.profiles_jsbsim import jsbsim_flight

ICD = Path(__file__).parents[2] / "configs" / "icd" / "ema-testbed.yaml"


@pytest.fixture(scope="module")
def flown() -> tuple[Aircraft, list, dict[tuple[int, int], list[tuple[int, list[int]]]]]:
    icd = load_icd(ICD)
    params = with_sample_rate(load_actuator(default_actuator_path()), 2000.0)
    aircraft = Aircraft(icd, jsbsim_flight(2000.0, "cruise", duration_s=0.6), params)
    terminals = aircraft.terminals()
    sent: dict[tuple[int, int], list[tuple[int, list[int]]]] = {}
    for terminal in terminals:  # log every word a terminal puts on the bus
        for sa, callback in list(terminal.transmit.items()):
            terminal.transmit[sa] = _logged(callback, sent.setdefault((terminal.address, sa),
                                                                      []))
    with LoopbackMonitor(terminals=terminals, schedule=aircraft.schedule(), frames=300,
                         bit_level=True) as monitor:
        records = list(monitor)
    return aircraft, records, sent


def _logged(callback: Callable[[int], Sequence[int]], log: list[tuple[int, list[int]]]
            ) -> Callable[[int], Sequence[int]]:
    def wrapper(t_ns: int) -> Sequence[int]:
        words = [int(w) & 0xFFFF for w in callback(t_ns)]
        log.append((t_ns, words))
        return words
    return wrapper


def test_the_schedule_is_the_icds(flown) -> None:
    aircraft, records, _ = flown
    names = {aircraft.icd.match(r).name for r in records if aircraft.icd.match(r)}
    assert names >= {"ema_fast_block", "ema_position_command", "ema_position_feedback",
                     "adc_air_data", "ema_slow_block", "ema_air_data"}
    fast = [r for r in records if r.sa == 10 and r.rt == 5]
    assert len(fast) == 300, "the fast block goes in every 2 ms minor frame"
    assert all(r.errors == () for r in records), [r.to_json() for r in records if r.errors][:2]


def test_every_word_decoded_is_the_word_the_terminal_encoded(flown) -> None:
    _, records, sent = flown
    for (rt, sa), log in sent.items():
        seen = [list(r.data) for r in records if (r.rt2 == rt and r.sa2 == sa) or
                (r.rt == rt and r.sa == sa and r.tr == "T")]
        assert seen == [words for _, words in log], (rt, sa)


def test_the_table_decodes_the_values_the_aircraft_put_on_the_bus(flown) -> None:
    aircraft, records, _ = flown
    series, _ = collect(aircraft.icd, records)
    flight = aircraft.profile
    cmd = series["position_command"]
    expected = np.interp(cmd.t_ns / 1e9, flight.time_s, flight.command_deg)
    assert np.max(np.abs(cmd.value - expected)) < 0.01  # one profile step, plus the 1 mdeg LSB
    tas = series["true_airspeed"]
    assert np.allclose(tas.value, np.interp(tas.t_ns / 1e9, flight.time_s, flight.airspeed_mps),
                       atol=0.01)
    position = series["surface_position"]
    assert position.value.size == 300 * 4
    # The last fast block's samples are the plant's, latched one period before the poll: the
    # EMA took samples up to the last poll of the flight (the power block's, one sample later).
    history = aircraft.ema.history["position_deg"]
    last_poll = max(r.t_ns for r in records if r.rt == 5 and r.sa == 10)
    newest = round(last_poll * aircraft.ema.rate_hz / 1e9) - 1   # index of the newest handed
    behind = aircraft.ema.samples_done - 1 - newest               # samples taken after it
    assert np.allclose(position.value[-50:], history[-51 - behind:-1 - behind], atol=0.0011), \
        "the last block's samples are the plant's, latched one period before the poll"
    assert np.all(series["dc_bus_voltage"].value[-100:] > 22)
