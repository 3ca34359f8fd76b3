"""Suite-wide: the ``slow`` marker, applied here to the tests that took longest.

The default run (``python3 -m pytest``, and CI) deselects them (pyproject ``addopts``);
``python3 -m pytest -m slow`` runs only them, ``python3 -m pytest -m "slow or not slow"``
everything. Chosen from ``--durations=30`` of one full run (810 s on 2 cores shared with other
work, load average 4.4-5.6): every test whose own call took 10 s or more there. Slow set-ups
(module fixtures shared by several tests) are not listed: marking one test would only move
the cost to the next.
"""

from __future__ import annotations

from pathlib import Path

import pytest

SLOW = frozenset({
    "tests/service/test_kill9.py::test_kill_9_while_writing_loses_no_reported_event",
    "tests/chapter10/test_reader_fuzz.py::test_decode_reads_every_intact_packet_of_a_damaged_file",
    "tests/cli/test_commission_cli.py::test_commission_writes_actuator_record_and_dictionary",
    "tests/catalog/test_episodes_cli.py::test_ack_stores_who_when_note_and_a_second_ack_is_refused",
    "tests/catalog/test_catalog_cli.py::test_trend_table_json_and_plot",
    "tests/catalog/test_episodes_cli.py::test_episodes_lists_one_line_each_and_filters",
    "tests/catalog/test_catalog_cli.py::test_show_and_a_missing_id",
    "tests/service/test_demo_end_to_end.py::test_the_demo_diagnoses_its_bit_and_writes_the_catalog",
    "tests/service/test_end_to_end.py::test_replaying_the_daemons_recording_gives_its_events_and_stamps",
    "tests/catalog/test_catalog_cli.py::test_export_csv_and_json",
    "tests/service/test_end_to_end.py::test_seeded_fault_reaches_the_catalog_and_the_cli",
    "tests/cli/test_codec_cli.py::test_demo_runs_from_any_directory_and_names_a_missing_icd",
    "tests/cli/test_monitor_cli.py::test_monitor_unknown_backend_or_option",
    "tests/service/test_backpressure.py::test_a_stalled_main_loop_drops_reports_and_stays_bounded",
    "tests/service/test_service.py::test_watchdog_goes_on_while_a_backend_is_retried",
    "tests/catalog/test_catalog_cli.py::test_list_table_and_json_agree_with_the_reader",
    "tests/service/test_service.py::test_unknown_key_and_bad_fault_exit_78",
    "tests/catalog/test_catalog_cli.py::test_list_limit_says_there_is_more_and_env_names_the_catalog",
    "tests/catalog/test_catalog_cli.py::test_stats_shows_intervals_and_gaps",
    "tests/cli/test_codec_cli.py::test_encode_then_decode_round_trip_with_faults",
    "tests/catalog/test_catalog_cli.py::test_bad_arguments_are_usage_errors",
    "tests/catalog/test_durability.py::test_kill_9_loses_nothing_reported_and_leaves_a_sound_file",
    "tests/service/test_service.py::test_sighup_reloads_a_valid_config_and_keeps_the_old_on_an_invalid_one",
    "tests/testbed/test_demo_two_ema.py::test_the_demo_diagnoses_and_trends_both_emas",
    "tests/testbed/test_demo_two_ema.py::test_a_table_without_the_elevator_flies_the_aileron_alone",
    # added with it: 52 s at load 15 (a whole commissioning of 5 BITs, in process)
    "tests/reasoner/test_baseline_wear.py::"
    "test_commissioning_holds_each_bit_out_once_for_the_detector_and_the_wear_reading",
})
"""Test ids (without parameters: every parameter set of a listed test is slow)."""


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    for item in items:
        if item.nodeid.split("[", 1)[0] in SLOW:
            item.add_marker(pytest.mark.slow)


@pytest.fixture(scope="session")
def dictionary(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A small fault dictionary (ESR and friction, two pressures, over the envelope), built
    once per session for every test that diagnoses (~30 s)."""
    from mapr_daemon.ema.params import default_actuator_path, load_actuator
    from mapr_daemon.reasoner.diagnosis.dictionary import DictionarySpec
    from mapr_daemon.reasoner.training import dictionary_build

    spec = DictionarySpec(pressures_pa=(0.0, 1600.0), nominal_per_pressure=4,
                          severities=(0.25, 0.5, 0.75, 1.0), kinds=("esr", "friction"),
                          shorts=("A_high",), opens=("A_high",), detection_map_runs=2,
                          healthy_runs=120,
                          calibration_runs=20, envelope=True, ground_share=0.2,
                          threshold_margin=1.5)
    path = tmp_path_factory.mktemp("dictionary") / "dictionary.npz"
    dictionary_build.build(load_actuator(default_actuator_path()), spec).save(path)
    return path
