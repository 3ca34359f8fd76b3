"""Window features (the paper's eight intermediate values) and the fault-curve matrices."""

from __future__ import annotations

import numpy as np
import pytest

from mapr_daemon.ema.faults import FaultSet
from mapr_daemon.ema.params import default_actuator_path, load_actuator
from mapr_daemon.errors import ConfigError
from mapr_daemon.reasoner.diagnosis import curves
from mapr_daemon.reasoner.diagnosis.features import (
    EXTENDED_SIGNALS,
    FEATURES,
    PAPER_SIGNALS,
    WindowSpec,
    column_names,
    feature_matrix,
    window_values,
)
from mapr_daemon.reasoner.training.corpus import simulate_bit

RATE = 2000.0


def test_window_values_of_a_sine_between_bins() -> None:
    n = 256
    t = np.arange(n) / RATE
    f0 = 203.3  # between the 7.8 Hz bins: the neighbour-bin refinement must find it
    x = 1.5 + 2.0 * np.sin(2 * np.pi * f0 * t)
    v = window_values(x[None, :], RATE)[0]
    mean, std, cube, freq, power, left, right, bw = v
    assert mean == pytest.approx(1.5, abs=0.02)
    assert std == pytest.approx(2.0 / np.sqrt(2), rel=0.01)
    assert cube == pytest.approx(std**3)
    assert abs(freq - f0) < 0.5  # far better than the 7.8 Hz bin
    assert left < freq < right
    assert bw == pytest.approx(right - left)
    assert bw < 4 * RATE / n  # a pure tone: a few bins wide with a Hann window
    assert power > 0


def test_features_follow_the_tone_and_the_amplitude() -> None:
    t = np.arange(64) / RATE
    a = window_values(np.sin(2 * np.pi * 300 * t)[None], RATE)[0]
    b = window_values(3 * np.sin(2 * np.pi * 500 * t)[None], RATE)[0]
    assert b[FEATURES.index("frequency")] > a[FEATURES.index("frequency")] + 150
    assert b[FEATURES.index("power")] == pytest.approx(9 * a[FEATURES.index("power")], rel=0.3)


def test_paper_matrix_is_32_by_32_in_the_paper_column_order() -> None:
    names = column_names(PAPER_SIGNALS)
    assert len(names) == 32
    assert names[:3] == ["mean:phase_a_current_a", "mean:phase_b_current_a",
                         "mean:phase_c_current_a"]
    assert names[3] == "std:phase_a_current_a"
    assert names[24:] == [f"{f}:position_deg" for f in FEATURES]
    assert len(column_names(EXTENDED_SIGNALS)) == 96
    assert column_names(EXTENDED_SIGNALS)[:32] == names
    rng = np.random.default_rng(0)
    sig = {s: rng.standard_normal((2, 2000)) for s in PAPER_SIGNALS}
    starts = WindowSpec().starts((300, 360, 1000, 1600), 2000)
    m = feature_matrix(sig, starts, 32, RATE)
    assert m.shape == (2, 32, 32)
    # column 0 window 0 is the mean of phase A's first window
    assert m[1, 0, 0] == pytest.approx(sig["phase_a_current_a"][1, starts[0]:starts[0] + 32].mean())


def test_windows_four_left_four_right_of_each_corner() -> None:
    starts = WindowSpec(length=10, per_side=4).starts((100, 500), 1000)
    assert starts.tolist()[:8] == [60, 70, 80, 90, 100, 110, 120, 130]
    assert len(starts) == 16
    with pytest.raises(ConfigError):
        WindowSpec(length=10).starts((20,), 1000)


def test_good_times_final_values_and_chosen_curve() -> None:
    levels = np.zeros((3, 2, 2))
    levels[:, 0, 0] = [1, 2, 3]   # monotone: kept
    levels[:, 0, 1] = [1, 3, 2]   # dips: dropped
    levels[:, 1, 0] = [0, 0, 0]   # flat counts as "stays the same": kept
    levels[:, 1, 1] = [5, 6, 9]   # monotone and largest at the end
    g = curves.good_times(levels)
    assert g.tolist() == [[True, False], [True, True]]
    v = curves.final_values(levels, g)
    assert v.shape == (3, 4)
    assert v[:, -1].tolist() == [1001, 2001, 2002]
    c = curves.chosen_curve(v)
    assert (c.row, c.col, c.reference) == (1, 1, 2002)
    assert c.values.tolist() == [5, 6, 9]
    scaled = curves.chosen_curve(v, scale=np.array([[0.1, 1.0], [1.0, 10.0]]))
    assert scaled.reference == 1001  # 3/0.1 beats 9/10
    assert curves.invert_curve(np.array([0, 0.5, 1]), np.array([0, 2, 4]), 3.0) == 0.75


def test_distance_is_elementwise_absolute_difference() -> None:
    a = np.array([[1.0, -2.0]])
    assert curves.distance(a, np.array([[3.0, 1.0]])).tolist() == [[2.0, 3.0]]


def test_pca_new_values_weight_the_changing_columns() -> None:
    rng = np.random.default_rng(1)
    nom = rng.standard_normal((32, 16))
    levels = np.stack([nom.copy() for _ in range(3)])
    ramp = np.linspace(0, 1, 32)
    for k in range(3):
        levels[k, :, 5] += (k + 1) * ramp  # only column 5 moves, more at each level
    a, nv = curves.pca_new_values(levels, nom, np.arange(16))
    assert np.argmax(np.abs(a)) == 5 and a[5] > 0.99
    assert nv.shape == (3, 32)
    assert np.all(np.diff(nv[:, -1]) > 0)


def test_variable_stride_descent_finds_the_valley_and_stops_on_stride() -> None:
    def f(x: np.ndarray) -> float:
        return float((x[0] - 1.3) ** 2 + 4 * (x[1] + 0.7) ** 2)

    res = curves.variable_stride_descent(f, np.array([5.0, 5.0]), step=0.5, min_step=1e-4)
    assert np.allclose(res.x, [1.3, -0.7], atol=1e-2)
    assert res.value < 1e-3
    bounded = curves.variable_stride_descent(f, np.array([0.0, 0.0]), 0.5, 1e-4,
                                             np.array([0.0, 0.0]), np.array([1.0, 1.0]))
    assert bounded.x[0] == pytest.approx(1.0, abs=1e-3)
    assert bounded.x[1] == pytest.approx(0.0, abs=1e-3)


def test_simulate_bit_chunk_as_long_as_the_batch_is_still_the_bit() -> None:
    """The BIT command is shared and the pressure per run whatever the chunk: a chunk as long
    as the batch gives the same runs as the default chunking."""
    params = load_actuator(default_actuator_path())
    faults, qs, seeds = [FaultSet()] * 3, [300.0, 900.0, 1800.0], [1, 2, 3]
    same = simulate_bit(params, faults, qs, seeds, chunk=3)
    ref = simulate_bit(params, faults, qs, seeds)
    for name, values in ref.channels.items():
        np.testing.assert_array_equal(same.channels[name], values, err_msg=name)
