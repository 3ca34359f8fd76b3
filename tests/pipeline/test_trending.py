"""An actuator's trend after each BIT, as the daemon and a replay store it: flights told from
the traffic (or declared), SoH and RUL from the per-kind degradation estimates, the BIT
history in the catalog and a restart that continues it."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from mapr_daemon.catalog import BitOutcome, CatalogWriter, Event
from mapr_daemon.catalog.model import BitRecord
from mapr_daemon.ema.params import default_actuator_path, load_actuator
from mapr_daemon.errors import ConfigError
from mapr_daemon.pipeline.trending import AssetHistory, FlightLog, Trending, history_from_bits
from mapr_daemon.reasoner.prognosis import trend
from mapr_daemon.reasoner.prognosis.prognostic_model import PrognosticModel
from mapr_daemon.reasoner.training.rul_scoring import learn_prior

T0 = 1_778_300_000_000_000_000
HOUR = 3_600_000_000_000
DAY = 24 * HOUR


@pytest.fixture(scope="module")
def model() -> PrognosticModel:
    """ESR trended with a measured-looking noise (sd 0.05 of the threshold) and the fleet
    prior of the aging model; the estimators are not needed: outcomes carry the estimates."""
    params = load_actuator(default_actuator_path())
    return PrognosticModel(params.name, {}, {"esr": trend.Noise(0.05)}, {},
                           {"esr": learn_prior(params, "esr", 8)})


def bit(flight: int, h: float, fault: str | None = None) -> BitOutcome:
    t = T0 + flight * DAY + HOUR // 2
    event = None if fault is None else Event(t_ns=t, asset="EMA1", fault=fault,
                                             confidence=0.9)
    return BitOutcome("EMA1", t, event, wear={"esr": h}, fault=fault)


def fly(trending: Trending, flight: int) -> None:
    """One flight of traffic, one hour long, seen every ten minutes; flights a day apart."""
    for minute in range(0, 61, 10):
        trending.observe(T0 + flight * DAY + minute * 60 * 10**9)


def esr(n: float) -> float:
    """ESR's degradation on its physical shape (1/ESR falls linearly), at 1 on flight 100."""
    return 1.0 / (1.0 - 0.005 * n) - 1.0


def test_a_healthy_actuator_is_soh_one_with_no_rul_and_says_why(model: PrognosticModel
                                                                ) -> None:
    trending = Trending("N101", 900.0, {"EMA1": model})
    out = []
    for n in range(1, 11):
        fly(trending, n)
        out += trending.annotate([bit(n, 0.01 * (-1) ** n)])
    last = out[-1]
    assert [o.flight for o in out] == list(range(1, 11))
    assert last.health is not None and last.health.soh == 1.0 and last.health.mode is None
    assert last.health.rul is None and "within its healthy scatter" in (last.health.note or "")


