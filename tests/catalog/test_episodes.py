"""Fault episodes: a persistent fault is one episode across its BITs, with its severity trend;
it closes after N clear BITs, a later detection opens a new one, and one part's modes share
an episode. Written through the real writer and read back from the file."""

from __future__ import annotations

from pathlib import Path

import pytest

from mapr_daemon.catalog import BitOutcome, CatalogReader, CatalogWriter, Event
from mapr_daemon.catalog.episode_batch import fold
from mapr_daemon.catalog.episodes import Detection, Episode, observe

from .conftest import T0

BIT_NS = 2_000_000_000  # one BIT every 2 s, as the testbed flies them


def bit(k: int, fault: str | None, *, asset: str = "EMA1", severity: float | None = 0.5,
        part: str | None = None) -> BitOutcome:
    """The outcome of BIT number ``k``: an anomaly event, or nominal when ``fault`` is None."""
    t = T0 + k * BIT_NS
    if fault is None:
        return BitOutcome(asset, t)
    evidence = {"part": part} if part is not None else {}
    return BitOutcome(asset, t, Event(t_ns=t, asset=asset, fault=fault, confidence=0.9,
                                      severity=severity, evidence=evidence))


def write(path: Path, outcomes: list[BitOutcome], clear_after: int = 3,
          batch: int = 4) -> list[int]:
    ids: list[int] = []
    with CatalogWriter(path, clear_after=clear_after) as writer:
        writer.open_session(backend="loopback", config_hash="e")
        for i in range(0, len(outcomes), batch):  # episodes carry across batches
            ids += writer.add_bits(outcomes[i:i + batch])
    return ids


ESR = "SMPS output capacitor"
SEVERITIES = (0.52, 0.60, 0.55, 0.63, 0.66, 0.70)


def test_a_persistent_fault_over_six_bits_is_one_episode_with_its_trend(
        catalog_path: Path) -> None:
    ids = write(catalog_path, [bit(k, "esr", severity=s, part=ESR)
                               for k, s in enumerate(SEVERITIES)])
    with CatalogReader(catalog_path) as reader:
        (episode,) = reader.episodes()
        events = reader.episode_events(episode.id)
    assert [e.id for e in events] == ids and len(ids) == 6
    assert {e.episode_id for e in events} == {episode.id}
    assert (episode.asset, episode.part, episode.mode, episode.state) == \
        ("EMA1", ESR, "esr", "open")
    assert episode.bits == 6
    assert (episode.opened_ns, episode.last_ns) == (T0, T0 + 5 * BIT_NS)
    assert (episode.sev_first, episode.sev_last) == (0.52, 0.70)
    assert (episode.sev_min, episode.sev_max) == (0.52, 0.70)
    # least-squares slope of severity against the BIT ordinal 0..5, computed independently
    xs = range(6)
    mx, my = sum(xs) / 6, sum(SEVERITIES) / 6
    expect = sum((x - mx) * (y - my) for x, y in zip(xs, SEVERITIES, strict=True)) / \
        sum((x - mx) ** 2 for x in xs)
    assert episode.slope == pytest.approx(expect, rel=1e-9)
    assert expect > 0 and episode.as_dict()["slope_per_bit"] == pytest.approx(expect, rel=1e-9)


@pytest.mark.parametrize("n", [1, 3, 5])
def test_it_closes_after_n_clear_bits_and_a_new_detection_opens_another(
        catalog_path: Path, n: int) -> None:
    fault = [bit(k, "esr", part=ESR) for k in range(3)]
    clear = [bit(3 + k, None) for k in range(n)]
    again = [bit(3 + n, "esr", part=ESR)]
    write(catalog_path, [*fault, *clear[:-1]], clear_after=n)
    with CatalogReader(catalog_path) as reader:   # one short of N: still open
        (first,) = reader.episodes()
    assert first.open and first.clear == n - 1
    with CatalogWriter(catalog_path, clear_after=n) as writer:
        writer.open_session(backend="loopback", config_hash="e")
        writer.add_bits([clear[-1]])
        writer.add_bits(again)
    with CatalogReader(catalog_path) as reader:
        new, old = reader.episodes()
        assert [e.episode_id for e in reader.episode_events(new.id)] == [new.id]
        assert reader.episodes(open_only=True) == [new]
    assert old.id == first.id and old.state == "closed" and old.bits == 3
    assert old.closed_ns == T0 + (2 + n) * BIT_NS   # the Nth clear BIT's time
    assert (new.state, new.bits, new.opened_ns) == ("open", 1, T0 + (3 + n) * BIT_NS)


def test_a_detection_before_n_clear_bits_keeps_the_episode_open(catalog_path: Path) -> None:
    outcomes = [bit(0, "esr", part=ESR), bit(1, None), bit(2, None), bit(3, "esr", part=ESR),
                bit(4, None), bit(5, None)]
    write(catalog_path, outcomes, clear_after=3)
    with CatalogReader(catalog_path) as reader:
        (episode,) = reader.episodes()
    assert episode.open and episode.bits == 2 and episode.clear == 2


