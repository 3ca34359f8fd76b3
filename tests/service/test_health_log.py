"""The daemon's health lines: a state change is one line, a persistent fault is not one per
BIT; an input slower than real time and a growing queue are said once (no clock: the
checks are fed numbers)."""

from __future__ import annotations

import logging

from mapr_daemon.catalog import BitOutcome
from mapr_daemon.catalog.episodes import Detection, opened
from mapr_daemon.findings import Health
from mapr_daemon.service.config import Config, parse
from mapr_daemon.service.health_log import HealthLog, Pace


def _bit(k: int, soh: float, rul: float | None = None) -> BitOutcome:
    health = Health(soh, "esr", rul, None if rul is None else rul * 0.7,
                    None if rul is None else rul * 1.4)
    return BitOutcome("EMA1", k, health=health)


def test_a_persistent_fault_is_one_line_per_change_not_per_bit() -> None:
    hl = HealthLog("N9", rul_warn_flights=10.0)
    first = hl.observe([_bit(0, 0.9, 80.0)])
    assert [lvl for lvl, _ in first] == [logging.INFO]
    assert first[0][1].startswith("N9/EMA1 health: SoH 0.90 (esr: 10 % of the way")
    assert hl.observe([_bit(k, 0.85, 70.0) for k in range(1, 6)]) == []   # same band
    fell = hl.observe([_bit(6, 0.7, 40.0), _bit(7, 0.69, 39.0)])
    assert len(fell) == 1 and fell[0][0] == logging.WARNING
    assert "SoH fell to 0.70 (band 0.50-0.75, was 0.75-1.00)" in fell[0][1]
    low = hl.observe([_bit(8, 0.6, 12.0), _bit(9, 0.58, 11.0)])   # low end 8.4, 7.7
    assert len(low) == 1 and low[0][0] == logging.WARNING
    assert "RUL 12 (8.4-17) flights (esr): below health.rul_warn_flights 10" in low[0][1]
    back = hl.observe([_bit(10, 0.95, None)])   # repaired: band up, RUL gone
    assert [lvl for lvl, _ in back] == [logging.INFO, logging.INFO]
    assert "SoH rose to 0.95" in back[0][1] and "RUL back above 10 flights" in back[1][1]


def test_episodes_opened_and_closed_are_said_once() -> None:
    hl = HealthLog("N9", rul_warn_flights=None)
    old = opened(1, Detection("EMA2", "motor and gear", "friction", 0, 0.4))
    assert hl.episodes_now({("EMA2", "motor and gear"): old}) == []   # open at start: noted
    new = opened(2, Detection("EMA1", "SMPS output capacitor", "esr", 5, 0.5))
    both = {("EMA2", "motor and gear"): old, ("EMA1", "SMPS output capacitor"): new}
    lines = hl.episodes_now(both)
    assert lines == [(logging.WARNING, "episode 2 opened: N9/EMA1 SMPS output capacitor (esr); "
                                       "`mapr catalog episodes` follows it")]
    assert hl.episodes_now(both) == []   # the same fault at the next BITs: nothing
    lines = hl.episodes_now({("EMA1", "SMPS output capacitor"): new})
    assert lines == [(logging.INFO, "episode 1 closed: N9/EMA2 motor and gear (friction), "
                                    "no longer detected")]


def test_slow_input_and_a_growing_queue_are_warned_once() -> None:
    pace = Pace(queue_bound=40)
    s = 1_000_000_000
    assert pace.check(0.0, 0, 0, 0) == []
    assert pace.check(1.0, 1 * s, 800, 0) == []                    # real time
    slow = pace.check(61.0, 21 * s, 27_424, 0)                      # 20 s of bus in 60 s
    assert len(slow) == 1 and slow[0][0] == logging.WARNING
    assert "slower than real time: 0.33 s of bus time per second (26624 messages" in slow[0][1]
    assert pace.check(62.0, 21 * s + s // 3, 27_800, 0) == []       # still slow: said once
    assert pace.check(63.0, 22 * s + s // 3, 28_600, 0)[0][0] == logging.INFO
    assert pace.check(70.0, 22 * s + s // 3, 28_600, 0) == []       # idle bus: not slow
    # the queue deepens at each check (in real time): said once, when it has grown three
    # checks in a row and holds a tenth of its bound
    lines = [line for depth in (1, 4, 8, 12, 16) for line in
             pace.check(70.0 + depth, 22 * s + s // 3 + depth * s, 29_000 + depth, depth)]
    assert len(lines) == 1 and "the reader's queue grows: 8/40 batches" in lines[0][1]
    drained = pace.check(90.0, 42 * s + s // 3, 30_000, 1)
    assert drained == [(logging.INFO, "the reader's queue drained (1/40 batches)")]


def test_the_rul_warning_is_a_validated_config_key() -> None:
    from mapr_daemon.errors import ConfigError
    from mapr_daemon.icd.yamlsrc import load_text

    def config(text: str) -> Config:
        return parse(load_text(text, "c.yaml"), "c.yaml")

    assert config("health:\n  rul_warn_flights: 25\n").health.rul_warn_flights == 25.0
    assert config("health:\n  rul_warn_flights: null\n").health.rul_warn_flights is None
    assert Config().health.rul_warn_flights == 10.0
    for bad in ("health:\n  rul_warn_flights: -1\n", "health:\n  rul_warn: 5\n"):
        try:
            config(bad)
        except ConfigError as error:
            assert "health." in str(error)
        else:
            raise AssertionError(f"accepted {bad!r}")
