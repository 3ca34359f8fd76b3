"""`mapr report`: one self-contained HTML file for a maintenance chief, checked as a person
would: its order (most urgent first), its words, plots from one BIT to thousands without a
warning, and screenshots in a real (headless) browser at one flight and at 220 flights."""

from __future__ import annotations

import html
import re
import shutil
import subprocess
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from mapr_daemon.catalog import CatalogReader
from mapr_daemon.views.html_report import build
from tests.catalog.conftest import T0
from tests.catalog.health_data import write_health_catalog
from tests.catalog.test_catalog_cli import mapr
from tests.views.report_data import (
    FLEET_FLIGHTS,
    ONE_FLIGHT_BITS,
    URGENCY,
    write_fleet_catalog,
    write_one_flight_catalog,
)

BROWSER = shutil.which("chromium") or shutil.which("chromium-browser")
NO_BROWSER = "no chromium binary on PATH (.ci/run installs Debian's chromium)"
WIDTH, HEIGHT = 1200, 3000
"""The screenshot: tall enough for the overview, how to read it and the first actuator."""


def _report(tmp_path: Path, write: Callable[[Path], Path] = write_health_catalog) -> Path:
    """``mapr report`` on the catalog ``write`` makes; it must print nothing but its one
    line (no matplotlib warning, no traceback)."""
    path = write(tmp_path / "c.sqlite")
    out = tmp_path / "health.html"
    done = mapr("report", "-o", str(out), "--catalog", str(path))
    assert done.returncode == 0, done.stderr
    assert done.stderr == f"report written to {out}\n"
    return out


def _build(path: Path) -> str:
    """The report made in this process with every warning an error."""
    with CatalogReader(path) as reader, warnings.catch_warnings():
        warnings.simplefilter("error")
        return build(reader, T0)


def _text(markup: str) -> str:
    """The words as read: inline tags dropped, block tags (cells, paragraphs) a space."""
    inline = re.sub(r"</?(b|a|span)\b[^>]*>", "", markup)
    return re.sub(r"\s+", " ", html.unescape(re.sub(r"<[^>]+>", " ", inline)))


def test_report_is_one_self_contained_file(tmp_path: Path) -> None:
    text = _report(tmp_path).read_text(encoding="utf-8")
    # nothing fetched: no script, no external URL; the plots are inline PNGs
    assert "<script" not in text.lower()
    assert not re.search(r"""(src|href)=["']?(https?:|//)""", text)
    pytest.importorskip("matplotlib", reason="the report's plots need matplotlib")
    assert text.count('src="data:image/png;base64,') == 2


def test_the_overview_puts_the_most_urgent_first(tmp_path: Path) -> None:
    page = _build(write_fleet_catalog(tmp_path / "fleet.sqlite"))
    sections = re.findall(r'<section id="([^"]+)"><h2>(\d+)\. ', page)
    assert [name for name, _ in sections] == list(URGENCY)
    assert [int(rank) for _, rank in sections] == list(range(1, len(URGENCY) + 1))
    overview = page[page.index("Fleet overview"):page.index("How to read this")]
    tails, actuators = overview.split("<h3>Actuators</h3>")
    # each tail by its most urgent actuator: N104 (RUL 0), N103 (4), N101 (50), N102 (82)
    assert re.findall(r"<tr><td>(N10\d)</td>", tails) == ["N104", "N103", "N101", "N102"]
    assert re.findall(r'<a href="#([^"]+)">', actuators) == list(URGENCY)
    text = _text(actuators)
    for row in ("1 N104/EMA2 replace now 0.00 short 0 flights 1 open (inverter)",
                "2 N103/EMA1 replace within 4 flights 0.04 esr 5.0 (4.2-6.7) flights",
                "5 N102/EMA1 watch 0.90 capacitance none: the trend does not reach",
                "6 N101/EMA1 nothing due 1.00 - none: no part wears measurably"):
        assert row in text
    assert "the low end of the RUL's 90 % interval (soonest first; no RUL last)" in overview


