"""The daemon's path from diagnosed BITs to fault episodes, without flying: the pipeline's
catalog outcome of each BIT (an event, or nominal) and the writer's episodes from them.
(tests/service/test_end_to_end.py flies the testbed and replays its recording.)"""

from __future__ import annotations

from pathlib import Path

from mapr_daemon.catalog import CatalogReader, CatalogWriter
from mapr_daemon.findings import Diagnosis
from mapr_daemon.icd.yamlsrc import load_text
from mapr_daemon.pipeline.bitwatch import BitFound
from mapr_daemon.pipeline.clock import BusClock
from mapr_daemon.pipeline.pipeline import build_pipeline
from mapr_daemon.service.config import Config, load_config, parse

T0 = 1_778_300_000_000_000_000
ESR = Diagnosis(anomaly=True, fault="esr", confidence=0.9, severity=0.3, unit="ohm",
                part="SMPS output capacitor", evidence={"severity_fraction_of_range": 0.55})
NOMINAL = Diagnosis(anomaly=False, fault=None, severity=None, unit=None, confidence=0.97)


def test_nominal_bits_reach_the_writer_and_close_the_episode(tmp_path: Path) -> None:
    config = parse(load_text(f"catalog:\n  path: {tmp_path / 'c.sqlite'}\n"
                             "  episode_clear_bits: 2\n", "x.yaml"), "x.yaml")
    assert config.catalog.episode_clear_bits == 2
    pipe = build_pipeline(config)
    clock = BusClock("recording")
    clock.offset_ns = T0   # what the recording's time packets would give
    decisions = [ESR, ESR, NOMINAL, NOMINAL, ESR]
    outcomes = [pipe.outcome(pipe.asset, BitFound(k * 2_000_000_000, k * 2_000_000_000 + 10**6, d),
                             clock)
                for k, d in enumerate(decisions)]
    assert [o.event is None for o in outcomes] == [False, False, True, True, False]
    assert [o.t_ns for o in outcomes] == [T0 + k * 2_000_000_000 for k in range(5)]
    with CatalogWriter(config.catalog.path,
                       clear_after=config.catalog.episode_clear_bits) as writer:
        writer.open_session(backend="chapter10", config_hash=config.digest())
        ids = writer.add_bits(outcomes[:3]) + writer.add_bits(outcomes[3:])
    with CatalogReader(config.catalog.path) as reader:
        new, old = reader.episodes()
        events = reader.events(newest_first=False)
    assert len(ids) == 3 and [e.episode_id for e in events] == [old.id, old.id, new.id]
    assert (old.asset, old.part, old.bits, old.state, old.closed_ns) == \
        ("EMA1", "SMPS output capacitor", 2, "closed", T0 + 3 * 2_000_000_000)
    assert (new.bits, new.state, new.sev_first) == (1, "open", 0.55)


def test_the_default_is_three_clear_bits() -> None:
    assert Config().catalog.episode_clear_bits == 3
    shipped = Path(__file__).resolve().parents[2] / "configs" / "mapr.yaml"
    assert load_config(shipped).catalog.episode_clear_bits == 3
