"""Bus timing rules a monitor segments messages with (MIL-STD-1553B 4.3.3.8-9).

All gaps are measured as the standard defines them: from the mid-bit crossing of the last
bit (parity) of one word to the mid-sync crossing of the next, so two contiguous words are
2.0 µs apart and the idle time is 2.0 µs less than the gap.
"""

from __future__ import annotations

from dataclasses import dataclass

CONTIGUOUS_GAP_NS = 2_000
"""Mid-crossing to mid-crossing gap between two contiguous words."""
SYNC_MID_NS = 1_500
"""From a word's sync leading edge to its mid-sync crossing."""


@dataclass(frozen=True, slots=True)
class BusTiming:
    """The thresholds, in ns, mid-crossing to mid-crossing. Defaults are the standard's."""

    response_min_ns: int = 4_000
    """An RT response sooner than this is an early response."""
    response_max_ns: int = 12_000
    """An RT response later than this (but before the time-out) is a late response."""
    no_response_ns: int = 14_000
    """No status word within this time: no response (the standard's minimum time-out)."""
    intermessage_min_ns: int = 4_000
    """Shortest legal gap between the end of one message and the next command."""
    contiguity_slack_ns: int = 500
    """A gap longer than contiguous by more than this inside a transmission is a break."""
    babble_ns: int = 800_000
    """An RT transmitting longer than this is babbling (the fail-safe limit)."""

    def __post_init__(self) -> None:
        if not 0 < self.response_min_ns <= self.response_max_ns <= self.no_response_ns:
            raise ValueError("need 0 < response_min <= response_max <= no_response")

    @property
    def break_ns(self) -> int:
        """Gaps above this end a contiguous transmission."""
        return CONTIGUOUS_GAP_NS + self.contiguity_slack_ns
