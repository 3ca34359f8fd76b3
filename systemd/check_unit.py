"""Check mapr.service with systemd's own tools and print the figures.

    python3 systemd/check_unit.py

Runs ``systemd-analyze verify`` (the unit parses, every directive is known) and
``systemd-analyze security --offline=true`` (the hardening score; target <= 2.0, lower is
safer) on the unit file in this directory, without installing it. ``verify`` also checks
that ExecStart's ``mapr`` exists on systemd's search path; on a machine where MAPR is not
installed system-wide that one complaint is reported and set apart. Stdlib only.
"""

from __future__ import annotations

import dataclasses
import re
import shutil
import subprocess
import sys
from pathlib import Path

UNIT = Path(__file__).with_name("mapr.service")
SYSTEMD_PATH = "/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin"
"""Where systemd looks up a bare ExecStart= command."""
TARGET_EXPOSURE = 2.0


@dataclasses.dataclass
class Verdict:
    version: str
    verify_problems: list[str]
    """Lines of ``verify`` that are real problems with the unit."""
    verify_notes: list[str]
    """The missing-``mapr`` complaint, when MAPR is not installed system-wide."""
    exposure: float | None
    """None when this systemd has no ``security --offline``."""


def systemd_version() -> str:
    out = subprocess.run(["systemd-analyze", "--version"], capture_output=True, text=True,
                         check=False).stdout
    return out.split("\n", 1)[0].strip()


def check(unit: Path = UNIT) -> Verdict:
    """Run both checks; raises FileNotFoundError when systemd-analyze is absent."""
    if shutil.which("systemd-analyze") is None:
        raise FileNotFoundError("systemd-analyze is not installed")
    version = systemd_version()
    done = subprocess.run(["systemd-analyze", "verify", "--man=no", str(unit)],
                          capture_output=True, text=True, check=False, timeout=60)
    lines = [x for x in (done.stdout + done.stderr).splitlines() if x.strip()]
    installed = shutil.which("mapr", path=SYSTEMD_PATH) is not None
    notes = [x for x in lines if not installed and "Command mapr is not executable" in x]
    problems = [x for x in lines if x not in notes]
    if done.returncode != 0 and not problems and not notes:
        problems.append(f"verify exited {done.returncode}")
    exposure = None
    sec = subprocess.run(["systemd-analyze", "security", "--offline=true", "--no-pager",
                          str(unit)], capture_output=True, text=True, check=False, timeout=60)
    found = re.search(r"Overall exposure level for \S+: (\d+(?:\.\d+)?)", sec.stdout)
    if found:
        exposure = float(found.group(1))
    return Verdict(version, problems, notes, exposure)


def main() -> int:
    try:
        verdict = check()
    except FileNotFoundError as error:
        print(f"skipped: {error} (apt-get install systemd)")
        return 0
    print(f"{verdict.version}")
    print(f"systemd-analyze verify {UNIT.name}: "
          + ("clean" if not verdict.verify_problems else "PROBLEMS"))
    for line in verdict.verify_problems:
        print(f"  problem: {line}")
    for line in verdict.verify_notes:
        print(f"  note (mapr not installed system-wide here): {line}")
    if verdict.exposure is None:
        print("systemd-analyze security: this systemd has no --offline (needs v250+)")
    else:
        ok = "meets" if verdict.exposure <= TARGET_EXPOSURE else "MISSES"
        print(f"systemd-analyze security {UNIT.name}: exposure {verdict.exposure:.1f} "
              f"({ok} the target <= {TARGET_EXPOSURE})")
    bad = verdict.verify_problems or (verdict.exposure or 0.0) > TARGET_EXPOSURE
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
