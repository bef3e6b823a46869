"""A newcomer follows the README's five-minute tour and every step does what it says.

The commands are read from the README itself (between ``<!-- tour -->`` and
``<!-- /tour -->``), run in an empty folder with the shared data folder
where the README says it is, and each step's output is checked: the run and
where it went, the discovery's page, the sweep's child runs, the report, and
the UI answering on its address.
"""

from __future__ import annotations

import re
import shlex
import socket
import subprocess
import sys
import time
import urllib.request

import pytest
from conftest import REPO, SHARED_DATA, mlflow_runs, run_studies, sweep_parents
from documented_commands import NOISE


def _quiet(proc) -> None:
    """Nothing on the console that a user cannot act on (a traceback, a library's lines)."""
    noise = [line for line in (proc.stdout + proc.stderr).splitlines() if any(m in line for m in NOISE)]
    assert not noise, noise[:5]


def _tour() -> list[list[str]]:
    text = (REPO / "README.md").read_text()
    block = re.search(r"<!-- tour -->\n(.*?)<!-- /tour -->", text, re.S).group(1)
    commands = []
    for line in block.splitlines():
        line = line.split("  #")[0].strip()
        if line:
            commands.append(shlex.split(line.replace("../shared/data", str(SHARED_DATA))))
    return commands


def _fitness_table(page: str, manoeuvre: str) -> dict:
    """``{condition: {method: fitness}}`` of the report's validation-fitness table of ``manoeuvre``."""
    block = page.split(f"## Validation fitness, {manoeuvre}", 1)[1].split("\n\n")[1]
    rows = [[c.strip() for c in line.strip("|").split("|")] for line in block.splitlines()]
    head, body = rows[0], rows[2:]
    return {row[0]: {m: float(v) for m, v in zip(head[1:], row[1:])} for row in body}


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.mark.slow
def test_the_readme_tour_runs_step_by_step(tmp_path):
    if not (SHARED_DATA / "kvlcc2_free_running").is_dir():
        pytest.skip("the shared data folder is not next to the repository")
    steps = _tour()
    assert [s[:2] for s in steps] == [["studies", "run"], ["studies", "discover"], ["studies", "run"],
                                      ["studies", "report"], ["studies", "ui"]]
    # 1. the main job: validation errors printed, and where the run went
    proc = run_studies(steps[0][1:], tmp_path)
    assert proc.returncode == 0, proc.stderr[-2000:]
    _quiet(proc)
    assert "logged to" in proc.stdout and "studies ui" in proc.stdout
    # what the README says it validates: zig-zags 10/10, 20/20 (trained on), 40/40 and a turning circle
    lines = proc.stdout.splitlines()
    for name in ("zigzag_10_10", "zigzag_20_20", "zigzag_40_40", "turning_35"):
        assert any(line.strip().startswith(name) for line in lines), (name, proc.stdout)
    assert "3 manoeuvre(s) or record(s) not trained on and 1 trained on" in proc.stdout
    assert len(mlflow_runs(tmp_path)) == 1
    # 2. the discovery on MARIN's records: the ship read from the files, a verdict with its page
    proc = run_studies(steps[1][1:], tmp_path)
    assert proc.returncode == 0, proc.stderr[-2000:]
    _quiet(proc)
    pages = list((tmp_path / "outputs").rglob("report.md"))
    assert len(pages) == 1 and '"cause"' in (pages[0].parent / "discovery.json").read_text()
    # the held-out turn goes beyond the zig-zags' states: said with the ranges, not a probability
    assert "verdict: outside_training_states (a measurement, not a probability" in proc.stdout, proc.stdout
    assert "yaw rate r' = r L / U" in proc.stdout and "records studied at full scale" in proc.stdout
    assert "Records studied at full scale" in pages[0].read_text()
    import sqlite3
    with sqlite3.connect(tmp_path / "mlruns" / "mlflow.db") as con:
        vessels = {row[0] for row in con.execute("select value from tags where key = 'vessel'")}
    assert "kvlcc2" in vessels
    # 3. the sweep: a parent run and one child per job (two methods at two noise levels)
    proc = run_studies(steps[2][1:], tmp_path)
    assert proc.returncode == 0, proc.stderr[-2000:]
    _quiet(proc)
    assert len(sweep_parents(tmp_path)) == 1 and len(mlflow_runs(tmp_path)) == 6
    # 4. the report of the sweep
    proc = run_studies(steps[3][1:], tmp_path)
    assert proc.returncode == 0, proc.stderr[-2000:]
    _quiet(proc)
    page = (tmp_path / "reports" / "tour" / "index.md").read_text()
    assert "noise.measurement" in page and (tmp_path / "reports" / "tour" / "index.html").is_file()
    # what the sweep compares differs visibly in the report's fitness figure: noise-free fits are
    # exact, noisy ones are not (orders of magnitude apart), and the two methods differ with noise
    turn = _fitness_table(page, "turning_35")
    assert set(turn) == {"+0 %", "+2 %"} and set(turn["+2 %"]) == {"LS", "SVM"}
    for method in ("LS", "SVM"):
        assert turn["+2 %"][method] > 1e6 * turn["+0 %"][method]
    assert max(turn["+2 %"].values()) > 2 * min(turn["+2 %"].values())
    assert (tmp_path / "reports" / "tour" / "fitness_turning_35.png").is_file()
    # 5. the UI answers on its address (a free port instead of 5000)
    port = _free_port()
    ui = subprocess.Popen([sys.executable, "-m", "studies", *steps[4][1:], f"port={port}"], cwd=tmp_path,
                          stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline, status = time.time() + 90.0, None
        while time.time() < deadline and status is None:
            try:
                status = urllib.request.urlopen(f"http://127.0.0.1:{port}/", timeout=2).status
            except OSError:
                time.sleep(1.0)
        assert status == 200
    finally:
        ui.terminate()
        ui.wait(timeout=30)
