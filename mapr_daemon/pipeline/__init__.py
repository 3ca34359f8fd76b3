"""Records -> events: the one path shared by the daemon (``mapr run``), ``mapr replay`` and
``mapr fleet``.

:mod:`.pipeline` builds a :class:`Pipeline` from the settings it reads
(:mod:`.settings`: the ICD, the assets, the aircraft, the reasoner) and turns each batch of
bus records into a :class:`Batch` of diagnosed BITs and catalog events; :mod:`.bitwatch`
cuts each actuator's built-in tests out of the decoded signals for its reasoner;
:mod:`.trending` keeps flights and each actuator's health trend; :mod:`.clock` stamps events
with bus and absolute time; :mod:`.wiring` says which ICD signal is which reasoner channel.

What the caller does with the events (the daemon's catalog writes and systemd status, the
replay's summary, the fleet's archive) is the caller's: this package imports nothing of the
service (:mod:`mapr_daemon.service`).
"""

from mapr_daemon.pipeline.bitwatch import BitFound, BitWatch
from mapr_daemon.pipeline.clock import BusClock
from mapr_daemon.pipeline.pipeline import Batch, Failure, Pipeline, Watched, build_pipeline
from mapr_daemon.pipeline.settings import (
    DEFAULT_ICD,
    AircraftConfig,
    AssetConfig,
    PipelineConfig,
    ReasonerConfig,
)
from mapr_daemon.pipeline.trending import Trending

__all__ = ["DEFAULT_ICD", "AircraftConfig", "AssetConfig", "Batch", "BitFound", "BitWatch",
           "BusClock", "Failure", "Pipeline", "PipelineConfig", "ReasonerConfig", "Trending",
           "Watched", "build_pipeline"]
