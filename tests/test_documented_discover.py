"""The README's and the docs' command lines run as written: the discoveries on the Mariner's stand-ins and MARIN's runs.

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


@pytest.mark.parametrize("command", documented.runnable("discover"), ids=str)
def test_runs_as_written(command, project):
    proc = documented.run_as_written(command, project)
    # the verdict with its confidence (or what it measures), the held-out error in metres, the scale
    assert "verdict: " in proc.stdout, proc.stdout
    assert "(confidence " in proc.stdout or "(a measurement, not a probability" in proc.stdout, proc.stdout
    assert "held-out prediction error" in proc.stdout and " m" in proc.stdout
    assert "records studied at full scale" in proc.stdout

