"""The README's and the docs' command lines run as written: the roll-decay runs and discovery on SSPA's decays.

Each command (:func:`documented_commands.runnable`) runs in page order, as a
newcomer would type it, in one folder holding the files the examples name
(stand-ins made by code that shares nothing with ``studies``, or the shared
records) with the shared data folder beside it. It must end with status 0 and
print nothing a user cannot act on (a traceback, a library's warning, Hydra's
launcher lines: :data:`documented_commands.NOISE`).
"""

from __future__ import annotations

import pytest

import documented_commands as documented
from documented_commands import SHARED

pytestmark = [pytest.mark.slow,
              pytest.mark.skipif(not (SHARED / "data").is_dir(), reason="the shared data folder is absent")]


@pytest.fixture(scope="module")
def project(tmp_path_factory):
    return documented.examples_folder(tmp_path_factory.mktemp("newcomer"))


@pytest.mark.parametrize("command", documented.runnable("roll"), ids=str)
def test_runs_as_written(command, project):
    proc = documented.run_as_written(command, project)
    if command.argv[0] == "discover":        # the verdict with its confidence; the page says its scale
        assert "verdict: " in proc.stdout and "(confidence " in proc.stdout, proc.stdout
        page = max((project / "outputs").rglob("report.md"), key=lambda p: p.stat().st_mtime).read_text()
        assert "Records studied at " in page and "roll angles in deg" in page, page[:500]


def test_a_roll_run_on_a_shipped_decay_takes_the_roll_defaults(project):
    """`studies run model=roll data.path=...` with no method: the roll kind's own (nls),
    its coefficients printed with their units."""
    decay = SHARED / "data" / "kvlcc2_roll_decay" / "model_test_21337.csv"
    command = documented.Documented("test", 0, f"studies run model=roll data.path=[{decay}]")
    proc = documented.run_as_written(command, project)
    assert "run 'nls roll" in proc.stdout
    assert "omega0 = " in proc.stdout and "rad/s" in proc.stdout and "b1 = " in proc.stdout

