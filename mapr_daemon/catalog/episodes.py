"""Fault episodes: one persistent fault of one actuator's replaceable part, across its BITs.

A fault that persists writes an event at every BIT; an episode groups them, so a maintainer
sees one line per fault with its history instead of a dozen identical events. The rule:

- **Key.** An episode belongs to one actuator (the event's ``asset``) and one replaceable
  part (the event's ``evidence["part"]``, :mod:`mapr_daemon.reasoner.diagnosis.parts`; the fault
  mode
  itself when an event names no part). A BIT that decides another mode of the same part (the
  SMPS's high-side and low-side switch resistances, which the bus data cannot tell apart)
  updates the same episode; ``modes`` lists every mode seen.
- **Open** at the first BIT that detects the part while no episode of that key is open.
- **Update** at each later BIT that detects it again: the count of detecting BITs, the last
  detection's time, and the severity trend (first, last, min, max of the share of the
  fault's range, and the least-squares slope of severity against the BIT's ordinal in the
  episode, in share of range per BIT; terminal faults, which have no severity, leave the
  trend alone).
- **Clear.** Any other diagnosed BIT of the same actuator (nominal, or another part) is a
  clear BIT for each of its open episodes; a detection resets the count. When an episode has
  been clear for ``clear_after`` consecutive BITs (``catalog.episode_clear_bits`` in the
  daemon config, default :data:`DEFAULT_CLEAR_BITS`) it is closed at that BIT's time. A later
  detection opens a new episode. A BIT the reasoner failed on counts neither way.

The functions here are pure: they take an episode's stored state and one BIT and return the
new state; :func:`observe` is the rule for one BIT. The catalog writer (:mod:`.writer`)
applies it at write time to a whole batch (:func:`.episode_batch.fold`, the same rule in
batch form), in the transaction that stores the BITs' events, so the daemon and
``mapr replay`` build the same episodes.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import Any, NamedTuple

from mapr_daemon.catalog.model import Event, display_name

DEFAULT_CLEAR_BITS = 3
"""Consecutive clear BITs that close an episode, unless the daemon config says otherwise."""


class Detection(NamedTuple):
    """What one BIT found, as far as episodes care: where, which part and mode, how bad."""

    asset: str
    part: str
    mode: str
    t_ns: int
    severity: float | None
    """Share of the fault's range, or None (a terminal fault, or none stated)."""


def detection_of(event: Event) -> Detection:
    """The :class:`Detection` an anomaly event stands for (part from its evidence)."""
    severity = event.severity
    if severity is not None and not math.isfinite(severity):
        severity = None
    return Detection(event.asset, str(event.evidence.get("part") or event.fault), event.fault,
                     int(event.t_ns), severity)


@dataclasses.dataclass(frozen=True)
class Episode:
    """One fault episode's stored state (a row of the catalog's ``episodes`` table)."""

    id: int
    asset: str
    part: str
    mode: str
    """The mode the latest detecting BIT decided."""
    modes: tuple[str, ...]
    """Every mode of the part seen in the episode, in the order first seen."""
    opened_ns: int
    last_ns: int
    """Time of the latest detecting BIT."""
    closed_ns: int | None = None
    """Time of the clear BIT that closed it; None while it is open."""
    bits: int = 1
    """Detecting BITs."""
    span: int = 1
    """BITs of the actuator since it opened (detecting and clear): the next BIT's ordinal."""
    clear: int = 0
    """Consecutive clear BITs since the latest detection."""
    sev_first: float | None = None
    sev_last: float | None = None
    sev_min: float | None = None
    sev_max: float | None = None
    fit: tuple[float, float, float, float, float] = (0.0, 0.0, 0.0, 0.0, 0.0)
    """Running sums of the severity fit: n, sum x, sum y, sum x^2, sum xy (x = BIT ordinal)."""
    acked_by: str | None = None
    acked_ns: int | None = None
    ack_note: str | None = None
    tail: str = ""
    """The aircraft, when the catalog knows it (the episodes table keeps the daemon's bare
    asset name, or a fleet run's ``TAIL/ASSET``); set by the reader."""

    @property
    def name(self) -> str:
        """The actuator as every view names it: ``TAIL/ASSET`` (``mapr health``'s name)."""
        return display_name(self.tail, self.asset)

    @property
    def open(self) -> bool:
        return self.closed_ns is None

    @property
    def state(self) -> str:
        return "open" if self.open else "closed"

    @property
    def slope(self) -> float | None:
        """Least-squares severity slope, share of range per BIT (None under two points)."""
        n, sx, sy, sxx, sxy = self.fit
        den = n * sxx - sx * sx
        if n < 2 or den <= 0:
            return None
        return (n * sxy - sx * sy) / den

    def as_dict(self) -> dict[str, Any]:
        """A JSON-ready dict (``mapr catalog episodes --json``)."""
        out = dataclasses.asdict(self)
        del out["fit"], out["span"], out["clear"]
        out.update(modes=list(self.modes), state=self.state, slope_per_bit=self.slope,
                   clear_bits=self.clear)
        return out