def test_it_says_how_to_read_it_and_which_rul_to_believe(tmp_path: Path) -> None:
    page = _build(write_fleet_catalog(tmp_path / "fleet.sqlite"))
    text = _text(page)
    read = text[text.index("How to read this"):text.index("1. N104/EMA2")]
    assert "Plan the replacement on the low end." in read
    assert "nine times out of ten the threshold is reached between 10 and 21 flights" in read
    assert "esr DC-link capacitor ESR rises to 2x nominal" in read
    assert "capacitance DC-link capacitance falls to 0.7x nominal" in read
    # the headline RUL in words, with the leading mode's threshold
    esr = text[text.index("2. N103/EMA1"):text.index("3. N101/EMA2")]
    assert ("esr (DC-link capacitor ESR: replace when it rises to 2x nominal)" in esr)
    assert ("RUL 5.0 (4.2-6.7) flights (12 (10-17) h): nine times out of ten the replace-at "
            "threshold is reached between 4.2 and 6.7 flights after flight 220; plan on 4.2."
            in esr)
    assert "Believe the headline RUL, esr's: 5.0 (4.2-6.7) flights." in esr
    assert "capacitance" in esr and "what-if: not wearing measurably; not a forecast" in esr
    # the case: per-kind RULs next to no headline RUL say what they are
    healthy = text[text.index("6. N101/EMA1"):text.index("7. N103/EMA2")]
    assert "No headline RUL (no part wears measurably" in healthy
    assert "not forecasts: do not plan on them" in healthy
    for figure in ("168 (92-353) flights", "191 (105-401) flights", "88 (48-185) flights"):
        assert f"{figure} what-if: not wearing measurably" in healthy
    terminal = text[text.index("1. N104/EMA2"):text.index("2. N103/EMA1")]
    assert "RUL 0: the part has failed; replace before the next flight." in terminal


def _axes(records: Any, hours: bool = False) -> tuple[Any, Any]:
    from mapr_daemon.views.plot import figure

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        fig = figure(records, "N101/EMA1", hours=hours)
        fig.canvas.draw()   # ticks and layout as saved, warnings included
    return fig.axes[0], fig.axes[1]


def _visible_ticks(ax: Any) -> list[float]:
    low, high = ax.get_xlim()
    return [t for t in ax.get_xticks() if low <= t <= high]


def test_plots_read_right_from_one_bit_to_thousands(tmp_path: Path) -> None:
    pytest.importorskip("matplotlib", reason="the report's plots need matplotlib")
    from mapr_daemon.views.plot import positions

    with CatalogReader(write_one_flight_catalog(tmp_path / "one.sqlite")) as reader:
        one = reader.bits("EMA1", "N101")
    with CatalogReader(write_fleet_catalog(tmp_path / "fleet.sqlite")) as reader:
        long, terminal = reader.bits("EMA1", "N103"), reader.bits("EMA2", "N104")
    assert len(one) == ONE_FLIGHT_BITS and len(long) == 2 * FLEET_FLIGHTS
    # the BITs of one flight side by side inside its slot, in time order
    xs = [x for x, _ in positions(one)]
    assert xs == sorted(xs) and len(set(xs)) == ONE_FLIGHT_BITS
    assert 0.5 < xs[0] < xs[-1] < 1.5
    # two runs each counted as flight 1 (the demo's) share the slot, not overlap
    twice = [x for x, _ in positions([*one[:10], *long[:4], *one[10:20]])]
    assert twice == sorted(twice) and len(set(twice)) == 24
    assert sum(0.5 < x < 1.5 for x in twice) == 22   # 10 + 2 + 10 BITs of flight 1
    for records in (one[:1], one):   # one BIT, then 34 of one flight
        soh, rul = _axes(records)
        assert soh.get_xlim() == pytest.approx((0.5, 1.5))   # not 0.96..1.04
        assert _visible_ticks(soh) == [1.0]
        assert rul.get_ylim() == pytest.approx((0.0, 1.0))   # RUL 0: not -0.04..0.04
        assert "now: 0, at the replace-at threshold" in [
            t.get_text() for t in rul.get_legend().get_texts()]
    soh, rul = _axes(one)
    assert "34 BITs" in [t.get_text() for t in soh.texts]
    for records, hours in ((long, False), (long, True), (terminal, False)):
        soh, rul = _axes(records, hours)
        low, high = soh.get_xlim()
        x = [p[0] for p in positions(records, hours)]
        assert low < min(x) and max(x) < high
        if not hours:
            assert all(float(t).is_integer() for t in _visible_ticks(soh))
        assert rul.get_ylim()[0] == 0.0 and rul.get_ylim()[1] >= 1.0
    assert rul.get_ylim() == pytest.approx((0.0, 1.0))   # the terminal fault's RUL 0
    soh, rul = _axes(long)
    assert rul.get_ylim()[1] > 400   # the young trend's wide interval, all of it shown
    assert "now: 5.0 (4.2-6.7) flights" in [t.get_text() for t in rul.get_legend().get_texts()]


def _chromium(*args: str, height: int = HEIGHT) -> subprocess.CompletedProcess[str]:
    assert BROWSER is not None
    return subprocess.run([BROWSER, "--headless", "--no-sandbox", "--disable-gpu",
                           "--hide-scrollbars", f"--window-size={WIDTH},{height}", *args],
                          capture_output=True, text=True, timeout=180, check=False)


