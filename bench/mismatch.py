"""Mismatched units through the BIT: do they fly it, and how far do they sit from the data sheet?

For each actuator file, a fleet of units (``mapr_daemon.testbed.mismatch.fleet``) flies the BIT
profile at the envelope's corners (ground and max dynamic pressure, cold and hot, low and high
bus), each beside its data sheet's twin (same noise seed, same condition). Printed per actuator
and corner: the end-of-hold position error (mean and worst unit) and, per channel, how far a
unit's record sits from its twin's: the RMS over the BIT of the difference, in units of the
channel's noise (mean and worst unit). The fleet seed is printed; pick another with ``--seed``.

Run: ``python3 bench/mismatch.py [--units 20] [--seed 2024]``.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
from seeds import fresh as fresh_seed

from mapr_daemon.ema.batch import RunSpec
from mapr_daemon.ema.params import CHANNELS, load_actuator
from mapr_daemon.ema.plant import EmaBatch, SensorBlock
from mapr_daemon.testbed.mismatch import fleet
from mapr_daemon.testbed.profiles import bit_profile

ACTUATORS = Path(__file__).resolve().parents[1] / "configs" / "actuators"
SHOWN = ("dc_link_current_a", "phase_a_current_a", "dc_bus_voltage_v", "position_deg",
         "smps_input_current_a", "ripple_rms_v")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--units", type=int, default=20)
    ap.add_argument("--seed", type=int, help="default: drawn afresh (printed)")
    args = ap.parse_args()
    args.seed = fresh_seed(args.seed)
    print(f"fleet seed {args.seed} (both actuators), {args.units} units each; distance = "
          "RMS(unit - twin) over the BIT / the channel's noise (its LSB if noiseless), "
          "mean/worst unit")
    t0 = time.perf_counter()
    for name in ("aileron-uav", "elevator-uav"):
        sheet = load_actuator(ACTUATORS / f"{name}.yaml")
        units = fleet(sheet, args.units, seed=args.seed)
        forms = [u.form for u in units]
        print(f"\n{name}: unit seeds {[u.seed for u in units][:4]}...; stiction "
              f"{sum(f.breakaway_ratio > 0 for f in forms)}, voltage mode "
              f"{sum(f.voltage_mode for f in forms)}, discrete loops "
              f"{sum(f.current_loop_hz > 0 for f in forms)} of {len(forms)}")
        rate = sheet.sensors.sample_rate_hz
        prof = bit_profile(rate, "ground")
        end = round(prof.corners_s[2] * rate)
        env = sheet.envelope
        for q, amb, bus in ((0.0, env.ambient_min_c, sheet.bus.min_v),
                            (env.max_dynamic_pressure_pa, env.ambient_max_c, sheet.bus.max_v)):
            print(f"  q {q:6.0f} Pa, {amb:+.0f} C, bus {bus:.0f} V:")
            specs = [u.spec(seed=k, ambient_c=amb, bus_v=bus) for k, u in enumerate(units)]
            twins = [RunSpec(sheet, seed=k, ambient_c=amb, bus_v=bus) for k in range(len(units))]
            speeds, blocks = [], []
            for group in (specs, twins):
                tb = time.perf_counter()
                blocks.append(EmaBatch(group, powered=False).advance(
                    prof.n_samples, prof.command_deg[None], q))
                speeds.append(len(group) * prof.time_s[-1] / (time.perf_counter() - tb))
            twin = blocks[1].truth["position_true_deg"]
            start = round(prof.corners_s[0] * rate)
            reach = (twin[:, start:] > 19.8).argmax(axis=1) / rate * 1e3
            print(f"    data sheet (twins): 19.8 deg after {reach.min():.0f}-{reach.max():.0f} ms,"
                  f" overshoot {twin.max(axis=1).min() - 20:.2f}-{twin.max(axis=1).max() - 20:.2f}"
                  f" deg, end-of-hold error worst "
                  f"{np.abs(twin[:, end - 100:end] - 20).max():.3f} deg")
            block = SensorBlock(blocks[0].time_s, {
                c: np.concatenate([b.channels[c] for b in blocks]) for c in CHANNELS},
                {"position_true_deg": blocks[0].truth["position_true_deg"]})
            print(f"  (simulated actuator-s per wall s: units {speeds[0]:.0f}, twins "
                  f"{speeds[1]:.0f})")
            pos = block.truth["position_true_deg"][: len(units)]
            hold = np.abs(pos[:, end - 100:end] - 20.0).max(axis=1)
            back = np.abs(pos[:, -100:]).max(axis=1)
            print("    units: end-of-hold error mean "
                  f"{hold.mean():.3f} worst {hold.max():.3f} deg; back at 0 mean "
                  f"{back.mean():.3f} worst {back.max():.3f} deg")
            parts = []
            for c in SHOWN:
                x = block.channels[c]
                noise = max(sheet.sensors.channels[c].noise_rms,
                            2 * sheet.sensors.channels[c].full_scale
                            / 2 ** sheet.sensors.channels[c].bits)
                d = np.sqrt(((x[: len(units)] - x[len(units):]) ** 2).mean(axis=1)) / noise
                parts.append(f"{c} {d.mean():.1f}/{d.max():.1f}")
            print("    distance: " + "; ".join(parts[:3]))
            print("              " + "; ".join(parts[3:]))
    assert set(SHOWN) <= set(CHANNELS)
    print(f"\nwall time {time.perf_counter() - t0:.1f} s")


if __name__ == "__main__":
    main()
