"""JSBSim flights: a trimmed light aircraft flying bank-angle manoeuvres, as actuator inputs.

JSBSim (the ``jsbsim`` PyPI package, which ships its aircraft and runs offline) flies the
``c172x`` from a trim at the chosen condition's altitude and airspeed. A simple autopilot
writes the stick: a bank-angle loop on the ailerons follows a schedule of turns (left, right,
roll reversals), and a pitch loop on the elevator holds the trimmed attitude. The aileron and
elevator commands are what the flight-control computer would send to the EMAs over the bus;
the air data (altitude, true airspeed, density, dynamic pressure) is what the air-data
computer would send. JSBSim runs at its own 120 Hz; the result is interpolated onto the
plant's output sample times.

Example::

    prof = jsbsim_flight(2000.0, "cruise", duration_s=30.0, surface="aileron")
"""

from __future__ import annotations

import contextlib
import math
import os
import sys
from collections.abc import Iterator

import numpy as np

from mapr_daemon.ema.profile import Profile, condition
from mapr_daemon.errors import ConfigError

FT = 0.3048
SLUG_FT3 = 515.378818
PSF = 47.880259

AIRCRAFT = "c172x"
MAX_DEFLECTION_DEG = 20.0
"""Full-scale surface deflection for a normalised command of 1 (the c172's aileron travel)."""


@contextlib.contextmanager
def _quiet_stdout() -> Iterator[None]:
    """Silence JSBSim's C++ banner and trim report (it writes to file descriptor 1)."""
    sys.stdout.flush()
    saved = os.dup(1)
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, 1)
        yield
    finally:
        os.dup2(saved, 1)
        os.close(saved)
        os.close(devnull)


def bank_schedule(t: float, seed: int) -> float:
    """Bank-angle command (deg): alternating turns every 8 s, amplitude varying by seed."""
    if t < 3.0:
        return 0.0
    k = int((t - 3.0) // 8.0)
    rng = np.random.default_rng(seed * 1009 + k)
    return float((-1) ** k * rng.uniform(15.0, 35.0))


def jsbsim_flight(sample_rate_hz: float, cond: str = "cruise", duration_s: float = 30.0,
                  surface: str = "aileron", seed: int = 0) -> Profile:
    """Fly the c172x at ``cond`` for ``duration_s``; returns the chosen surface's command."""
    import jsbsim  # imported here: only flights need it

    if surface not in ("aileron", "elevator"):
        raise ConfigError("surface must be aileron or elevator", field="surface")
    c = condition(cond)
    if c.airspeed_mps < 30.0:
        raise ConfigError(f"condition {cond!r} is not flyable by the {AIRCRAFT} (below 30 m/s)",
                          field="condition")
    with _quiet_stdout():
        fdm = jsbsim.FGFDMExec(None)
        fdm.set_debug_level(0)
        if not fdm.load_model(AIRCRAFT):
            raise ConfigError(f"JSBSim cannot load {AIRCRAFT}", field="aircraft")
        fdm.set_output_filename(0, os.devnull)  # the c172x asks for a CSV log in the cwd
        fdm.disable_output()
        fdm["ic/h-sl-ft"] = c.altitude_m / FT
        fdm["ic/vt-kts"] = c.airspeed_mps / 0.514444
        fdm["ic/gamma-deg"] = 0.0
        fdm["ic/psi-true-deg"] = 0.0
        fdm.run_ic()
        fdm["propulsion/set-running"] = -1
        fdm["propulsion/engine/set-running"] = 1
        fdm.run_ic()
        try:
            fdm.do_trim(1)
        except Exception as error:  # jsbsim raises its own TrimFailureError
            raise ConfigError(f"JSBSim cannot trim the {AIRCRAFT} at {cond!r}: {error}",
                              field="condition") from None
    theta_trim = float(fdm["attitude/theta-deg"])
    elev_trim = float(fdm["fcs/elevator-cmd-norm"])
    dt = float(fdm.get_delta_t())
    n = math.ceil(duration_s / dt) + 2
    rows = np.empty((n, 7))
    for k in range(n):
        t = float(fdm.get_sim_time())
        phi = float(fdm["attitude/phi-deg"])
        p = math.degrees(float(fdm["velocities/p-rad_sec"]))
        ail = 0.02 * (bank_schedule(t, seed) - phi) - 0.01 * p
        theta = float(fdm["attitude/theta-deg"])
        q = math.degrees(float(fdm["velocities/q-rad_sec"]))
        elev = elev_trim - 0.05 * (theta_trim + 0.1 * abs(phi) - theta) + 0.02 * q
        fdm["fcs/aileron-cmd-norm"] = float(np.clip(ail, -1.0, 1.0))
        fdm["fcs/elevator-cmd-norm"] = float(np.clip(elev, -1.0, 1.0))
        fdm.run()
        rows[k] = (t, float(fdm["fcs/aileron-cmd-norm"]), float(fdm["fcs/elevator-cmd-norm"]),
                   float(fdm["position/h-sl-ft"]) * FT, float(fdm["velocities/vt-fps"]) * FT,
                   float(fdm["atmosphere/rho-slugs_ft3"]) * SLUG_FT3,
                   float(fdm["aero/qbar-psf"]) * PSF)
    m = round(duration_s * sample_rate_hz)
    ts = np.arange(1, m + 1) / sample_rate_hz
    col = 1 if surface == "aileron" else 2

    def at(j: int) -> np.ndarray:
        return np.interp(ts, rows[:, 0], rows[:, j])

    return Profile(
        name=f"jsbsim-{AIRCRAFT}-{surface}@{c.name}", time_s=ts,
        command_deg=at(col) * MAX_DEFLECTION_DEG, altitude_m=at(3), airspeed_mps=at(4),
        density_kg_m3=at(5), dynamic_pressure_pa=at(6))
