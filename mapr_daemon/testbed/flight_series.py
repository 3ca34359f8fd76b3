"""A whole flight's channels as the ICD's decoded series, batch by batch (no bus in between).

The in-flight tracker's path in the pipeline (:class:`~mapr_daemon.pipeline.inflight.
InflightWatch`) reads decoded series; flying a whole flight through the simulated bus costs
about twice its length in CPU, so tests and benches of that path hand it the plant's
channels (:func:`~mapr_daemon.testbed.whole_flight.fly`) as the shipped testbed ICD's series
would carry them: the six tracker channels at the drive's rate, the air-data computer's
dynamic pressure at 50 Hz and the FCC's BIT request at 10 Hz, with an ``INITIATED_BIT``
request at the chosen times.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from mapr_daemon.arrays import FloatArray
from mapr_daemon.icd import Icd, Series, load_icd
from mapr_daemon.pipeline.bitcut import INITIATED_BIT

ICD_PATH = Path(__file__).resolve().parents[2] / "configs" / "icd" / "ema-testbed.yaml"
SIGNAL: dict[str, str] = {
    "phase_a_current_a": "phase_current_a", "phase_b_current_a": "phase_current_b",
    "phase_c_current_a": "phase_current_c", "dc_link_current_a": "dc_link_current",
    "dc_bus_voltage_v": "dc_bus_voltage", "position_deg": "surface_position"}
"""Tracker channel -> the shipped ICD's signal (its default wiring)."""


def _series(icd: Icd, name: str, t: np.ndarray, v: FloatArray) -> Series:
    return Series(icd.parameter(name)[1], t.astype(np.int64), np.asarray(v, dtype=np.float64),
                  np.zeros(t.size, dtype=np.int64), np.zeros(t.size, dtype=np.uint8))


def flight_series(channels: Mapping[str, FloatArray], q: FloatArray, rate: float, t0_ns: int,
                  bits_at_s: Sequence[float] = (), batch_s: float = 2.0,
                  icd: Icd | None = None) -> list[dict[str, Series]]:
    """The flight (``q``: its dynamic pressure per sample) as batches of decoded series."""
    icd = icd if icd is not None else load_icd(ICD_PATH)
    n = np.asarray(channels["position_deg"]).size
    t = t0_ns + (np.arange(n) * 1e9 / rate).astype(np.int64)
    per = max(1, int(batch_s * rate))
    air, fcc = max(1, int(rate / 50)), max(1, int(rate / 10))
    requests = t0_ns + np.asarray(bits_at_s, dtype=np.float64) * 1e9
    out = []
    for a in range(0, n, per):
        sl = slice(a, min(a + per, n))
        s = {sig: _series(icd, sig, t[sl], np.asarray(channels[k])[sl])
             for k, sig in SIGNAL.items()}
        s["dynamic_pressure"] = _series(icd, "dynamic_pressure", t[sl][::air],
                                        np.asarray(q)[sl][::air])
        tr = t[sl][::fcc]
        near = np.abs(tr[:, None] - requests[None, :]).min(axis=1, initial=np.inf) \
            < 0.5e9 / 10 if requests.size else np.zeros(tr.size, dtype=bool)
        s["bit_request"] = _series(icd, "bit_request", tr,
                                   np.where(near, INITIATED_BIT, 0).astype(np.float64))
        out.append(s)
    return out
