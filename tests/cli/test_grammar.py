"""One CLI grammar (docs/cli.md, "One grammar"), checked on every subcommand's parser."""

from __future__ import annotations

import argparse
import contextlib
import io
from collections.abc import Iterator

import pytest

from mapr_daemon.cli import exitcodes
from mapr_daemon.cli.main import build_parser, main
from mapr_daemon.cli.notes import SHOWN_ALIKE, Notes
from mapr_daemon.cli.validate import parse_option


def parsers() -> Iterator[tuple[str, argparse.ArgumentParser]]:
    """Every (sub)subcommand's parser, by its prog (``mapr catalog list``)."""
    todo = [build_parser()]
    while todo:
        parser = todo.pop()
        yield parser.prog, parser
        for action in parser._actions:
            if isinstance(action, argparse._SubParsersAction):
                todo.extend(action.choices.values())


def mapr(*argv: str) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    code = 0
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = main(list(argv))
        except SystemExit as done:
            code = int(done.code or 0)
    return code, out.getvalue(), err.getvalue()


def test_dash_o_means_output_and_dash_capital_o_a_backend_option_everywhere() -> None:
    outputs = options = 0
    for prog, parser in parsers():
        for action in parser._actions:
            if "-o" in action.option_strings and action.help == argparse.SUPPRESS:
                # the old backend-option spelling, hidden, where it used to be the only -o
                assert prog in ("mapr monitor", "mapr record") and action.dest == "option"
            elif "-o" in action.option_strings:
                assert action.dest == "output", f"{prog}: -o is {action.dest}"
                assert action.option_strings == ["-o", "--output"], prog
                outputs += 1
            if action.dest == "option" and action.help != argparse.SUPPRESS:
                assert action.option_strings == ["-O", "--option"], prog
                assert action.type is parse_option, prog
                options += 1
            if "--output" in action.option_strings:
                assert "-o" in action.option_strings, f"{prog}: --output without -o"
    assert outputs >= 6 and options == 3


def test_every_command_takes_quiet() -> None:
    for prog, parser in parsers():
        if parser.add_help:
            assert any(a.option_strings == ["-q", "--quiet"] for a in parser._actions), prog


def test_decode_and_monitor_share_their_filter_flags() -> None:
    found = {prog: {s for a in p._actions for s in a.option_strings}
             for prog, p in parsers() if prog in ("mapr decode", "mapr monitor")}
    filters = {"--rt", "--sa", "--tr", "--format", "--errors", "--error", "--from", "--to"}
    assert filters <= found["mapr decode"] and filters <= found["mapr monitor"]


@pytest.mark.parametrize("argv", [
    ["monitor", "-O", "out.yaml"], ["record", "x.c10", "-O", "novalue"],
    ["icd", "discover", "x.c10", "-O", "=1"], ["monitor", "-o", "out.yaml"],
])
def test_a_backend_option_without_equals_is_refused(argv: list[str]) -> None:
    code, out, err = mapr(*argv)
    assert code == exitcodes.USAGE and out == ""
    assert err.startswith(f"mapr {' '.join(w for w in argv[:2] if w.isalpha())}: error:")


def test_old_dash_o_backend_option_still_works_with_a_note() -> None:
    code, out, err = mapr("monitor", "--backend", "loopback", "-o", "frames=2",
                          "-o", "bit_level=false", "--count", "1", "--json")
    assert code == exitcodes.OK and out.count("\n") == 1
    assert "mapr monitor: note: -o KEY=VALUE is deprecated, write -O frames=2" in err


@pytest.mark.parametrize("argv", [
    ["decode", "--bogus", "x.c10"], ["monitor", "--bogus"], ["catalog", "list", "--bogus"],
])
def test_an_unknown_flag_is_named_by_its_subcommand(argv: list[str]) -> None:
    code, _, err = mapr(*argv)
    sub = " ".join(w for w in argv if not w.startswith("-") and "." not in w)
    assert code == exitcodes.USAGE
    assert err.startswith(f"mapr {sub}: error: unrecognized arguments: --bogus")


def test_monitor_takes_lists_as_decode_does() -> None:
    code, out, _ = mapr("monitor", "--backend", "loopback", "-O", "bit_level=false",
                        "--rt", "5,7", "--count", "3", "--json")
    assert code == exitcodes.OK and out.count("\n") == 3


def test_stats_json_with_text_is_refused() -> None:
    code, _, err = mapr("decode", "--stats", "json", "--text", "missing.c10")
    assert code == exitcodes.USAGE and "--stats json and --text" in err


def test_warnings_alike_are_collapsed_and_quiet_silences_them() -> None:
    out = io.StringIO()
    notes = Notes("decode", stream=out)
    for offset in range(SHOWN_ALIKE + 12):
        notes.warn(f"f.c10: packet at {offset * 4096}: bad checksum")
    notes.warn("f.c10: channel 3 has no time packet")
    notes.finish()
    lines = out.getvalue().splitlines()
    assert len(lines) == SHOWN_ALIKE + 2
    assert all(line.startswith("mapr decode: f.c10: ") for line in lines)
    assert lines[-1].endswith("bad checksum (and 12 more like it)")

    quiet = io.StringIO()
    silent = Notes("decode", quiet=True, stream=quiet)
    silent.warn("f.c10: packet at 0: bad checksum")
    silent.finish()
    assert quiet.getvalue() == ""