def _share_near(pixels: Any, rgb: tuple[int, int, int]) -> float:
    """Share of the screenshot's pixels within a few levels of colour ``rgb``."""
    import numpy as np

    target = np.array(rgb, dtype=np.float64) / 255.0
    near = np.all(np.abs(pixels[..., :3] - target) < 0.06, axis=-1)
    return float(near.mean())


CASES = {
    "one flight": (write_one_flight_catalog,
                   ["N101/EMA1 replace now 0.00 esr", "N101/EMA3 watch 0.54 friction",
                    "BITs on fewer than three flights: no trend yet",
                    "RUL 0: at the replace-at threshold now"]),
    f"{FLEET_FLIGHTS} flights": (write_fleet_catalog,
                                 ["N104/EMA2 replace now", "N103/EMA1 replace within 4 flights",
                                  "No headline RUL", "Believe the headline RUL"]),
}


@pytest.mark.skipif(BROWSER is None, reason=NO_BROWSER)
@pytest.mark.parametrize("case", list(CASES))
def test_report_renders_in_a_browser(tmp_path: Path, case: str) -> None:
    write, expected = CASES[case]
    page = _report(tmp_path, write)
    dom = _chromium("--dump-dom", page.as_uri())
    assert dom.returncode == 0, dom.stderr[-2000:]
    text = _text(dom.stdout)
    for words in ("Fleet overview: what needs attention first", "How to read this",
                  "Plan the replacement on the low end.", "Bus statistics", *expected):
        assert words in text
    assert text.index("Fleet overview") < text.index("How to read this") < text.index("1. ")
    shot = tmp_path / f"report-{case.replace(' ', '-')}.png"
    done = _chromium(f"--screenshot={shot}", page.as_uri())
    assert done.returncode == 0 and shot.exists(), done.stderr[-2000:]
    mpimg = pytest.importorskip("matplotlib.image", reason="reads the screenshot")
    pixels = mpimg.imread(shot)
    assert pixels.shape[:2] == (HEIGHT, WIDTH)
    assert float(pixels[..., :3].std()) > 0.05   # not a blank page
    assert float(pixels[-HEIGHT // 4:, :, :3].std()) > 0.05   # the page runs that long
    # the first actuator's plot decoded and drawn: its SoH line and the threshold's red
    assert _share_near(pixels, (31, 119, 180)) > 1e-4   # tab:blue
    assert _share_near(pixels, (214, 39, 40)) > 1e-4    # tab:red
    # the overview's badges: "replace now" on red
    assert _share_near(pixels, (0xF8, 0xD0, 0xD0)) > 1e-4


def test_a_withheld_headline_rul_is_not_shown_as_the_headline_in_the_per_kind_table(
        tmp_path: Path) -> None:
    """The headline RUL withheld (the trend leans on a life nobody stated): the leading kind's
    own row keeps its figure, but must not call it the headline RUL, says how much of the
    assumed life's spread it still spans, and the page says not to plan on it."""
    from mapr_daemon.catalog import BitOutcome, CatalogWriter
    from mapr_daemon.catalog.model import Flight
    from mapr_daemon.findings import Health

    note = ("the friction trend has not yet narrowed the part's life (its interval spans 48 % "
            "of it): the figure would be the data sheet's assumed life of about 200 flights, "
            "not this unit's (state assets[].expected_life_flights for the fleet, or wait for "
            "more BITs)")
    modes = {"friction": {"h": 0.21, "z": 7.5, "evidenced": True, "rul": 160.0, "low": 70.0,
                          "high": 420.0, "prior_share": 0.48},
             "esr": {"h": 0.01, "z": 0.3, "evidenced": False, "rul": None, "low": None,
                     "high": None}}
    path = tmp_path / "c.sqlite"
    with CatalogWriter(path) as writer:
        writer.open_session(backend="replay", config_hash="x", started_ns=T0)
        writer.add_bits([BitOutcome("EMA1", T0 + k * 10**12, tail="N101", flight=k,
                                    flight_hours=1.0, wear={"friction": 0.21, "esr": 0.0},
                                    health=Health(0.79, "friction", note=note, modes=modes))
                         for k in (1, 2, 3)],
                        [Flight("N101", k, T0 + k * 10**12, T0 + k * 10**12 + 10**9, 1.0,
                                "declared") for k in (1, 2, 3)])
    text = _text(_build(path))
    section = text[text.index("1. N101/EMA1"):]
    assert f"No RUL: {note}." in section
    assert "the headline RUL (leading mode)" not in section
    assert "160 (70-420) flights withheld from the headline" in section
    assert "48 %" in section.split("160 (70-420) flights", 1)[1]
    assert f"No headline RUL ({note}). The per-kind RULs below are what-ifs" in section
