"""The paper's fault curves (III.C-D): N, the good-times matrix G, the final values V.

For one fault type, take the matrix M of every fault-seeded run, ordered by increasing
degradation, and the nominal matrix ``M_nom``:

* ``N = sqrt((M - M_nom)**2)`` element by element (:func:`distance`);
* ``G`` starts as ones and an element drops to 0 as soon as its N decreases from one
  degradation level to the next (:func:`good_times`) — typically sparse;
* ``V`` has one row per 1 in G: that cell's N over the degradation levels, plus a reference
  value ``1000*row + column`` (1-based, as the paper counts) (:func:`final_values`);
* the chosen curve is the row with the largest value at the highest degradation
  (:func:`chosen_curve`). We also offer the same choice on N scaled by the nominal spread
  (``scale=``), since raw N compares amperes with degrees.

Plus the paper's two side tools: the PCA-weighted *new values* (:func:`pca_new_values`) and
the multivariate gradient descent with variable stride length (:func:`variable_stride_descent`),
whose stopping condition is the step size, not the gradient norm.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np
import numpy.typing as npt

from mapr_daemon.arrays import FloatArray
from mapr_daemon.errors import ConfigError


def distance(m: FloatArray, m_nom: FloatArray) -> FloatArray:
    """The paper's N: the element-wise ``sqrt((M - M_nom)**2)``."""
    out: FloatArray = np.sqrt((m - m_nom) ** 2)
    return out


def good_times(n_levels: FloatArray) -> npt.NDArray[np.bool_]:
    """G from N matrices ordered by increasing degradation, shape ``(levels, rows, cols)``.

    An element stays 1 only while its N stays the same or grows at every next level.
    """
    if n_levels.ndim != 3 or n_levels.shape[0] < 1:
        raise ConfigError("need N matrices stacked (levels, rows, cols)", field="N")
    g: npt.NDArray[np.bool_] = np.all(np.diff(n_levels, axis=0) >= 0.0, axis=0)
    return g


def reference_id(row: int, col: int) -> int:
    """The paper's reference value of a cell, 0-based indices in: ``1000*(row+1) + (col+1)``."""
    return 1000 * (row + 1) + (col + 1)


def final_values(n_levels: FloatArray, g: npt.NDArray[np.bool_]) -> FloatArray:
    """V: one row per 1 in G, the N values over the levels then the reference id."""
    rows, cols = np.nonzero(g)
    v = np.empty((rows.size, n_levels.shape[0] + 1))
    v[:, :-1] = n_levels[:, rows, cols].T
    v[:, -1] = 1000 * (rows + 1) + (cols + 1)
    return v


@dataclasses.dataclass(frozen=True)
class Curve:
    """A chosen fault curve: the cell, its reference id and N over the levels."""

    row: int
    col: int
    reference: int
    values: FloatArray


def chosen_curve(v: FloatArray, scale: FloatArray | None = None) -> Curve:
    """The V row with the largest value at the highest degradation (paper III.D).

    ``scale`` (rows, cols) divides each row first (e.g. the nominal spread of that cell), which
    compares cells in units of noise rather than in their own physical units.
    """
    if v.shape[0] == 0:
        raise ConfigError("the good-times matrix has no ones: no monotone curve", field="G")
    ref = v[:, -1].astype(np.int64)
    rows, cols = ref // 1000 - 1, ref % 1000 - 1
    last = v[:, -2].copy()
    if scale is not None:
        last = last / scale[rows, cols]
    k = int(np.argmax(last))
    return Curve(int(rows[k]), int(cols[k]), int(ref[k]), v[k, :-1].copy())


def invert_curve(curve_x: FloatArray, curve_y: FloatArray, y: float) -> float:
    """The x at which a non-decreasing curve reaches ``y`` (linear, clamped to its ends)."""
    ys = np.maximum.accumulate(curve_y)
    if y <= ys[0]:
        return float(curve_x[0])
    if y >= ys[-1]:
        return float(curve_x[-1])
    return float(np.interp(y, ys, curve_x))


def pca_new_values(m_levels: FloatArray, m_nom: FloatArray,
                   cols: npt.NDArray[np.int64]) -> tuple[FloatArray, FloatArray]:
    """The paper's PCA-weighted new values NV_1..NV_32 for every degradation level.

    The difference between the first degradation level and nominal, restricted to ``cols``
    (the paper: DC, f, B and P of each signal, 16 columns), is a (windows x 16) matrix; its first
    principal component gives the coefficients ``a``; ``NV[level, w] = sum_k a_k M[level, w, k]``.
    Returns ``(a, NV)`` with NV of shape ``(levels, windows)``.
    """
    d = (m_levels[0] - m_nom)[:, cols]
    centred = d - d.mean(axis=0)
    _, _, vt = np.linalg.svd(centred, full_matrices=False)
    a: FloatArray = vt[0]
    if a[np.argmax(np.abs(a))] < 0:  # fix the sign so the curve reads the same way each build
        a = -a
    nv: FloatArray = m_levels[:, :, cols] @ a
    return a, nv


@dataclasses.dataclass(frozen=True)
class DescentResult:
    """Where the variable-stride descent stopped."""

    x: FloatArray
    value: float
    evaluations: int
    iterations: int


def variable_stride_descent(f: Callable[[FloatArray], float], x0: FloatArray, step: float,
                            min_step: float, lower: FloatArray | None = None,
                            upper: FloatArray | None = None,
                            max_iterations: int = 200) -> DescentResult:
    """The paper's Figure 12: gradient descent whose stride grows on success, halves back on
    failure, and which stops when the stride falls below ``min_step``.

    The gradient is a central difference; the direction is the unit steepest descent. After a
    better point the stride doubles in the same direction; after a worse one the walker steps
    half a stride back and keeps the best of the last two positions.
    """
    lo = np.full_like(x0, -np.inf) if lower is None else lower
    hi = np.full_like(x0, np.inf) if upper is None else upper
    x = np.clip(np.asarray(x0, dtype=np.float64), lo, hi)
    evals = 0

    def fx(p: FloatArray) -> float:
        nonlocal evals
        evals += 1
        return float(f(np.clip(p, lo, hi)))

    best = fx(x)
    it = 0
    h = max(min_step, 1e-9)
    while step >= min_step and it < max_iterations:
        it += 1
        grad = np.empty_like(x)
        for i in range(x.size):
            e = np.zeros_like(x)
            e[i] = h
            grad[i] = (fx(x + e) - fx(x - e)) / (2 * h)
        norm = float(np.linalg.norm(grad))
        if norm == 0.0:
            break
        direction = -grad / norm
        trial = np.clip(x + step * direction, lo, hi)
        value = fx(trial)
        if value < best:
            x, best = trial, value
            step *= 2.0  # better: a longer stride the same way
            trial = np.clip(x + step * direction, lo, hi)
            value = fx(trial)
            if value < best:
                x, best = trial, value
            else:
                step *= 0.25
        else:
            step *= 0.5  # worse: half a step back, compare with the previous two
            back = np.clip(x + step * direction, lo, hi)
            value = fx(back)
            if value < best:
                x, best = back, value
    return DescentResult(x, best, evals, it)
