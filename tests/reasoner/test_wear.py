"""The per-kind degradation estimators: the inversion on a known forward model, and ESR read
around its failure threshold (ESR x2, 5 % of its Table 1 range) on simulated BITs."""

from __future__ import annotations

import numpy as np
import pytest

from mapr_daemon.ema.faults import Fault, FaultSet, nominal_value
from mapr_daemon.errors import ConfigError
from mapr_daemon.reasoner.prognosis import soh, wear_estimators
from mapr_daemon.reasoner.training.corpus import simulate_bit
from mapr_daemon.reasoner.training.dictionary_build import run_matrices

from .conftest import Bench


def test_inverts_a_known_forward_model() -> None:
    """Coordinates made by a known forward model (cubic in h, second order in the conditions)
    plus small noise: the estimate recovers h
    across and beyond the threshold, and runs at other conditions do not bias it."""
    rng = np.random.default_rng(3)
    coef = rng.standard_normal((25, 6))
    coef[10:20] *= 3.0  # a clear signature: the h-terms

    def draw(n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        h = rng.uniform(0.0, 1.5, n)
        c = np.c_[rng.uniform(0.0, 1.0, n), rng.normal(0.0, 1.0, n), rng.normal(0.0, 1.0, n)]
        y = np.stack([wear_estimators.regressors(h[i: i + 1], c[i])[0] for i in range(n)]) @ coef
        return y + 0.01 * rng.standard_normal(y.shape), c, h

    y, c, h = draw(200)
    model = wear_estimators.WearModel.fit("esr", y, c, h)
    yt, ct, ht = draw(40)
    est = np.array([model.estimate(yt[i], ct[i]) for i in range(40)])
    assert np.abs(est - ht).max() < 0.02
    with pytest.raises(ConfigError):
        wear_estimators.WearModel.fit("esr", y[:10], c[:10], h[:10])


def test_reads_esr_near_its_threshold(bench: Bench) -> None:
    """Trained on 60 ESR BITs (0 to 1.5 of the threshold), the estimator reads BITs of other
    seeds at 0, 0.5 and 1.0 of the threshold within 0.2, in order."""
    params, d = bench.params, bench.dictionary
    lo = nominal_value(params, "esr")
    span = soh.failure_value(params, "esr") - lo
    rng = np.random.default_rng(11)
    h_train = rng.uniform(0.0, 1.5, 60)
    h_test = np.repeat([0.0, 0.5, 1.0], 3)
    h_all = np.r_[h_train, h_test]
    fs = [FaultSet.of([Fault("esr", lo + h * span)]) if h > 0 else FaultSet() for h in h_all]
    qs = [float(q) for q in rng.uniform(100.0, 1500.0, h_all.size)]
    runs = simulate_bit(params, fs, qs, [60_000 + i for i in range(h_all.size)])
    m = run_matrices(runs, d.window_starts, d.window_samples)
    y, c = wear_estimators.observations(d, m, qs)
    models = wear_estimators.fit_kinds(["esr"], y[:60], c[:60], h_train, ["esr"] * 60)
    est = np.array([models["esr"].estimate(y[i], c[i]) for i in range(60, h_all.size)])
    assert np.abs(est - h_test).max() < 0.2, est
    means = est.reshape(3, 3).mean(axis=1)
    assert means[0] < means[1] < means[2]
