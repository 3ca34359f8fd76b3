"""Regenerate ``ema-cruise-20ms.sr``: 20 ms of the testbed aircraft's bus, bit level.

    python tests/data/codec/make_ema_capture.py

Ten 2 ms minor frames of the EMA testbed's schedule (configs/icd/ema-testbed.yaml) on the
loopback bus — the aileron EMA, healthy, in a JSBSim cruise — sampled at 16 MS/s as a logic
analyzer on the two transceivers would, and saved as a sigrok session. Tests and docs decode
it with and without the message table.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from drivers.backends.loopback import BusController
from drivers.backends.loopback.line import SampleWriter
from drivers.capturefile import write_sigrok
from mapr_daemon.ema.params import default_actuator_path, load_actuator, with_sample_rate
from mapr_daemon.icd import load_icd
from mapr_daemon.testbed.aircraft import Aircraft
from mapr_daemon.testbed.profiles_jsbsim import jsbsim_flight

ROOT = Path(__file__).resolve().parents[3]
RATE = 16e6


def main() -> None:
    icd = load_icd(ROOT / "configs" / "icd" / "ema-testbed.yaml")
    params = with_sample_rate(load_actuator(default_actuator_path()), 2000.0)
    aircraft = Aircraft(icd, jsbsim_flight(2000.0, "cruise", duration_s=0.1), params)
    controller = BusController(aircraft.schedule(), aircraft.terminals())
    writer = SampleWriter(RATE)
    samples = np.concatenate([writer.write(controller.run_frame()) for _ in range(10)])
    write_sigrok(Path(__file__).parent / "ema-cruise-20ms.sr", samples, RATE)


if __name__ == "__main__":
    main()
