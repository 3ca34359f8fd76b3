"""The reasoner's replaceable part and ambiguity group are stored with the event and shown."""

from __future__ import annotations

from pathlib import Path

from mapr_daemon.catalog import CatalogReader, CatalogWriter, event_from_reasoner
from mapr_daemon.findings import Diagnosis
from mapr_daemon.views.text import event_detail

from .conftest import T0

AMBIGUITY = {"part": "SMPS switches", "part_probability": 1.0,
             "members": [{"fault": "smps_ron_high", "probability": 0.62},
                         {"fault": "smps_ron_low", "probability": 0.38}],
             "group": ["smps_ron_high", "smps_ron_low"], "ambiguous": True,
             "rule": "members with probability >= 0.05 given the part"}


def _decision(**extra: object) -> Diagnosis:
    return Diagnosis.from_json({
        "anomaly": True, "fault": "smps_ron_high", "severity": 0.4, "unit": "ohm",
        "confidence": 0.5, "parameters": {}, "soh": 0.0, "component": "smps_high_side_mosfet",
        "rul": None, "evidence": {"severity_fraction_of_range": 0.3}, **extra})


def test_part_and_ambiguity_are_stored_and_shown(catalog_path: Path) -> None:
    ambiguous = event_from_reasoner(_decision(part="SMPS switches", ambiguity=AMBIGUITY),
                                    t_ns=T0, asset="EMA1")
    clear = event_from_reasoner(
        _decision(part="SMPS switches", ambiguity={**AMBIGUITY, "group": ["smps_ron_high"],
                                                   "ambiguous": False}),
        t_ns=T0 + 1, asset="EMA1")
    old = event_from_reasoner(_decision(), t_ns=T0 + 2, asset="EMA1")  # before parts existed
    with CatalogWriter(catalog_path) as writer:
        writer.open_session(backend="loopback", config_hash="x")
        writer.add_events([ambiguous, clear, old])
    with CatalogReader(catalog_path) as reader:
        a, c, o = (reader.event(i) for i in (1, 2, 3))
    assert a is not None and c is not None and o is not None
    assert a.evidence["part"] == "SMPS switches" and a.evidence["ambiguity"] == AMBIGUITY
    text = event_detail(a, None)
    assert ("  part        SMPS switches (smps_ron_high 62%, smps_ron_low 38%: not separable "
            "in the bus data)") in text.splitlines()
    assert "  part        SMPS switches" in event_detail(c, None).splitlines()
    assert "part " not in event_detail(o, None)
