"""A batch of BITs against the open fault episodes, at write time: :func:`fold`.

The rule is :func:`.episodes.observe`, one BIT at a time; :func:`fold` gives the same result
for a whole batch (tests/catalog/test_episodes.py checks the two agree on random sequences)
at a cost the catalog's bulk insert can carry: each episode's state is accumulated in place
while the batch is walked and turned into an :class:`~.episodes.Episode` once at the end, and
clear BITs are counted, not applied one by one, so a BIT costs a few dictionary operations
whatever the number of open episodes.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from mapr_daemon.catalog.episodes import Detection, Episode


class _Run:
    """One episode's state while a batch is folded (mutable, private to :func:`fold`)."""

    __slots__ = ("ack", "asset", "bits", "clear", "closed_ns", "dirty", "fit", "id",
                 "last_ns", "mode", "modes", "opened_ns", "part", "sev", "since", "span")

    def __init__(self, ep: Episode, since: int, dirty: bool) -> None:
        self.id, self.asset, self.part, self.mode = ep.id, ep.asset, ep.part, ep.mode
        self.modes = list(ep.modes)
        self.opened_ns, self.last_ns, self.closed_ns = ep.opened_ns, ep.last_ns, ep.closed_ns
        self.bits, self.span, self.clear = ep.bits, ep.span, ep.clear
        self.sev = [ep.sev_first, ep.sev_last, ep.sev_min, ep.sev_max]
        self.fit = list(ep.fit)
        self.ack = (ep.acked_by, ep.acked_ns, ep.ack_note)
        self.since = since
        """Index, in its actuator's BITs of this batch, of the first not yet applied."""
        self.dirty = dirty

    def severity(self, value: float | None, x: int) -> None:
        if value is None:
            return
        sev, fit = self.sev, self.fit
        if sev[0] is None:
            sev[0] = value
        sev[1] = value
        sev[2] = value if sev[2] is None else min(sev[2], value)
        sev[3] = value if sev[3] is None else max(sev[3], value)
        fit[0] += 1
        fit[1] += x
        fit[2] += value
        fit[3] += x * x
        fit[4] += x * value

    def detect(self, found: Detection) -> None:
        """Another detecting BIT (:func:`.episodes.detected`)."""
        self.severity(found.severity, self.span)
        self.mode = found.mode
        if found.mode not in self.modes:
            self.modes.append(found.mode)
        self.last_ns = max(self.last_ns, found.t_ns)
        self.bits += 1
        self.span += 1
        self.clear = 0
        self.dirty = True

    def clears(self, times: Sequence[int], until: int, clear_after: int) -> None:
        """The clear BITs ``times[since:until]`` (:func:`.episodes.cleared` once each,
        stopping when it closes)."""
        gap = until - self.since
        if gap <= 0 or self.closed_ns is not None:
            return
        need = max(1, clear_after - self.clear)   # clear BITs left before it closes
        if gap >= need:
            self.span += need
            self.clear += need
            self.closed_ns = int(times[self.since + need - 1])
        else:
            self.span += gap
            self.clear += gap
        self.dirty = True

    def episode(self) -> Episode:
        first, last, low, high = self.sev
        n, sx, sy, sxx, sxy = self.fit
        return Episode(id=self.id, asset=self.asset, part=self.part, mode=self.mode,
                       modes=tuple(self.modes), opened_ns=self.opened_ns, last_ns=self.last_ns,
                       closed_ns=self.closed_ns, bits=self.bits, span=self.span,
                       clear=self.clear, sev_first=first, sev_last=last, sev_min=low,
                       sev_max=high, fit=(n, sx, sy, sxx, sxy), acked_by=self.ack[0],
                       acked_ns=self.ack[1], ack_note=self.ack[2])


def _opened(episode_id: int, found: Detection, since: int) -> _Run:
    run = _Run(Episode(id=episode_id, asset=found.asset, part=found.part, mode=found.mode,
                       modes=(found.mode,), opened_ns=found.t_ns, last_ns=found.t_ns),
               since, dirty=True)
    run.severity(found.severity, 0)
    return run


def fold(bits: Sequence[tuple[str, int, Detection | None]],
         open_episodes: Mapping[tuple[str, str], Episode], clear_after: int, next_id: int
         ) -> tuple[dict[int, Episode], list[int | None]]:
    """A batch of diagnosed BITs ``(asset, t_ns, detection or None)``, in time order, against
    the open episodes (keyed by ``(asset, part)``).

    Returns every episode the batch changed or opened, by id (its final state), and each
    BIT's episode id (None for a nominal BIT). New episodes take ids from ``next_id`` on.
    """
    if clear_after < 1:
        raise ValueError("clear_after must be at least 1 BIT")
    times: dict[str, list[int]] = {}
    """Per actuator, the times of its BITs in this batch (the Nth clear BIT's closes)."""
    runs = {key: _Run(ep, 0, dirty=False) for key, ep in open_episodes.items()
            if ep.closed_ns is None}
    done: list[_Run] = []
    ids: list[int | None] = []
    for asset, t_ns, found in bits:
        ts = times.get(asset)
        if ts is None:
            ts = times[asset] = []
        k = len(ts)
        ts.append(t_ns)
        if found is None:
            ids.append(None)
            continue
        key = (asset, found.part)
        run = runs.get(key)
        if run is not None:
            run.clears(ts, k, clear_after)
            if run.closed_ns is not None:
                done.append(run)
                run = None
        if run is None:
            run = runs[key] = _opened(next_id, found, k + 1)
            next_id += 1
        else:
            run.detect(found)
            run.since = k + 1
        ids.append(run.id)
    for (asset, _), run in runs.items():
        ts = times.get(asset)
        if ts is not None:
            run.clears(ts, len(ts), clear_after)
    changed = {r.id: r.episode() for r in (*done, *runs.values()) if r.dirty}
    return changed, ids
