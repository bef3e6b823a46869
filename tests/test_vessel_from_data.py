"""``vessel=auto``: a measured record says which ship it is, or it is refused.

A measured KVLCC2 record must never be analysed as the Mariner (the default
vessel of simulated studies): the ship comes from the record's header, a
sidecar file or the particulars beside it; ``vessel=`` overrides.
"""

from __future__ import annotations

import shutil

import pytest
from conftest import SHARED_DATA, hsva_file, marin_file, mlflow_runs, run_studies

from studies.config import compose_settings
from studies.errors import DataError
from studies.workflows.vessel_choice import settle_vessel, vessel_of_records


def _settled(*overrides, root=None) -> str:
    cfg = compose_settings("config", overrides=list(overrides))
    return settle_vessel(cfg, root)


def test_the_facilities_files_name_their_ship():
    assert vessel_of_records([marin_file("zz_10"), hsva_file("35_05")]) == "kvlcc2"
    assert _settled(f"data.path=[{marin_file('zz_20')}]") == "kvlcc2"
    # no record: a simulated study of the Mariner, as before
    assert _settled() == "mariner"
    # vessel= overrides what the records say
    assert _settled("vessel=mariner", f"data.path=[{marin_file('zz_20')}]") == "mariner"


@pytest.mark.slow
def test_a_record_without_a_ship_is_refused_on_the_command_line(tmp_path, good_frame):
    path = tmp_path / "trial_7.csv"
    good_frame.to_csv(path, index=False)
    proc = run_studies(["run", f"data.path={path}", f"hydra.run.dir={tmp_path / 'run'}"], cwd=tmp_path)
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "trial_7.csv" in lines[0] and "which ship" in lines[0], proc.stderr
    assert "vessel=" in lines[0]
    assert mlflow_runs(tmp_path) == []
    # discover refuses it too, before any run
    proc = run_studies(["discover", f"data.path=[{path}]", f"hydra.run.dir={tmp_path / 'run2'}"], cwd=tmp_path)
    assert proc.returncode == 2 and "which ship" in proc.stderr, proc.stderr
    assert mlflow_runs(tmp_path) == []


def test_a_sidecar_or_the_particulars_beside_name_the_ship(tmp_path, good_frame):
    path = tmp_path / "trial_7.csv"
    good_frame.to_csv(path, index=False)
    (tmp_path / "trial_7.csv.yaml").write_text("vessel: mariner\n")
    assert vessel_of_records([path]) == "mariner"
    # a folder of KVLCC2 model tests with HSVA's particulars file beside them
    folder = tmp_path / "basin"
    folder.mkdir()
    shutil.copy(SHARED_DATA / "kvlcc2_hsva" / "ship_data.yml", folder / "ship_data.yml")
    good_frame.to_csv(folder / "run_1.csv", index=False)
    assert vessel_of_records([folder / "run_1.csv"]) == "kvlcc2"
    # particulars of no known ship
    other = tmp_path / "other"
    other.mkdir()
    (other / "ship_data.yml").write_text("L: 6.0\nB: 0.9\nT: 0.3\nscale_factor: 40\n")
    good_frame.to_csv(other / "run_1.csv", index=False)
    with pytest.raises(DataError, match="fits no known vessel"):
        vessel_of_records([other / "run_1.csv"])


def test_unknown_and_mixed_ships_are_refused(tmp_path, good_frame):
    kcs = tmp_path / "KCS_turn_35.csv"
    good_frame.to_csv(kcs, index=False)
    with pytest.raises(DataError, match="KCS"):
        vessel_of_records([kcs])
    mariner = tmp_path / "trial.csv"
    good_frame.to_csv(mariner, index=False)
    (tmp_path / "trial.csv.yaml").write_text("vessel: mariner\n")
    with pytest.raises(DataError, match="different ships"):
        vessel_of_records([marin_file("zz_10"), mariner])
