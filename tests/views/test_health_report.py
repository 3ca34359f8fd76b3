"""`mapr report`: one self-contained HTML file, checked in a real (headless) browser."""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import pytest

from tests.catalog.health_data import write_health_catalog
from tests.catalog.test_catalog_cli import mapr

BROWSER = shutil.which("chromium") or shutil.which("chromium-browser")


def _report(tmp_path: Path) -> Path:
    path = write_health_catalog(tmp_path / "c.sqlite")
    out = tmp_path / "health.html"
    done = mapr("report", "-o", str(out), "--catalog", str(path))
    assert done.returncode == 0, done.stderr
    return out


def test_report_is_one_self_contained_file(tmp_path: Path) -> None:
    text = _report(tmp_path).read_text(encoding="utf-8")
    # nothing fetched: no script, no external URL; the plots are inline PNGs
    assert "<script" not in text.lower()
    assert not re.search(r"""(src|href)=["']?(https?:|//)""", text)
    pytest.importorskip("matplotlib", reason="the report's plots need matplotlib")
    assert text.count('src="data:image/png;base64,') == 2


def _chromium(*args: str) -> subprocess.CompletedProcess[str]:
    assert BROWSER is not None
    return subprocess.run([BROWSER, "--headless", "--no-sandbox", "--disable-gpu",
                           "--window-size=1200,1600", *args], capture_output=True, text=True,
                          timeout=180, check=False)


@pytest.mark.skipif(BROWSER is None, reason="no chromium binary on PATH (the CI installs "
                                            "Debian's chromium)")
def test_report_renders_in_a_browser(tmp_path: Path) -> None:
    html = _report(tmp_path)
    dom = _chromium("--dump-dom", html.as_uri())
    assert dom.returncode == 0, dom.stderr[-2000:]
    text = re.sub(r"<[^>]+>", " ", dom.stdout)
    text = re.sub(r"\s+", " ", text)
    assert "N101/EMA1" in text and "N101/EMA2" in text
    assert "SoH 0.34 · leading mode esr" in text and "SoH 1.00 · leading mode -" in text
    assert "1 open (dc-link capacitor)" in text and "Bus statistics" in text
    shot = tmp_path / "shot.png"
    done = _chromium(f"--screenshot={shot}", html.as_uri())
    assert done.returncode == 0 and shot.exists(), done.stderr[-2000:]
    mpimg = pytest.importorskip("matplotlib.image", reason="reads the screenshot")
    pixels = mpimg.imread(shot)
    assert pixels.shape[:2] == (1600, 1200)
    assert float(pixels[..., :3].std()) > 0.05  # not a blank page