def _evolve(ep: Episode, changes: dict[str, Any]) -> Episode:
    """A copy of ``ep`` with ``changes`` (``ep`` is left as it was). What
    ``dataclasses.replace`` does, without re-running ``__init__``: every field here is a
    plain value, and the writer calls this for every BIT of a batch."""
    new = object.__new__(Episode)
    new.__dict__.update(ep.__dict__)
    new.__dict__.update(changes)
    return new


def _severity(ep: Episode, severity: float | None, x: int, changes: dict[str, Any]
              ) -> dict[str, Any]:
    """``changes`` plus the severity trend's, for a detection at BIT ordinal ``x``."""
    if severity is None:
        return changes
    n, sx, sy, sxx, sxy = ep.fit
    changes.update(
        sev_first=severity if ep.sev_first is None else ep.sev_first, sev_last=severity,
        sev_min=severity if ep.sev_min is None else min(ep.sev_min, severity),
        sev_max=severity if ep.sev_max is None else max(ep.sev_max, severity),
        fit=(n + 1, sx + x, sy + severity, sxx + x * x, sxy + x * severity))
    return changes


_BLANK = Episode(id=0, asset="", part="", mode="", modes=(), opened_ns=0, last_ns=0)
"""Every field at its value for a new episode, bar those :func:`opened` sets."""


def opened(episode_id: int, found: Detection) -> Episode:
    """A new episode at its first detection (BIT ordinal 0)."""
    return _evolve(_BLANK, _severity(_BLANK, found.severity, 0, {
        "id": episode_id, "asset": found.asset, "part": found.part, "mode": found.mode,
        "modes": (found.mode,), "opened_ns": found.t_ns, "last_ns": found.t_ns}))


def detected(ep: Episode, found: Detection) -> Episode:
    """``ep`` after another BIT that detects its part."""
    modes = ep.modes if found.mode in ep.modes else (*ep.modes, found.mode)
    return _evolve(ep, _severity(ep, found.severity, ep.span, {
        "mode": found.mode, "modes": modes, "last_ns": max(ep.last_ns, found.t_ns),
        "bits": ep.bits + 1, "span": ep.span + 1, "clear": 0}))


def cleared(ep: Episode, t_ns: int, clear_after: int) -> Episode:
    """``ep`` after a diagnosed BIT of its actuator that does not detect its part: closed at
    ``t_ns`` once it has been clear for ``clear_after`` consecutive BITs."""
    clear = ep.clear + 1
    return _evolve(ep, {"span": ep.span + 1, "clear": clear,
                        "closed_ns": int(t_ns) if clear >= clear_after else None})


def observe(open_episodes: Mapping[str, Episode], asset: str, t_ns: int,
            found: Detection | None, clear_after: int, next_id: int
            ) -> tuple[dict[str, Episode], int | None]:
    """One diagnosed BIT of ``asset`` against its open episodes (keyed by part).

    Returns the episodes it changed (keyed by part; closed ones included, with
    ``closed_ns`` set) and the id of the episode the BIT's event belongs to (None for a
    nominal BIT). A new episode takes ``next_id``.
    """
    if clear_after < 1:
        raise ValueError("clear_after must be at least 1 BIT")
    changed: dict[str, Episode] = {}
    for part, ep in open_episodes.items():
        if ep.asset != asset or not ep.open or (found is not None and part == found.part):
            continue
        changed[part] = cleared(ep, t_ns, clear_after)
    if found is None:
        return changed, None
    current = open_episodes.get(found.part)
    if current is not None and current.open:
        changed[found.part] = detected(current, found)
    else:
        changed[found.part] = opened(next_id, found)
    return changed, changed[found.part].id