def test_a_mode_not_yet_evidenced_still_states_its_rul_from_the_trend_and_the_fleet(
        model: PrognosticModel) -> None:
    """Early wear inside one reading's scatter: the mode does not lead (no headline RUL, SoH
    1.0) but states its RUL, which brackets this unit's true end of life (flight 200, a life
    the fleet prior knows)."""
    trending = Trending("N101", 900.0, {"EMA1": model})
    out = []
    for n in range(2, 26, 2):
        trending.log.declare(n)
        fly(trending, n)
        out += trending.annotate([bit(n, esr(n / 2) + 0.02 * (-1) ** (n // 2))])
    health = out[-1].health
    assert health is not None and health.mode is None and health.rul is None
    row = health.modes["esr"]
    assert row["evidenced"] is False
    assert row["low"] is not None and row["high"] is not None
    assert row["low"] <= row["rul"] <= row["high"]
    assert row["low"] <= 200 - 24 <= row["high"]
    first = out[1].health   # BITs on two flights: no trend, no RUL of any mode
    assert first is not None and "rul" not in first.modes["esr"]


def test_a_part_stated_to_live_long_is_followed_beyond_the_default_horizon(
        model: PrognosticModel) -> None:
    """Parts stated to live 3,000 flights, early in life: the RUL is a number of flights
    (followed to three lives), not 'beyond 2,000 flights'."""
    trending = Trending("N101", 900.0, {"EMA1": model.with_lives({"esr": 3000.0})})
    out = []
    for n in range(20, 260, 20):
        trending.log.declare(n)
        fly(trending, n)
        out += trending.annotate([bit(n, 1.0 / (1.0 - n / 6000.0) - 1.0)])
    health = out[-1].health
    assert health is not None
    row = health.modes["esr"]
    assert row["rul"] is not None and row["rul"] > 2000
    with pytest.raises(ConfigError, match="beyond"):
        model.with_lives({"esr": 50_000.0})


def test_a_wearing_capacitor_leads_with_soh_and_a_rul_interval_that_holds_the_truth(
        model: PrognosticModel) -> None:
    trending = Trending("N101", 900.0, {"EMA1": model})
    out = []
    for n in range(2, 62, 2):           # a BIT every other flight, those flights recorded
        trending.log.declare(n)
        fly(trending, n)
        out += trending.annotate([bit(n, esr(n))])
    health = out[-1].health
    assert health is not None and health.mode == "esr"
    now = (esr(56) + esr(58) + esr(60)) / 3   # SoH: the mean of the last three BITs
    assert health.soh == pytest.approx(1 - now, abs=1e-6)
    assert health.rul is not None and health.rul_low is not None and health.rul_high is not None
    assert health.rul_low <= 100 - 60 <= health.rul_high
    assert health.rul_hours == pytest.approx(health.rul * 1.0, rel=1e-6)   # 1 h flights
    assert out[-1].flight_hours == pytest.approx(59.5, abs=0.01)   # unseen flights: 1 h


def test_a_terminal_fault_is_soh_zero_and_its_event_says_so(model: PrognosticModel) -> None:
    trending = Trending("", 900.0, {"EMA1": model})
    fly(trending, 1)
    (o,) = trending.annotate([bit(1, 0.0, fault="short")])
    assert o.health is not None and (o.health.soh, o.health.rul) == (0.0, 0.0)
    assert o.event is not None and o.event.soh == 0.0


def test_flights_are_told_from_gaps_in_the_traffic_or_declared() -> None:
    log = FlightLog("N101", gap_s=900.0)
    for minute in range(0, 71, 10):           # traffic every 10 min for 70 min: one flight
        log.observe(T0 + minute * 60 * 10**9)
    log.observe(T0 + 3 * HOUR)                # 1 h 50 min later: the next flight
    for minute in range(10, 31, 10):          # half an hour of it
        log.observe(T0 + 3 * HOUR + minute * 60 * 10**9)
    assert log.number == 2
    flights = log.pop_changed()
    assert [(f.flight, round(f.hours, 3), f.source) for f in flights] == \
        [(1, 1.167, "bus"), (2, 0.5, "bus")]
    log.declare(40, hours=1.5)
    log.observe(T0 + 30 * DAY)
    assert log.number == 40
    mean = (1.1667 + 0.5 + 1.5) / 3           # flights 3..39 not seen: counted at the mean
    assert log.hours_at(T0 + 30 * DAY) == pytest.approx(1.1667 + 0.5 + 37 * mean, rel=1e-3)


def test_a_bit_just_before_a_flight_gap_in_the_same_batch_stays_in_its_flight(
        model: PrognosticModel) -> None:
    """One batch of traffic (a file read in batches, a busy bus) holds the end of a flight,
    with a BIT in it, the ground gap, then the next flight's first traffic: the BIT is
    counted in the flight it was flown in, and the later traffic starts the next flight."""
    trending = Trending("N101", 900.0, {"EMA1": model})
    fly(trending, 1)                          # flight 1: an hour of traffic, a day in
    flown = bit(1, 0.05)                      # half an hour into flight 1
    later = flown.t_ns + 3 * HOUR             # after the ground gap, in the same batch
    (o,) = trending.annotate_batch([flown], later)
    assert o.flight == 1
    assert trending.log.number == 2           # the batch's last traffic: the next flight
    ten_minutes = 600 * 10**9
    (after,) = trending.annotate_batch([dataclasses.replace(flown, t_ns=later + ten_minutes)],
                                       None)
    assert after.flight == 2


def test_the_history_is_stored_and_a_restart_continues_the_trend(
        model: PrognosticModel, tmp_path: Path) -> None:
    path = tmp_path / "c.sqlite"
    first = Trending("N101", 900.0, {"EMA1": model})
    with CatalogWriter(path) as writer:
        writer.open_session(backend="chapter10", config_hash="x")
        for n in range(2, 32, 2):
            first.log.declare(n)
            fly(first, n)
            writer.add_bits(first.annotate([bit(n, esr(n))]), first.log.pop_changed())
        bits, flights, _ = writer.history("N101")
    assert [b.flight for b in bits] == list(range(2, 32, 2))
    assert bits[-1].health.mode == "esr" and bits[-1].wear == {"esr": esr(30)}
    assert [f.flight for f in flights] == list(range(2, 32, 2))
    resumed = Trending("N101", 900.0, {"EMA1": model},
                       {"EMA1": _history(bits)}, flights)
    fly(resumed, 40)
    (o,) = resumed.annotate([bit(40, esr(40))])
    assert o.flight == 31 and o.health is not None   # traffic after a gap: the next flight
    assert o.health.mode == "esr" and o.health.rul is not None


def _history(bits: list[BitRecord]) -> AssetHistory:
    return AssetHistory([float(b.flight) for b in bits], [dict(b.wear) for b in bits])


NOMINAL = {"dynamic_pressure_pa": 1000.0, "supply_v": 28.0, "ambient_c": 25.0}
LOW_BUS = {"dynamic_pressure_pa": 1000.0, "supply_v": 23.0, "ambient_c": 25.0}


@pytest.fixture(scope="module")
def condition_model(model: PrognosticModel) -> PrognosticModel:
    """ESR whose estimate scatters by sd 0.02 at the nominal 28 V bus and 0.1 at 23 V (the
    log-sd model: 0.02 * exp(-0.322 * (V - 28)))."""
    noise = trend.Noise(0.05, log_sd=(float(np.log(0.02)), 0.0, -0.322, 0.0, 0.0, 0.0, 0.0))
    return PrognosticModel(model.actuator, {}, {"esr": noise}, {}, dict(model.priors),
                           supply_nominal_v=28.0)


def test_a_small_wear_is_evidenced_on_bits_flown_at_nominal_supply_only(
        condition_model: PrognosticModel) -> None:
    """The same three estimates (0.08 of the threshold): flown at the nominal bus they are
    wear (3 SE above healthy); flown at the bus's low limit, where the estimate is five times
    noisier, they are within the healthy scatter."""
    health = {}
    for name, cond in (("nominal", NOMINAL), ("low bus", LOW_BUS)):
        trending = Trending("N101", 900.0, {"EMA1": condition_model})
        for n in (1, 2, 3):
            trending.log.declare(n)
            fly(trending, n)
            (o,) = trending.annotate([dataclasses.replace(bit(n, 0.08), conditions=cond)])
        health[name] = o.health
    assert health["nominal"] is not None and health["nominal"].mode == "esr"
    assert health["low bus"] is not None and health["low bus"].mode is None


def test_the_conditions_are_stored_and_reloaded_with_the_history(
        condition_model: PrognosticModel, tmp_path: Path) -> None:
    """Two BITs flown at the bus's low limit (sd 0.1 there) are stored; resumed from the
    catalog as the daemon resumes (history_from_bits), a third at nominal supply still finds
    no wear.
    Had the conditions been lost, the two would be weighed by the envelope-wide sd (0.01 in
    this model) and the same readings would count as wear."""
    path = tmp_path / "c.sqlite"
    model = dataclasses.replace(condition_model, noise={"esr": dataclasses.replace(
        condition_model.noise["esr"], sd0=0.01)})
    first = Trending("N101", 900.0, {"EMA1": model})
    with CatalogWriter(path) as writer:
        writer.open_session(backend="chapter10", config_hash="x")
        for n in (1, 2):
            first.log.declare(n)
            fly(first, n)
            writer.add_bits(first.annotate([dataclasses.replace(bit(n, 0.05),
                                                                conditions=LOW_BUS)]),
                            first.log.pop_changed())
        bits, flights, _ = writer.history("N101")
    assert [dict(b.conditions) for b in bits] == [LOW_BUS, LOW_BUS]
    resumed = Trending("N101", 900.0, {"EMA1": model}, history_from_bits(bits), flights)
    resumed.log.declare(3)
    fly(resumed, 3)
    (o,) = resumed.annotate([dataclasses.replace(bit(3, 0.05), conditions=NOMINAL)])
    assert o.health is not None and o.health.mode is None
    lost = Trending("N101", 900.0, {"EMA1": model}, {"EMA1": _history(bits)}, flights)
    lost.log.declare(3)
    fly(lost, 3)
    (o,) = lost.annotate([dataclasses.replace(bit(3, 0.05), conditions=NOMINAL)])
    assert o.health is not None and o.health.mode == "esr"   # conditions dropped: "wear"


def test_a_reading_flown_where_the_estimate_is_poor_does_not_set_the_soh(
        condition_model: PrognosticModel) -> None:
    """Two BITs at the nominal bus read 0.3 of the threshold, a third at the bus's low limit
    (five times noisier there) reads 0.9: SoH follows the good readings (0.69), not their
    plain mean (0.5)."""
    trending = Trending("N101", 900.0, {"EMA1": condition_model})
    for n, (h, cond) in enumerate(((0.3, NOMINAL), (0.3, NOMINAL), (0.9, LOW_BUS)), start=1):
        trending.log.declare(n)
        fly(trending, n)
        (o,) = trending.annotate([dataclasses.replace(bit(n, h), conditions=cond)])
    assert o.health is not None and o.health.mode == "esr"
    assert o.health.soh == pytest.approx(1.0 - (2 * 2500 * 0.3 + 100 * 0.9) / 5100, abs=0.01)
