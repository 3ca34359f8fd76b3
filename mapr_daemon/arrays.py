"""Array type aliases shared by the aircraft side: one spelling of "an array of float64"."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]
"""A numpy array of float64 (signals, feature matrices, estimates)."""

__all__ = ["FloatArray"]
