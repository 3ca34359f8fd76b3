"""The demo's reasoner: the fault dictionaries and prognostic models it diagnoses with, and the
BIT diagnosis.

``mapr demo`` must run on a fresh machine with nothing but the package. When no
``--dictionary`` is given, each actuator type's dictionary and prognostic model (what SoH
trends and RUL need, :mod:`mapr_daemon.reasoner.prognosis.prognostic_model`) come from, in
order:

1. the pre-built pair shipped with the package for the demo's stock actuators
   (:mod:`.demo_models`), when it was built by the current code (its key matches);
2. the user's cache directory (``$MAPR_CACHE``, else ``$XDG_CACHE_HOME/mapr``, else
   ``~/.cache/mapr``), under the same key;
3. a build from the shipped spec (``configs/reasoner/dictionary.yaml``), cached there: minutes
   of CPU, with a progress line that estimates the time left from the rate so far.

The key (:func:`~.demo_models.models_key`) is a digest of the spec, the actuator file, the
sample rate, the file formats and the source of every module the builds can run, so a changed
model is never diagnosed with a stale dictionary.
"""

from __future__ import annotations

import os
import sys
import time
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path

from drivers.mil1553.record import MonitorRecord
from mapr_daemon.cli.commands.dictionary import peak_rss_mb
from mapr_daemon.ema.params import ActuatorParams
from mapr_daemon.findings import Diagnosis
from mapr_daemon.pipeline.clock import BusClock
from mapr_daemon.pipeline.pipeline import Batch, build_pipeline
from mapr_daemon.pipeline.settings import ReasonerConfig
from mapr_daemon.service.config import Config
from mapr_daemon.testbed import demo_models


def cache_dir() -> Path:
    """Where the demo keeps what it builds, and its catalog."""
    explicit = os.environ.get("MAPR_CACHE")
    if explicit:
        return Path(explicit)
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "mapr"


class ProgressLine:
    """A build's progress on stderr, with the time it has taken and an estimate of the time
    left from the rate so far (after the first 5 %: earlier the rate says little); at 100 %
    it says what follows the simulation (``then``: fitting, not counted in the estimate). A
    terminal gets one line redrawn at every whole percent, a log one line per tenth."""

    def __init__(self, label: str, then: str) -> None:
        self.label, self.then = label, then
        self.started = time.monotonic()
        self.tty = sys.stderr.isatty()
        self.shown = -1

    def __call__(self, fraction: float) -> None:
        step = int(100 * fraction) if self.tty else 10 * int(10 * fraction)
        if step == self.shown:
            return
        self.shown = step
        elapsed = time.monotonic() - self.started
        left = ""
        if 0.05 <= fraction < 1.0:
            left = f", about {elapsed / fraction * (1.0 - fraction):.0f} s left"
        elif fraction >= 1.0:
            left = f"; {self.then}"
        if self.tty:
            print(f"\r  {self.label}: {step:3d} % ({elapsed:.0f} s{left})   ", end="",
                  file=sys.stderr, flush=True)
        else:
            print(f"  {self.label}: {step:3d} % ({elapsed:.0f} s{left})", file=sys.stderr,
                  flush=True)

    def done(self, what: str) -> None:
        """The closing line: what was built, in how long, at what peak memory."""
        line = f"  {what} in {time.monotonic() - self.started:.0f} s (peak memory " \
            f"{peak_rss_mb():.0f} MB)"
        print(f"\r{line}{' ' * 40}" if self.tty else line, file=sys.stderr)


def last_build_cpu_s(params: ActuatorParams, actuator_path: Path) -> float | None:
    """CPU seconds the shipped pair of this type took to build (its manifest), if shipped."""
    stock = demo_models.stock_for(actuator_path, params.sensors.sample_rate_hz)
    entry = None if stock is None else demo_models.read_manifest()["pairs"].get(stock.stem)
    return None if entry is None else float(entry["built"]["cpu_s"])


def _save(write: Callable[[Path], None], path: Path) -> None:
    """Write through a temporary name: a killed build never leaves a half file under a key."""
    path.parent.mkdir(parents=True, exist_ok=True)
    partial = path.with_suffix(".partial.npz")
    write(partial)
    partial.replace(path)


def build_dictionary(params: ActuatorParams, spec_path: Path, path: Path,
                     cpu_hint_s: float | None) -> None:
    """Build this type's fault dictionary into ``path``, progress on stderr."""
    from mapr_daemon.reasoner.diagnosis.dictionary import DictionarySpec
    from mapr_daemon.reasoner.training.dictionary_build import build
    hint = "" if cpu_hint_s is None else \
        f"; the dictionary and model together took {cpu_hint_s:.0f} s of CPU when last built"
    print(f"Building the {params.name} fault dictionary at {params.sensors.sample_rate_hz:g} "
          f"Hz ({spec_path.name}{hint}); it is kept in {path.parent}", file=sys.stderr)
    line = ProgressLine("dictionary: simulating fault-seeded BITs",
                        "fitting the healthy and fault models, calibrating the thresholds")
    dictionary = build(params, DictionarySpec.load(spec_path), progress=line)
    _save(dictionary.save, path)
    line.done("dictionary built")


