"""Records -> events: the one path shared by the daemon (``mapr run``), ``mapr replay`` and
``mapr fleet``.

:mod:`.pipeline` builds a :class:`Pipeline` from the settings it reads
(:mod:`.settings`: the ICD, the assets, the aircraft, the reasoner) and turns each batch of
bus records into a :class:`Batch` of diagnosed BITs and catalog events; :mod:`.bitcut`
cuts each actuator's built-in tests out of the decoded signals (one rule, shared with
commissioning from a recording, :mod:`.recorded_bits`) and :mod:`.bitwatch` hands them to its
reasoner; :mod:`.trending` keeps flights and each actuator's health trend; :mod:`.clock`
stamps events with bus and absolute time; :mod:`.wiring` says which ICD signal is which
reasoner channel.

What the caller does with the events (the daemon's catalog writes and systemd status, the
replay's summary, the fleet's archive) is the caller's: this package imports nothing of the
service (:mod:`mapr_daemon.service`).
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from mapr_daemon.pipeline.bitcut import BitCutter, CutBit
    from mapr_daemon.pipeline.bitwatch import BitFound, BitWatch
    from mapr_daemon.pipeline.clock import BusClock
    from mapr_daemon.pipeline.pipeline import Batch, Failure, Pipeline, Watched, build_pipeline
    from mapr_daemon.pipeline.recorded_bits import RecordedBits, bits_from_recording
    from mapr_daemon.pipeline.settings import (
        DEFAULT_ICD,
        AircraftConfig,
        AssetConfig,
        PipelineConfig,
        ReasonerConfig,
    )
    from mapr_daemon.pipeline.trending import Trending

_HOME = {
    "BitCutter": "mapr_daemon.pipeline.bitcut",
    "CutBit": "mapr_daemon.pipeline.bitcut",
    "BitFound": "mapr_daemon.pipeline.bitwatch",
    "BitWatch": "mapr_daemon.pipeline.bitwatch",
    "BusClock": "mapr_daemon.pipeline.clock",
    "Batch": "mapr_daemon.pipeline.pipeline",
    "Failure": "mapr_daemon.pipeline.pipeline",
    "Pipeline": "mapr_daemon.pipeline.pipeline",
    "Watched": "mapr_daemon.pipeline.pipeline",
    "build_pipeline": "mapr_daemon.pipeline.pipeline",
    "RecordedBits": "mapr_daemon.pipeline.recorded_bits",
    "bits_from_recording": "mapr_daemon.pipeline.recorded_bits",
    "DEFAULT_ICD": "mapr_daemon.pipeline.settings",
    "AircraftConfig": "mapr_daemon.pipeline.settings",
    "AssetConfig": "mapr_daemon.pipeline.settings",
    "PipelineConfig": "mapr_daemon.pipeline.settings",
    "ReasonerConfig": "mapr_daemon.pipeline.settings",
    "Trending": "mapr_daemon.pipeline.trending",
}
"""Each public name and the module it lives in, imported when first asked for: importing
one module of the package (a subcommand's parser) does not import them all."""

__all__ = ["DEFAULT_ICD", "AircraftConfig", "AssetConfig", "Batch", "BitCutter", "BitFound",
           "BitWatch", "BusClock", "CutBit", "Failure", "Pipeline", "PipelineConfig",
           "ReasonerConfig", "RecordedBits", "Trending", "Watched", "bits_from_recording",
           "build_pipeline"]


def __getattr__(name: str) -> Any:
    """The public name ``name``, from its module (PEP 562)."""
    if name not in _HOME:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(importlib.import_module(_HOME[name]), name)