def test_high_and_low_side_ron_alternating_stay_one_smps_switches_episode(
        catalog_path: Path) -> None:
    modes = ["smps_ron_high", "smps_ron_low"] * 4
    write(catalog_path, [bit(k, m, part="SMPS switches") for k, m in enumerate(modes)])
    with CatalogReader(catalog_path) as reader:
        (episode,) = reader.episodes()
    assert episode.part == "SMPS switches" and episode.bits == 8
    assert episode.modes == ("smps_ron_high", "smps_ron_low")
    assert episode.mode == "smps_ron_low" and episode.open


def test_other_parts_and_other_actuators_keep_their_own_episodes(catalog_path: Path) -> None:
    outcomes = [bit(0, "esr", part=ESR), bit(0, "friction", asset="EMA2",
                                              part="motor and gear"),
                bit(1, "friction", part="motor and gear"), bit(1, None, asset="EMA2"),
                bit(2, "friction", part="motor and gear"), bit(3, "friction",
                                                               part="motor and gear")]
    write(catalog_path, outcomes, clear_after=3)
    with CatalogReader(catalog_path) as reader:
        by_key = {(e.asset, e.part): e for e in reader.episodes()}
        ema2 = reader.episodes(asset="EMA2")
    # EMA1's ESR episode saw three BITs that found another part: clear, so closed
    assert by_key[("EMA1", ESR)].state == "closed"
    assert by_key[("EMA1", "motor and gear")].bits == 3
    # EMA2's one nominal BIT does not close its episode, nor touch EMA1's
    assert [(e.part, e.state, e.clear) for e in ema2] == [("motor and gear", "open", 1)]


def test_terminal_faults_leave_the_severity_trend_empty(catalog_path: Path) -> None:
    write(catalog_path, [bit(k, "short", severity=None, part="inverter bridge")
                         for k in range(3)])
    with CatalogReader(catalog_path) as reader:
        (episode,) = reader.episodes()
    assert episode.bits == 3 and episode.sev_first is None and episode.slope is None


def test_fold_is_pure_and_matches_one_bit_at_a_time() -> None:
    found = [("EMA1", T0 + k * BIT_NS,
              None if k in (2, 3) else Detection("EMA1", ESR, "esr", T0 + k * BIT_NS, 0.1 * k))
             for k in range(6)]
    start: dict[tuple[str, str], Episode] = {}
    changed, ids = fold(found, start, clear_after=3, next_id=7)
    assert start == {} and ids == [7, 7, None, None, 7, 7]
    (episode,) = changed.values()
    state: dict[str, Episode] = {}
    for asset, t, det in found:
        updates, _ = observe(state, asset, t, det, 3, 7)
        state.update(updates)
    assert state[ESR] == episode and episode.bits == 4 and episode.span == 6
    with pytest.raises(ValueError):
        observe({}, "EMA1", T0, None, 0, 1)


@pytest.mark.parametrize("seed", range(6))
def test_fold_over_batches_agrees_with_the_one_bit_rule(seed: int) -> None:
    """Random BIT sequences (2 actuators, 3 parts, nominal BITs, terminal faults), cut into
    random batches: the batch fold gives what :func:`observe` gives BIT by BIT."""
    import random
    rng = random.Random(seed)
    clear_after = rng.randint(1, 4)
    parts = {"esr": ESR, "capacitance": ESR, "friction": "motor and gear",
             "short": "inverter bridge"}
    bits: list[tuple[str, int, Detection | None]] = []
    for k in range(300):
        asset, t = rng.choice(["EMA1", "EMA2"]), T0 + k * BIT_NS
        mode = rng.choice([None, None, "esr", "esr", "capacitance", "friction", "short"])
        bits.append((asset, t, None if mode is None else Detection(
            asset, parts[mode], mode, t, None if mode == "short" else rng.random())))
    # the rule, one BIT at a time
    state: dict[tuple[str, str], Episode] = {}
    every: dict[int, Episode] = {}
    want: list[int | None] = []
    next_id = 1
    for asset, t, det in bits:
        mine = {p: e for (a, p), e in state.items() if a == asset}
        updates, eid = observe(mine, asset, t, det, clear_after, next_id)
        next_id += eid == next_id
        for part, ep in updates.items():
            every[ep.id] = ep
            if ep.open:
                state[(asset, part)] = ep
            else:
                state.pop((asset, part), None)
        want.append(eid)
    # the fold, over random batches, its open episodes carried as the writer reloads them
    stored: dict[int, Episode] = {}
    got: list[int | None] = []
    i, next_id = 0, 1
    while i < len(bits):
        n = rng.randint(1, 40)
        open_now = {(e.asset, e.part): e for e in stored.values() if e.open}
        changed, ids = fold(bits[i:i + n], open_now, clear_after, next_id)
        stored.update(changed)
        next_id = max([next_id - 1, *stored]) + 1
        got += ids
        i += n
    assert got == want
    assert stored == every
    assert sum(e.open for e in every.values()) >= 1 and len(every) > 10
