"""``mapr dictionary``: build the reasoner's fault dictionary, or plot its fault curves.

::

    mapr dictionary build -o dictionary.npz                # configs/reasoner/dictionary.yaml
    mapr dictionary build --spec my.yaml -o small.npz
    mapr dictionary build --jobs 1 -o dictionary.npz       # one worker thread (default: a
                                                           # thread per usable core)
    mapr dictionary plot dictionary.npz -o plots/          # paper Figs. 13-15 and 17
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
