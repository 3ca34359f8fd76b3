"""The EKF on healthy *mismatched* units: no BIT ends in a numerical error, and viscous friction
stays in the band the model's integration holds (issue 26, item 9).

Units are drawn off the data sheet by part-to-part tolerance and model form
(``mapr_daemon.testbed.mismatch.fleet``); each flies a sequence of healthy BITs, half at
0 Pa, the rest over the envelope, and the estimator runs on the data sheet with the
reasoner's reference adaptation between BITs (``Reference`` and ``Confirmation``, as
``Reasoner.diagnose`` does), so an adapted reference is carried into the next BIT.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from mapr_daemon.ema.params import default_actuator_path, load_actuator
from mapr_daemon.errors import RecordError
from mapr_daemon.reasoner.ekf import model as em
from mapr_daemon.reasoner.ekf.estimator import Confirmation, ParameterEstimator, Reference
from mapr_daemon.reasoner.training.corpus import Runs, simulate_bit
from mapr_daemon.testbed.mismatch import fleet

UNITS = 8
BITS_PER_UNIT = 6
FLEET_SEED = 26


@pytest.fixture(scope="module")
def flown() -> tuple[Runs, list[int]]:
    sheet = load_actuator(default_actuator_path())
    env = sheet.envelope
    rng = np.random.default_rng(FLEET_SEED + 1)
    specs, pressures, owner = [], [], []
    for u, unit in enumerate(fleet(sheet, UNITS, seed=FLEET_SEED)):
        for b in range(BITS_PER_UNIT):
            q = 0.0 if b % 2 == 0 else float(rng.uniform(0.0, env.max_dynamic_pressure_pa))
            specs.append(unit.spec(seed=1000 + len(specs),
                                   ambient_c=float(rng.uniform(env.ambient_min_c,
                                                               env.ambient_max_c)),
                                   bus_v=float(rng.uniform(sheet.bus.min_v, sheet.bus.max_v))))
            pressures.append(q)
            owner.append(u)
    return simulate_bit(sheet, [], pressures, [], specs=specs), owner


def test_no_healthy_mismatched_bit_ends_in_a_numerical_error(
        flown: tuple[Runs, list[int]]) -> None:
    runs, owner = flown
    sheet = load_actuator(default_actuator_path())
    bound = em.Plant.of(sheet).viscous_max
    failed: list[str] = []
    for u in sorted(set(owner)):
        reference, confirmation = Reference.nominal(sheet), Confirmation(3)
        for i in (i for i, o in enumerate(owner) if o == u):
            channels = {k: v[i] for k, v in runs.channels.items()}
            try:
                est = ParameterEstimator(sheet, reference).run(
                    channels, float(runs.dynamic_pressure_pa[i]))
            except RecordError as error:
                failed.append(f"unit {u} BIT {i}: {error}")
                continue
            assert all(math.isfinite(v) for v in est.value.values())
            assert abs(est.value["viscous"]) <= bound
            confirmed = confirmation.observe(reference.changed(est), est)
            if confirmed:
                reference.adapt(confirmed)
    assert failed == []


def test_a_reference_past_the_stability_bound_is_pulled_back_into_the_domain(
        flown: tuple[Runs, list[int]]) -> None:
    """An adapted reference (or one BIT's innovation) past ``viscous_max`` used to be carried
    by the model to ``g = -1`` (the speed flipping sign each sample); it is projected back."""
    runs, _ = flown
    sheet = load_actuator(default_actuator_path())
    plant = em.Plant.of(sheet)
    reference = Reference.nominal(sheet)
    reference.value["viscous"] = 2.5 * plant.viscous_max
    est = ParameterEstimator(sheet, reference).run(
        {k: v[0] for k, v in runs.channels.items()}, float(runs.dynamic_pressure_pa[0]))
    decay = 1.0 - plant.dt / plant.j_eq * plant.viscous_nom * est.value["viscous"]
    assert 0.0 <= decay <= 2.0


def test_project_clips_only_outside_the_domain() -> None:
    plant = em.Plant.of(load_actuator(default_actuator_path()))
    inside = np.array([0.1, 2.0, -1.7, -0.9, 0.6, 0.6, 0.01, 0.0])
    x = inside.copy()
    em.project(plant, x)
    assert np.array_equal(x, inside)
    x[2], x[3] = 10.0 * plant.viscous_max, -0.5
    em.project(plant, x)
    assert (x[2], x[3]) == (plant.viscous_max, -0.5)
    x[2] = -10.0 * plant.viscous_max
    em.project(plant, x)
    assert x[2] == -plant.viscous_max
