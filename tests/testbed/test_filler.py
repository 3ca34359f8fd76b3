"""``testbed.fill_bus``: the ICD's traffic unchanged, filler to a spare RT, a loaded bus."""

from __future__ import annotations

from collections import Counter
from pathlib import Path

from mapr_daemon.icd import load_icd
from mapr_daemon.service.config import Config
from mapr_daemon.service.source import monitor_factory

ROOT = Path(__file__).resolve().parents[2]
ICD = ROOT / "configs" / "icd" / "ema-testbed.yaml"


def fly(fill: bool) -> tuple[Counter[tuple[int, int]], float, int]:
    config = Config(icd=str(ICD), testbed=dict(realtime=False, duration_s=0.5,
                                                        fill_bus=fill))
    with monitor_factory(config, load_icd(ICD))() as monitor:
        records = list(monitor)
        load = monitor.stats.load("A")
    assert all(not r.errors for r in records)
    frames_ns = records[-1].end_ns - records[0].t_ns
    return Counter((r.rt, r.sa) for r in records), load, frames_ns


def test_filler_loads_the_bus_and_leaves_the_icd_traffic_alone() -> None:
    plain, plain_load, _ = fly(False)
    filled, load, filled_ns = fly(True)
    assert plain_load < 60 and load > 90   # the ICD alone loads the bus to ~53 %
    spare = {rt for rt, _ in filled} - {rt for rt, _ in plain}
    assert len(spare) == 1
    assert {k: v for k, v in filled.items() if k[0] not in spare} == plain
    assert filled_ns < 0.5e9 + 100_000   # 250 frames in 0.5 s: filler never pushes them late
