"""``mapr dictionary``: build the reasoner's fault dictionary, or plot its fault curves.

::

    mapr dictionary build -o dictionary.npz                # configs/reasoner/dictionary.yaml
    mapr dictionary build --spec my.yaml -o small.npz
    mapr dictionary build --jobs 1 -o dictionary.npz       # one worker thread (default: a
                                                           # thread per usable core)
    mapr dictionary plot dictionary.npz -o plots/          # paper Figs. 13-15 and 17
    mapr dictionary describe dictionary.npz                # what it holds: modes, thresholds,
                                                           # where on the envelope each mode
                                                           # is seen (--json: as JSON)
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import Any

from mapr_daemon.ema.params import default_actuator_path, load_actuator, with_sample_rate
from mapr_daemon.reasoner.diagnosis.dictionary import DictionarySpec


def default_spec_path() -> Path:
    """The shipped dictionary spec."""
    return Path(__file__).resolve().parents[3] / "configs" / "reasoner" / "dictionary.yaml"


def add_subparser(subparsers: Any) -> None:
    p = subparsers.add_parser("dictionary", help="build or plot the reasoner's fault dictionary",
                              description=__doc__,
                              formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="action", metavar="ACTION")
    sub.required = True
    b = sub.add_parser("build", help="simulate fault-seeded BIT runs into a dictionary file")
    b.add_argument("-o", "--output", required=True, type=Path)
    b.add_argument("--spec", type=Path, help="dictionary spec YAML (default: shipped)")
    b.add_argument("--prognosis", type=Path, metavar="FILE",
                   help="also build the actuator's prognostic model (degradation estimators, "
                        "their measured noise, fleet priors) into FILE: what SoH trends and "
                        "RUL need (assets[].prognosis)")
    b.add_argument("--actuator", type=Path, help="actuator YAML (default: aileron-uav)")
    b.add_argument("--sample-rate", type=float, default=None, metavar="HZ",
                   help="the sensors' sample rate on your bus (default: the actuator file's); "
                        "e.g. 1000 for the elevator of configs/icd/ema-testbed-two-ema.yaml")
    b.add_argument("--jobs", type=jobs, default=None, metavar="N",
                   help="worker threads (default: the cores this process may use)")
    b.set_defaults(func=run_build)
    pl = sub.add_parser("plot", help="fault curves as PNG files (paper Figs. 13-15, 17)")
    pl.add_argument("dictionary", type=Path)
    pl.add_argument("-o", "--output", required=True, type=Path, help="output directory")
    pl.set_defaults(func=run_plot)
    ds = sub.add_parser("describe", help="what a dictionary holds: modes, thresholds and where "
                                         "on the envelope each mode is seen")
    ds.add_argument("dictionary", type=Path)
    ds.add_argument("--json", action="store_true", help="one JSON document")
    ds.set_defaults(func=run_describe)


def peak_rss_mb() -> float:
    """This process's peak resident memory so far, in MB (the figure a build is held to)."""
    import resource

    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0   # Linux: kB


def jobs(text: str) -> int:
    """``--jobs``: a whole number >= 1."""
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 1:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number >= 1")
    return value


def run_build(args: argparse.Namespace) -> int:
    from mapr_daemon.reasoner.training.dictionary_build import build
    from mapr_daemon.reasoner.training.workers import resolve

    spec = DictionarySpec.load(args.spec or default_spec_path())
    params = load_actuator(args.actuator or default_actuator_path())
    if args.sample_rate is not None:   # the BIT record is sampled at the bus's rate
        params = with_sample_rate(params, args.sample_rate)
    workers = resolve(args.jobs)
    start = time.monotonic()
    cpu = time.process_time()
    tty = sys.stderr.isatty()

    def progress(fraction: float) -> None:
        if tty:
            sys.stderr.write(f"\rsimulating {100 * fraction:5.1f} %")
            sys.stderr.flush()

    d = build(params, spec, progress=progress, workers=workers)
    if tty:
        sys.stderr.write("\n")
    d.save(args.output)
    print(f"wrote {args.output}: {len(d.templates)} templates at {len(d.pressures_pa)} "
          f"pressures, threshold {d.threshold:.1f}, {time.monotonic() - start:.1f} s "
          f"({time.process_time() - cpu:.1f} s CPU on {workers} worker"
          f"{'s' if workers > 1 else ''}, peak memory {peak_rss_mb():.0f} MB)")
    if args.prognosis is not None:
        from mapr_daemon.reasoner.training.prognosis_build import build_prognostic_model
        start = time.monotonic()
        model = build_prognostic_model(d, params, workers=workers)
        model.save(args.prognosis)
        unusable = "".join(f"; {k} not trended: {why}" for k, why in model.unobservable.items())
        print(f"wrote {args.prognosis}: degradation estimators for {', '.join(model.kinds)}"
              f"{unusable}, {time.monotonic() - start:.1f} s")
    return 0


def run_plot(args: argparse.Namespace) -> int:
    from mapr_daemon.reasoner.diagnosis.curve_plots import plot_dictionary
    from mapr_daemon.reasoner.diagnosis.dictionary import Dictionary

    d = Dictionary.load(args.dictionary)
    for path in plot_dictionary(d, args.output):
        print(path)
    return 0


def run_describe(args: argparse.Namespace) -> int:
    import json

    from mapr_daemon.reasoner.diagnosis.dictionary import Dictionary
    from mapr_daemon.reasoner.diagnosis.features import SWITCH_SOURCES

    d = Dictionary.load(args.dictionary)
    cal = d.calibration
    sensed = [SWITCH_SOURCES[s] for s in d.signals if s in SWITCH_SOURCES]
    kinds = sorted({t.kind for t in d.templates if not t.switch})
    switches = sorted(f"{t.kind} {t.switch}" for t in d.templates if t.switch)
    thresholds = {"anomaly (likelihood ratio)": d.threshold,
                  "healthy residual": cal.get("null_threshold"),
                  "matched filter (phase-A Ron)": cal.get("matched_threshold"),
                  "pair gain (two faults)": cal.get("pair_threshold"),
                  "unexplained (left by the best explanation)": cal.get("unexplained_threshold")}
    unit = d.healthy is not None and d.healthy.unit_coef is not None
    doc = {"file": str(args.dictionary), "actuator": d.actuator,
           "sample_rate_hz": d.sample_rate_hz, "parametric_modes": kinds,
           "switch_faults": switches, "false_alarm_rate": cal.get("false_alarm_rate"),
           "calibrated_to_a_unit": unit, "switch_temperatures": sensed,
           "thresholds": thresholds,
           "detection_map": None if d.detection is None else d.detection.as_json()}
    if args.json:
        print(json.dumps(doc, indent=2))
        return 0
    print(f"{args.dictionary}: {d.actuator} at {d.sample_rate_hz:g} Hz"
          f"{', calibrated to a unit' if unit else ''}")
    print(f"parametric modes: {', '.join(kinds)}")
    print(f"switch faults: {', '.join(switches) or 'none'}")
    print("switch temperatures: " + (f"read ({', '.join(sensed)}; a record without them is "
                                     "flagged)" if sensed else "not read"))
    print(f"false-alarm rate per BIT: {cal.get('false_alarm_rate', float('nan')):g}")
    for name, value in thresholds.items():
        print(f"  {name:<44} {'-' if value is None else f'{value:.4g}'}")
    if d.detection is None:
        print("no detection map (built before it, or with detection_map_runs: 0)")
    else:
        print("where each mode is seen:")
        for line in d.detection.table():
            print(f"  {line}")
    return 0
