"""How the EMA's parts change with temperature: the laws the plant flies and the healthy model
predicts with, written once.

A healthy actuator on a cold morning is not a faulty one: its capacitor's ESR has doubled, its
MOSFETs and windings conduct better. The reasoner must predict that from the measured
temperature, over the whole operating envelope (-40..+70 C, DO-160's common operating
category), rather than extrapolate a fit made at room temperature. Each law is a factor on the
part's 25 C value:

============================  =====================================  =========================
part                          law                                    source
============================  =====================================  =========================
copper winding resistance     ``1 + 0.00393 (T - 25)``               annealed copper's tempco
                                                                     (IEC 60028: 0.00393/K at
                                                                     20 C)
MOSFET on-resistance          ``1 + 0.006 (T - 25)``                 power-MOSFET datasheets'
                                                                     normalised Ron vs Tj
                                                                     (~1.6x from 25 to 125 C)
electrolytic capacitor ESR    ``exp(-0.02 (T - 25))``                electrolyte conductivity
                                                                     falls as it cools: ESR
                                                                     about doubles from 25 to
                                                                     -10 C and is ~3.7x at -40
                                                                     C, inside the spread of
                                                                     aluminium-electrolytic
                                                                     application notes (2-10x
                                                                     at -40 C by grade)
electrolytic capacitance      ``1 + 0.002 (T - 25)``                 about -13 % at -40 C (the
                                                                     same notes: -10 to -20 %)
============================  =====================================  =========================

The MOSFET and copper laws are linear in ``T``; only ESR's is not, so the healthy model takes
``T`` and :func:`esr_factor` as regressors (:mod:`mapr_daemon.reasoner.diagnosis.healthy_model`).
The winding's
law is applied to the motor's own temperature inside the compiled step
(:data:`mapr_daemon.ema.step.COPPER_ALPHA`, kept beside its kernel: numba's cache tracks only a
kernel's own file).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

REFERENCE_C = 25.0
"""Temperature at which the actuator file's values hold."""
RON_TEMPCO = 0.006
"""MOSFET Ron rise per kelvin."""
ESR_TEMPCO = 0.02
"""Electrolytic ESR: ``exp(-ESR_TEMPCO * (T - 25))``."""
CAP_TEMPCO = 0.002
"""Electrolytic capacitance change per kelvin."""
COPPER_TEMPCO = 0.00393
"""Copper resistance rise per kelvin."""

Temperature = float | npt.NDArray[np.float64]


def ron_factor(t_c: Temperature) -> Temperature:
    """MOSFET on-resistance at ``t_c`` over its 25 C value."""
    return 1.0 + RON_TEMPCO * (t_c - REFERENCE_C)


def esr_factor(t_c: Temperature) -> Temperature:
    """Electrolytic ESR at ``t_c`` over its 25 C value."""
    out: Temperature = np.exp(-ESR_TEMPCO * (np.asarray(t_c) - REFERENCE_C))
    return float(out) if np.ndim(out) == 0 else out


def capacitance_factor(t_c: Temperature) -> Temperature:
    """Electrolytic capacitance at ``t_c`` over its 25 C value."""
    return 1.0 + CAP_TEMPCO * (t_c - REFERENCE_C)


def copper_factor(t_c: Temperature) -> Temperature:
    """Copper resistance at ``t_c`` over its 25 C value."""
    return 1.0 + COPPER_TEMPCO * (t_c - REFERENCE_C)
