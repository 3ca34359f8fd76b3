"""In-flight parameter tracking: the EKF on the traffic between BITs (issue 29).

:mod:`.segments` cuts a flight's bus-rate channels into windows with enough excitation for
each parameter group; :mod:`.tracker` runs the EKF over the qualifying segments and ends the
flight with one estimate per parameter, its sd and its change from the unit's baseline;
:mod:`.accumulate` keeps only a streamed flight's qualifying windows until its end.
"""

from mapr_daemon.reasoner.inflight.accumulate import FlightAccumulator
from mapr_daemon.reasoner.inflight.segments import (
    CRITERION,
    Criterion,
    Excitation,
    Segment,
    excitation,
    select,
)
from mapr_daemon.reasoner.inflight.tracker import (
    FlightEstimate,
    FlightTracker,
    Tracked,
    adopt,
    commission,
    commissioning_values,
)

__all__ = ["CRITERION", "Criterion", "Excitation", "FlightAccumulator", "FlightEstimate",
           "FlightTracker", "Segment", "Tracked", "adopt", "commission", "commissioning_values",
           "excitation", "select"]