def build_prognosis(params: ActuatorParams, dictionary_path: Path, path: Path,
                    cpu_hint_s: float | None) -> None:
    """Build this type's prognostic model from its dictionary into ``path``, progress on
    stderr."""
    from mapr_daemon.reasoner.diagnosis.dictionary import Dictionary
    from mapr_daemon.reasoner.training.prognosis_build import build_prognostic_model
    print(f"Building the {params.name} prognostic model (degradation estimators, their noise, "
          f"fleet priors); it is kept in {path.parent}", file=sys.stderr)
    line = ProgressLine("prognostic model: simulating BITs at known wear",
                        "fitting the estimators and their noise, learning the fleet priors")
    model = build_prognostic_model(Dictionary.load(dictionary_path), params, progress=line)
    _save(model.save, path)
    line.done("prognostic model built")


def cached_dictionary(params: ActuatorParams, actuator_path: Path,
                      spec_path: Path | None = None) -> Path:
    """This type's dictionary at ``params``' rate: the shipped one, else the cached one, else
    built (with progress on stderr) and cached."""
    return cached_models(params, actuator_path, spec_path, dictionary_only=True)[0]


def cached_models(params: ActuatorParams, actuator_path: Path,
                  spec_path: Path | None = None, *, dictionary_only: bool = False
                  ) -> tuple[Path, Path]:
    """This type's dictionary and prognostic model at ``params``' sample rate: the shipped
    pair when the current code built it, else the cached files, else built (progress on
    stderr) and cached. ``dictionary_only``: the model is not built (its path may not
    exist)."""
    spec_path = spec_path or demo_models.demo_spec_path()
    rate = params.sensors.sample_rate_hz
    key = demo_models.models_key(spec_path, actuator_path, rate)
    stock = demo_models.stock_for(actuator_path, rate)
    ready = None if stock is None else demo_models.shipped(stock.stem, key)
    if ready is not None:
        return ready
    dictionary = cache_dir() / f"dictionary-{key}.npz"
    prognosis = cache_dir() / f"prognosis-{key}.npz"
    hint = last_build_cpu_s(params, actuator_path)
    if not dictionary.exists():
        if stock is not None:
            why = "do not match this code" if stock.stem in \
                demo_models.read_manifest()["pairs"] else "are not shipped"
            print(f"The pre-built {stock.stem} models {why} (`python3 -m "
                  f"mapr_daemon.testbed.demo_models --check` says why): building them.",
                  file=sys.stderr)
        build_dictionary(params, spec_path, dictionary, hint)
    if not (dictionary_only or prognosis.exists()):
        build_prognosis(params, dictionary, prognosis, hint)
    return dictionary, prognosis


def diagnose_bits(icd_path: str | Path, records: Sequence[MonitorRecord],
                  dictionary_path: Path) -> Batch:
    """Every BIT in the traffic, cut out, decided and stamped by the daemon's own path
    (:mod:`mapr_daemon.pipeline.pipeline`, the default asset: EMA1 on RT 5, the shipped
    actuator file and wiring)."""
    config = Config(icd=str(icd_path), reasoner=ReasonerConfig(dictionary=str(dictionary_path)))
    return build_pipeline(config).process(list(records), BusClock())


def describe(diagnosis: Diagnosis) -> Iterable[str]:
    """A maintainer's reading of one diagnosis."""
    evidence = diagnosis.evidence
    at = evidence.get("bit_bus_time_s")
    head = f"BIT at bus time {at:.3f} s" if isinstance(at, float) else "BIT"
    if not diagnosis.anomaly:
        yield (f"{head}: nominal (score {evidence.get('score', 0):.0f} below threshold "
               f"{evidence.get('threshold', 0):.0f})")
        return
    switch = diagnosis.switch
    fault = f"{diagnosis.fault}/{switch}" if switch else str(diagnosis.fault)
    severity = diagnosis.severity
    amount = "" if severity is None else f", severity {severity:.4g} {diagnosis.unit or ''}"
    soh = 1.0 if diagnosis.soh is None else diagnosis.soh
    yield (f"{head}: ANOMALY {fault}{amount}, confidence {diagnosis.confidence:.2f}, "
           f"state of health {soh:.2f} ({diagnosis.component or ''})")
    yield (f"    score {evidence.get('score', 0):.0f} vs threshold "
           f"{evidence.get('threshold', 0):.0f}")
