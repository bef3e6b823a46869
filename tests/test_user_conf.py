"""A user's own presets and manoeuvres in ``./conf`` (or ``$STUDIES_CONF``),
found before the packaged ones."""

from __future__ import annotations

import pytest

from conftest import mlflow_runs, run_studies
from studies.config import compose_settings, known_manoeuvres, manoeuvre_config

PRESET = """# @package _global_
preset: my_sweep
tracking:
  experiment: my_sweep
manoeuvre:
  duration: 200.0
validate:
  manoeuvres: [my_zigzag]
  duration: 100.0
hydra:
  mode: MULTIRUN
  sweeper:
    params:
      wind.speed: 0,4
"""

MANOEUVRE = """name: my_zigzag
kind: zigzag
amplitude: 15.0
heading: 15.0
duration: 300.0
dt: 0.1
"""


@pytest.fixture
def user_conf(tmp_path, monkeypatch):
    (tmp_path / "conf" / "experiment").mkdir(parents=True)
    (tmp_path / "conf" / "manoeuvre").mkdir()
    (tmp_path / "conf" / "experiment" / "my_sweep.yaml").write_text(PRESET)
    (tmp_path / "conf" / "manoeuvre" / "my_zigzag.yaml").write_text(MANOEUVRE)
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("STUDIES_CONF", raising=False)
    return tmp_path


def test_a_user_preset_and_manoeuvre_in_conf_are_found(user_conf):
    cfg = compose_settings("config", ["experiment=my_sweep"])
    assert cfg.preset == "my_sweep" and cfg.validate.manoeuvres == ["my_zigzag"]
    assert "my_zigzag" in known_manoeuvres() and "zigzag_20_20" in known_manoeuvres()
    assert manoeuvre_config("my_zigzag").amplitude == 15.0
    cfg = compose_settings("config", ["manoeuvre=my_zigzag"])
    assert cfg.manoeuvre.name == "my_zigzag" and cfg.manoeuvre.heading == 15.0


def test_a_user_manoeuvre_replaces_its_packaged_namesake(user_conf):
    text = MANOEUVRE.replace("my_zigzag", "zigzag_10_10").replace("15.0", "12.0")
    (user_conf / "conf" / "manoeuvre" / "zigzag_10_10.yaml").write_text(text)
    assert manoeuvre_config("zigzag_10_10").amplitude == 12.0
    assert compose_settings("config", ["manoeuvre=zigzag_10_10"]).manoeuvre.amplitude == 12.0


def test_studies_conf_points_at_another_folder(user_conf, tmp_path_factory, monkeypatch):
    elsewhere = tmp_path_factory.mktemp("team_conf")
    (user_conf / "conf").rename(elsewhere / "conf")
    monkeypatch.setenv("STUDIES_CONF", str(elsewhere / "conf"))
    assert compose_settings("config", ["experiment=my_sweep"]).preset == "my_sweep"


@pytest.mark.slow
def test_a_user_preset_runs_as_a_sweep(user_conf):
    proc = run_studies(["run", "experiment=my_sweep"], user_conf)
    assert proc.returncode == 0, proc.stderr
    runs = mlflow_runs(user_conf)
    assert len(runs) == 2 and {r[1] for r in runs} == {"FINISHED"}
