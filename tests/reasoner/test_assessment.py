"""``assess``: an actuator's BIT history read as SoH, the leading mode and its RUL, on its own
(the daemon's trending tests exercise it only through the catalog)."""

from __future__ import annotations

import dataclasses
import math

import pytest

from mapr_daemon.ema.params import default_actuator_path, load_actuator
from mapr_daemon.reasoner.prognosis import trend
from mapr_daemon.reasoner.prognosis.assessment import EVIDENCE_Z, assess
from mapr_daemon.reasoner.prognosis.prognostic_model import PrognosticModel
from mapr_daemon.reasoner.training.rul_scoring import learn_prior


@pytest.fixture(scope="module")
def model() -> PrognosticModel:
    """ESR and friction trended, each estimate with sd 0.05 of its failure threshold, and the
    aging model's fleet priors (estimators are not needed: the history carries estimates)."""
    params = load_actuator(default_actuator_path())
    return PrognosticModel(params.name, {},
                           {"esr": trend.Noise(0.05), "friction": trend.Noise(0.05)}, {},
                           {k: learn_prior(params, k, 8) for k in ("esr", "friction")})


def esr_path(flight: float, life: float = 200.0) -> float:
    """ESR's degradation on its physical shape (1/ESR falls linearly), 1 at ``life``."""
    return 1.0 / (1.0 - (1.0 - 0.5) * flight / life) - 1.0


def test_no_bit_yet_is_healthy_and_says_so(model: PrognosticModel) -> None:
    h = assess(model, [], [])
    assert (h.soh, h.mode, h.rul) == (1.0, None, None) and h.note == "no BIT yet"


@pytest.mark.parametrize("fault", ["short", "open"])
def test_a_terminal_fault_is_failed_now(model: PrognosticModel, fault: str) -> None:
    h = assess(model, [1.0, 2.0], [{"esr": 0.0}, {"esr": 0.0}], diagnosed=fault)
    assert (h.soh, h.mode, h.rul, h.rul_low, h.rul_high) == (0.0, fault, 0.0, 0.0, 0.0)


def test_healthy_scatter_leads_no_mode_but_every_kind_states_its_reading(
        model: PrognosticModel) -> None:
    flights = [float(n) for n in range(1, 9)]
    wear = [{"esr": 0.02 * (-1) ** n, "friction": -0.01 * (-1) ** n} for n in range(1, 9)]
    h = assess(model, flights, wear)
    assert h.soh == 1.0 and h.mode is None and h.rul is None
    assert "within its healthy scatter" in (h.note or "")
    assert set(h.modes) == {"esr", "friction"}
    assert all(not row["evidenced"] and abs(row["z"]) < EVIDENCE_Z for row in h.modes.values())


def test_clear_wear_on_two_flights_leads_but_has_no_trend_yet(model: PrognosticModel) -> None:
    h = assess(model, [1.0, 1.0, 2.0], [{"esr": 0.4}, {"esr": 0.42}, {"esr": 0.45}])
    assert h.mode == "esr" and h.rul is None and "fewer than three flights" in (h.note or "")
    assert h.soh == pytest.approx(1.0 - h.modes["esr"]["h"], abs=1e-3)
    assert 0.5 < h.soh < 0.65


def test_a_wearing_part_gets_soh_and_a_rul_interval_around_its_end_of_life(
        model: PrognosticModel) -> None:
    """ESR aging to its threshold at flight 200 (a life the fleet prior knows), read every 10
    flights up to flight 120: SoH is what is left of the way to the threshold (read from the
    last three BITs, equally weighted here), and the 90 % interval holds the true 80."""
    flights = [float(n) for n in range(10, 121, 10)]
    wear = [{"esr": esr_path(n) + 0.01 * (-1) ** i, "friction": 0.0}
            for i, n in enumerate(flights)]
    h = assess(model, flights, wear)
    assert h.mode == "esr" and h.note is None
    last_three = sum(w["esr"] for w in wear[-3:]) / 3
    assert h.soh == pytest.approx(1.0 - last_three, abs=1e-3)
    assert h.rul is not None and h.rul_low is not None and h.rul_high is not None
    assert h.rul_low <= 80.0 <= h.rul_high and h.rul_low < h.rul < h.rul_high
    assert h.modes["friction"]["evidenced"] is False


