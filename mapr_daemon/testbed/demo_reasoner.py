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
from collections.abc import Iterable, Sequence
from pathlib import Path

from drivers.mil1553.record import MonitorRecord
from mapr_daemon.ema.params import ActuatorParams
from mapr_daemon.findings import Diagnosis
from mapr_daemon.pipeline.clock import BusClock
from mapr_daemon.pipeline.pipeline import Batch, build_pipeline
from mapr_daemon.pipeline.settings import ReasonerConfig
from mapr_daemon.service.config import Config
from mapr_daemon.testbed import demo_models
from mapr_daemon.views.figures import severity_text


def cache_dir() -> Path:
    """Where the demo keeps what it builds, and its catalog."""
    explicit = os.environ.get("MAPR_CACHE")
    if explicit:
        return Path(explicit)
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "mapr"


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
    hint = demo_models.last_build_cpu_s(params, actuator_path)
    if not dictionary.exists():
        if stock is not None:
            why = "do not match this code" if stock.stem in \
                demo_models.read_manifest()["pairs"] else "are not shipped"
            print(f"The pre-built {stock.stem} models {why} (`python3 -m "
                  f"mapr_daemon.testbed.demo_models --check` says why): building them.",
                  file=sys.stderr)
        demo_models.build_dictionary(params, spec_path, dictionary, hint)
    if not (dictionary_only or prognosis.exists()):
        demo_models.build_prognosis(params, dictionary, prognosis, hint)
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
    severity = ("" if diagnosis.severity is None else ": " + severity_text(
        None, diagnosis.severity, diagnosis.unit, evidence))
    # the SoH is the trend's, on the health line below (one figure, as every view states it)
    yield (f"{head}: ANOMALY {fault}{severity} ({diagnosis.component or ''}), confidence "
           f"{diagnosis.confidence:.2f}")
    yield (f"    score {evidence.get('score', 0):.0f} vs threshold "
           f"{evidence.get('threshold', 0):.0f}")
