"""What the pipeline reads from a daemon config: the ICD, the assets, the aircraft, the reasoner.

The daemon's config file (:mod:`mapr_daemon.service.config`) holds these sections beside the
service's own (backend, catalog, recording, queue); ``mapr replay`` and ``mapr fleet`` read
the same file. The pipeline takes any object with these five attributes
(:class:`PipelineConfig`), so it needs nothing of the service to be built.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Protocol

from mapr_daemon.ema.params import default_actuator_path
from mapr_daemon.pipeline import wiring

REPO_CONFIGS = Path(__file__).resolve().parents[2] / "configs"
"""``configs/`` of a source checkout (the default ICD lives there)."""
DEFAULT_ICD = REPO_CONFIGS / "icd" / "ema-testbed.yaml"


@dataclasses.dataclass(frozen=True)
class AssetConfig:
    """An actuator the reasoner watches: its catalog name, remote-terminal address, data
    sheet, and which ICD signal is which reasoner channel (:mod:`.wiring`)."""

    name: str = "EMA1"
    rt: int = 5
    actuator: str = dataclasses.field(default_factory=lambda: str(default_actuator_path()))
    """The actuator file (``configs/actuators/*.yaml``): its physics and its ``bit:`` motion."""
    signals: dict[str, str] = dataclasses.field(
        default_factory=lambda: dict(wiring.DEFAULT_SIGNALS))
    """ICD signal -> reasoner channel or role (default: the shipped testbed ICD's wiring)."""
    dictionary: str | None = None
    """This actuator's fault dictionary (None: ``reasoner.dictionary``, the one for all)."""
    prognosis: str | None = None
    """Its prognostic model (``mapr dictionary build --prognosis``; None: no SoH trend or
    RUL, the events say why)."""
    expected_life_flights: dict[str, float] = dataclasses.field(default_factory=dict)
    """Per aging kind, the life the fleet's parts are expected to reach, in flights (the
    user's reliability figure; the trend holds it loosely). Absent: the prognostic model's
    own, which is the aging model's assumption (200 flights)."""
    commissioned: str | None = None
    """The unit's ``mapr commission`` folder (None: the dictionary alone). With it, BITs are
    also read against the unit's commissioned baseline, which gives the event's mode, part
    and severity when it explains the BIT
    (:mod:`mapr_daemon.reasoner.commissioning.unit_decision`): every BIT, and detection is
    the dictionary's combined with the unit's own detector, when the record has one
    (:mod:`mapr_daemon.reasoner.commissioning.detection`); only the BITs the dictionary flags
    otherwise."""


@dataclasses.dataclass(frozen=True)
class AircraftConfig:
    """The aircraft the bus belongs to, and how its flights are told apart."""

    tail: str = ""
    """Tail number (empty: one aircraft, unnamed); keys flights in the catalog."""
    flight_gap_s: float = 900.0
    """Actuator traffic that resumes after at least this long starts a new flight."""


@dataclasses.dataclass(frozen=True)
class ReasonerConfig:
    """The fault dictionary (None: monitor only, no diagnosis) and decision settings."""

    dictionary: str | None = None
    threshold: float | None = None
    """Anomaly threshold override (None: the dictionary's own calibration)."""
    paper: bool = False
    inflight: bool = True
    """Track each diagnosed actuator's parameters on the traffic between BITs and store one
    estimate per flight (:mod:`~mapr_daemon.pipeline.inflight`); False: BITs only."""


class PipelineConfig(Protocol):
    """The settings :func:`~mapr_daemon.pipeline.pipeline.build_pipeline` reads (the daemon's
    :class:`~mapr_daemon.service.config.Config` is one)."""

    @property
    def icd(self) -> str:
        """The message table's file."""

    @property
    def assets(self) -> tuple[AssetConfig, ...]:
        """The actuators watched, each diagnosed and trended on its own."""

    @property
    def aircraft(self) -> AircraftConfig:
        """The tail and how flights are told apart."""

    @property
    def reasoner(self) -> ReasonerConfig:
        """The shared dictionary and decision settings."""

    @property
    def source(self) -> str | None:
        """The file the settings came from (named in errors; None: built in)."""