def test_the_classifiers_named_kind_leads_over_a_shorter_rul(model: PrognosticModel) -> None:
    flights = [float(n) for n in range(5, 61, 5)]
    wear = [{"esr": esr_path(n), "friction": 0.5 * n / 60.0} for n in flights]
    assert assess(model, flights, wear, diagnosed="friction").mode == "friction"
    assert assess(model, flights, wear, diagnosed="esr").mode == "esr"


def test_past_the_threshold_is_zero_health_and_zero_rul(model: PrognosticModel) -> None:
    h = assess(model, [1.0, 2.0, 3.0, 4.0], [{"esr": v} for v in (0.9, 1.05, 1.1, 1.2)])
    assert (h.mode, h.soh, h.rul, h.rul_low, h.rul_high) == ("esr", 0.0, 0.0, 0.0, 0.0)


def test_missing_estimates_are_skipped_not_read_as_zero(model: PrognosticModel) -> None:
    flights = [float(n) for n in range(5, 61, 5)]
    wear = [{"esr": esr_path(n)} if i % 2 else {"esr": math.nan} for i, n in enumerate(flights)]
    h = assess(model, flights, wear)
    last_three_read = sum(esr_path(n) for n in (40.0, 50.0, 60.0)) / 3
    assert h.mode == "esr" and h.soh == pytest.approx(1.0 - last_three_read, abs=1e-3)
    assert "friction" not in h.modes


def _fast_friction(last: int, life: float = 60.0) -> tuple[list[float], list[dict[str, float]]]:
    """A friction unit living ``life`` flights (the fleet prior assumes about 200), read every
    three flights up to flight ``last``."""
    flights = [float(n) for n in range(1, last + 1, 3)]
    wear = [{"friction": ((n - 1.0) / life) ** 1.5 + 0.01 * (-1) ** i, "esr": 0.0}
            for i, n in enumerate(flights)]
    return flights, wear


def test_an_early_rul_that_is_only_the_assumed_life_is_withheld_with_the_reason(
        model: PrognosticModel) -> None:
    """Nobody stated the life: while the unit's readings have not narrowed the assumed life,
    the headline says so instead of a figure (which would be the prior's: 1.4x the truth
    here); the friction row keeps its figures and how much of the spread is left."""
    flights, wear = _fast_friction(16)
    h = assess(model.with_lives(), flights, wear)
    row = h.modes["friction"]
    assert h.mode == "friction" and h.rul is None and h.rul_low is None
    assert h.note is not None and "has not yet narrowed the part's life" in h.note and \
        "expected_life_flights" in h.note
    assert row["rul"] is not None and row["prior_share"] > trend.LEANS


def test_the_rul_is_stated_once_the_readings_place_the_life(model: PrognosticModel) -> None:
    flights, wear = _fast_friction(24)
    h = assess(model.with_lives(), flights, wear)
    assert h.rul is not None and h.note is None
    assert h.modes["friction"]["prior_share"] <= trend.LEANS
    assert h.rul_low is not None and h.rul_high is not None
    assert h.rul_low <= 60.0 - 23.0 <= h.rul_high


def test_a_stated_life_is_never_withheld(model: PrognosticModel) -> None:
    """The same early readings with the life stated: the RUL rests on the user's figure, as
    asked, and is given (it holds the truth)."""
    flights, wear = _fast_friction(16)
    h = assess(model.with_lives({"friction": 60.0}), flights, wear)
    assert h.rul is not None and h.rul_low is not None and h.rul_high is not None
    assert h.rul_low <= 60.0 - 15.0 <= h.rul_high


def test_a_trend_that_never_reaches_the_threshold_says_so_with_or_without_a_stated_life(
        model: PrognosticModel) -> None:
    """A kind the classifier names whose readings all sit at the estimator's floor: no
    degradation to trend, every draw beyond the horizon. That is not the assumed life: the
    note says the trend does not reach the threshold, whether or not the life was stated."""
    floored = dataclasses.replace(model, noise={
        **model.noise, "esr": trend.Noise(0.05, floor=0.0, detection=0.1)})
    flights = [float(n) for n in range(1, 11)]
    wear = [{"esr": 0.0, "friction": 0.0} for _ in flights]
    for lives in (None, {"esr": 200.0}):
        h = assess(floored.with_lives(lives), flights, wear, diagnosed="esr")
        assert h.mode == "esr" and h.rul == math.inf, lives
        assert h.note is not None and "does not reach the failure threshold" in h.note, lives
