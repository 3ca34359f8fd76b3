"""Our healthy model, signature models and false-alarm calibration on synthetic data whose
truth is known, and the inconclusive decision on a real record flown at a sagging supply."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from mapr_daemon.errors import ConfigError
from mapr_daemon.reasoner.diagnosis import classifier, fault_models, healthy_model
from mapr_daemon.reasoner.diagnosis.false_alarm import calibrate
from tests.reasoner.conftest import HELD_OUT, Bench


def test_ledoit_wolf_shrinks_little_with_many_runs_and_much_with_few() -> None:
    rng = np.random.default_rng(1)
    p = 40
    factor = rng.normal(size=(p, 2))
    cov = factor @ factor.T + np.eye(p)
    many = rng.multivariate_normal(np.zeros(p), cov, 4000)
    few = rng.multivariate_normal(np.zeros(p), cov, 30)
    s_many, a_many = healthy_model.ledoit_wolf(many)
    _, a_few = healthy_model.ledoit_wolf(few)
    assert a_many < 0.05 < a_few
    assert np.abs(s_many - cov).max() < 0.25 * np.abs(cov).max()


def _conditions(rng: np.random.Generator, n: int) -> list[healthy_model.Conditions]:
    q = rng.uniform(0, 2500, n)
    v = rng.normal(27.5, 0.5, n)
    t = rng.normal(25, 10, n)
    return [healthy_model.Conditions(float(a), float(b), float(b), float(c))
            for a, b, c in zip(q, v, t, strict=True)]


def _synthetic_m(rng: np.random.Generator, conds: list[healthy_model.Conditions],
                 columns: list[str], rows: int) -> np.ndarray:
    """M whose record cells depend on pressure and supply like a plant, plus a shared factor."""
    n = len(conds)
    m = rng.normal(0.0, 1.0, (n, rows, len(columns)))
    shared = rng.normal(0.0, 1.0, n)  # e.g. friction scatter: moves many cells together
    for i, c in enumerate(conds):
        m[i, :, columns.index(healthy_model.SUPPLY)] = c.supply_v
        m[i, :, columns.index(healthy_model.TEMPERATURE)] = c.temperature_c
        m[i, :, 0] += 3.0 * c.pressure_pa / 2500 + 0.5 * (c.supply_v - 27.5) + shared[i]
        m[i, :, 1] += 2.0 * shared[i]
    return m


COLUMNS = ["mean:dc_link_current_a", "mean:phase_a_current_a", healthy_model.SUPPLY,
           healthy_model.TEMPERATURE]


def test_healthy_model_removes_conditions_and_whitens() -> None:
    rng = np.random.default_rng(2)
    rows = healthy_model.PAPER_ROWS + 20
    cells = healthy_model.record_cells(COLUMNS, rows)
    assert cells.shape == (20 * 2, 1)  # the two current means, over the 20 record rows
    assert healthy_model.record_cells(COLUMNS, rows, 4).shape == (5 * 2, 4)
    conds = _conditions(rng, 400)
    model, whiten = healthy_model.fit(_synthetic_m(rng, conds, COLUMNS, rows), conds, cells, 27.5,
                                      25.8, 25.8, 24.0)
    test_conds = _conditions(rng, 300)
    test_m = _synthetic_m(rng, test_conds, COLUMNS, rows)
    z = np.stack([model.standardized(test_m[i], c) for i, c in enumerate(test_conds)])
    assert abs(float(z.mean())) < 0.1  # pressure and supply predicted away
    # the shared factor correlates the cells; whitened, held-out healthy runs are white
    off = ~np.eye(cells.shape[0], dtype=bool)
    assert float(np.abs(np.corrcoef(z.T)[off]).mean()) > 0.3
    w = z @ whiten
    # out of sample the smallest eigen-directions are under-estimated (a known bias that the
    # shrinkage only tempers), so the variances are near, not at, one
    assert 0.8 < float(np.diag(np.cov(w.T)).mean()) < 1.4
    assert float(np.abs(np.corrcoef(w.T)[off]).mean()) < 0.1


def test_false_alarm_threshold_matches_the_chi_square_quantile() -> None:
    rng = np.random.default_rng(3)
    scores = 2.0 * rng.chisquare(3.0, 2000)
    cal = calibrate(scores, 1e-4)
    truth = 2.0 * stats.chi2.isf(1e-4, 3.0)
    assert abs(cal.threshold - truth) < 0.15 * truth
    assert abs(cal.dof - 3.0) < 0.5 and abs(cal.scale - 2.0) < 0.3
    assert not cal.tail_governs
    heavy = np.concatenate([scores, [10 * truth]])  # a tail the law does not describe
    assert calibrate(heavy, 1e-4).threshold == 10 * truth
    with pytest.raises(ConfigError, match="false-alarm"):
        calibrate(scores, 0.7)
    with pytest.raises(ConfigError, match="calibration"):
        calibrate(scores[:5], 1e-4)


def test_signature_model_recovers_the_severity_of_a_smooth_fault() -> None:
    rng = np.random.default_rng(4)
    knots = np.array([0.0, 0.5, 1.0])
    direction = rng.normal(size=6)

    def signature(s: float, q: float) -> np.ndarray:
        return (20 * s + 10 * s * s) * (1 + q / 2500) * direction

    sev = rng.uniform(0.05, 1.0, 80)
    conds = _conditions(rng, 80)
    y = np.stack([signature(s, c.pressure_pa) + rng.normal(0, 0.3, 6)
                  for s, c in zip(sev, conds, strict=True)])
    coef = fault_models.fit_parametric(y, sev, conds, knots, 27.5)
    other = rng.normal(size=6) * 30
    models = fault_models.FaultModels(knots, [coef, None], [None, np.stack([other, other])],
                                      np.array([0.0, 2500.0]), 27.5)
    c = healthy_model.Conditions(1200.0, 27.5, 27.5, 25.0)
    fits = fault_models.fit_all(models, signature(0.6, 1200.0), c)
    assert abs(fits[0].severity - 0.6) < 0.05
    assert fits[0].residual < fits[1].residual
    zero = np.zeros(6)
    assert fault_models.glr_score(zero, fault_models.fit_all(models, zero, c)) == 0.0


def test_a_record_flown_below_the_supply_headroom_is_inconclusive(bench: Bench) -> None:
    d = bench.dictionary
    assert d.healthy is not None
    i = [k for k, _, _ in HELD_OUT].index("friction")
    m = bench.held_m[i].copy()
    col = d.columns.index(healthy_model.SUPPLY)
    m[healthy_model.PAPER_ROWS + 10, col] = d.healthy.supply_floor_v - 0.3
    dec = classifier.decide(d, m, HELD_OUT[i][2])
    assert dec.inconclusive and not dec.anomaly and dec.confidence == 0.0
    assert "aircraft-bus voltage" in dec.evidence["inconclusive"]
    assert classifier.decide(d, bench.held_m[i], HELD_OUT[i][2]).anomaly
