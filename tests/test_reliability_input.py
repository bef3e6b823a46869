"""Issue 9, item 1: bad input gives one line, a non-zero exit, no traceback and no MLflow run.

Complements tests/test_cli_run.py (missing column, NaN, non-increasing time,
degrees, empty, binary, nonexistent path, negative wind speed, noise 5):
renamed column, inf, duplicated time, wrong delimiter, too few samples,
Hydra's own errors (unknown key, unknown option, unparsable override, ...),
paths outside the project, bad values in one job of a sweep, and MARIN files
whose repeated time stamps are repaired, not refused.
"""

import numpy as np
import pytest

from conftest import SHARED_DATA, mlflow_runs, run_studies


def _one_line_refusal(proc, tmp_path, *expected, status=2):
    """One line on stderr naming what is wrong, exit ``status``, no traceback, no run."""
    assert proc.returncode == status, (proc.returncode, proc.stderr[-2000:])
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1, proc.stderr
    assert lines[0].startswith("studies: error: "), lines[0]
    for text in expected:
        assert text in lines[0], (text, lines[0])
    assert "Traceback" not in proc.stderr + proc.stdout
    assert mlflow_runs(tmp_path) == []
    return lines[0]


def _renamed(f, p):
    f.rename(columns={"r": "yaw_rate"}).to_csv(p, index=False)
    return ("'r'", "yaw_rate")


def _inf(f, p):
    g = f.copy()
    g.loc[33, "u"] = np.inf
    g.to_csv(p, index=False)
    return ("'u'", "33")


def _minus_inf(f, p):
    g = f.copy()
    g.loc[5, "psi"] = -np.inf
    g.to_csv(p, index=False)
    return ("'psi'", "row 5")


def _duplicated_time(f, p):
    g = f.copy()
    g.loc[20, "t"] = g.loc[19, "t"]
    g.to_csv(p, index=False)
    return ("'t'", "row 20", "duplicated")


def _semicolons(f, p):
    f.to_csv(p, index=False, sep=";")
    return ("semicolon",)


def _tabs(f, p):
    f.to_csv(p, index=False, sep="\t")
    return ("tab",)


@pytest.mark.slow   # end to end; the fast loop runs one such case (test_cli_run.py) and these through the loader
@pytest.mark.parametrize("maker", [_renamed, _inf, _duplicated_time, _semicolons],
                         ids=lambda m: m.__name__.strip("_"))
def test_malformed_record_is_refused_in_one_line(tmp_path, good_frame, maker):
    path = tmp_path / "bad_record.csv"
    expected = maker(good_frame, path)
    proc = run_studies(["run", f"data.path={path}", "vessel=mariner", f"hydra.run.dir={tmp_path / 'run'}"], cwd=tmp_path)
    _one_line_refusal(proc, tmp_path, "bad_record.csv", *expected)


@pytest.mark.parametrize("maker", [_renamed, _inf, _minus_inf, _duplicated_time, _semicolons, _tabs],
                         ids=lambda m: m.__name__.strip("_"))
def test_malformed_record_is_refused_by_the_loader(tmp_path, good_frame, maker):
    """The same cases (and two more) through the loader: one line, file, column, row."""
    from studies.data import load_manoeuvre
    from studies.errors import DataError

    path = tmp_path / "bad_record.csv"
    expected = maker(good_frame, path)
    with pytest.raises(DataError) as info:
        load_manoeuvre(path)
    text = str(info.value)
    assert "\n" not in text and text.startswith(str(path))
    for part in expected:
        assert part in text, (part, text)


@pytest.mark.parametrize("method", ["ls", pytest.param("bayes", marks=pytest.mark.slow)])
@pytest.mark.slow
def test_too_few_samples_for_the_method(tmp_path, good_frame, method):
    path = tmp_path / "short.csv"
    good_frame.iloc[:30].to_csv(path, index=False)
    proc = run_studies(["run", f"data.path={path}", "vessel=mariner", f"method={method}",
                        f"hydra.run.dir={tmp_path / 'run'}"], cwd=tmp_path)
    _one_line_refusal(proc, tmp_path, "short.csv", "30 samples")


CONFIG_ERRORS = [
    (["foo=3"], "foo: unknown key"),
    (["wind.spead=3"], "did you mean wind.speed"),
    (["method=nope"], "method: unknown option 'nope'; known: "),
    (["vessel=titanic"], "vessel: unknown option 'titanic'"),
    (["method=nls"], "'nls' identifies roll decay studies: model=roll"),
    (["model=roll", "method=ls"], "method 'ls' is not available for roll decay studies; known: bayes, fls"),
    (["experiment=nope"], "experiment: unknown option"),
    (["wind.speed=[1"], "cannot parse 'wind.speed=[1'"),
    (["wind.speed=4,8"], "-m"),
    (["wind=3"], "wind: is a group of settings"),
    (["wind.speed=${nowhere}"], "wind.speed"),
    (["hydra.job.chdir=maybe"], "hydra.job.chdir"),
    (["hydra.nope=1"], "hydra.nope: unknown key"),
    (["wind.speed=fast"], "wind.speed must be a number"),
    (["noise.wind_speed_error=5"], "noise.wind_speed_error"),
    (["validate.manoeuvres=[zigzag_99]"], "unknown manoeuvre 'zigzag_99'"),
    (["resume=perhaps"], "resume must be true or false"),
    (["seed=-1"], "seed must be non-negative"),
    (["validate.duration=-1"], "validate.duration must be positive"),
    (["report.dir=/etc"], "report.dir: '/etc' is outside the project directory"),
    (["simplify.output=../../outside.json"], "simplify.output"),
]


@pytest.mark.parametrize("args,text", CONFIG_ERRORS, ids=[a[0] for a, _ in CONFIG_ERRORS])
def test_config_error_is_one_line_exit_2(tmp_path, monkeypatch, capsys, args, text):
    """In-process (fast): these are refused before Hydra runs a job."""
    from studies.cli import main

    monkeypatch.chdir(tmp_path)
    with pytest.raises(SystemExit) as info:
        main(["run", *args, f"hydra.run.dir={tmp_path / 'run'}"])
    out = capsys.readouterr()
    assert info.value.code == 2
    lines = out.err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("studies: error: "), out.err
    assert text in lines[0], lines[0]
    assert not (tmp_path / "run").exists() and not (tmp_path / "mlruns").exists()


@pytest.mark.parametrize("args,text", [(["foo=3"], "foo: unknown key"),
                                       (["method=nope"], "method: unknown option 'nope'")])
def test_config_error_from_the_console_script(tmp_path, args, text):
    proc = run_studies(["run", *args, f"hydra.run.dir={tmp_path / 'run'}"], cwd=tmp_path)
    _one_line_refusal(proc, tmp_path, text)


@pytest.mark.slow
def test_bad_value_in_one_job_of_a_sweep_refuses_the_whole_sweep(tmp_path, refused_in_process):
    """Every job's config is checked before the first job starts."""
    proc = run_studies(["run", "-m", "wind.speed=4,-8", "method=ls,nope",
                        f"hydra.sweep.dir={tmp_path / 'multirun'}"], cwd=tmp_path)
    _one_line_refusal(proc, tmp_path, "method: unknown option 'nope'")
    # the same check, in process: one bad value among the swept ones
    refused_in_process("config", ["-m", "wind.speed=4,-8", f"hydra.sweep.dir={tmp_path / 'multirun'}"],
                       tmp_path, "run", "wind.speed must be >= 0")
    assert not (tmp_path / "multirun").exists()


def test_verbose_shows_the_traceback(tmp_path):
    proc = run_studies(["run", "foo=3", "verbose=true"], cwd=tmp_path)
    assert proc.returncode != 0
    assert "Traceback" in proc.stderr and "foo: unknown key" in proc.stderr
    assert mlflow_runs(tmp_path) == []


@pytest.mark.parametrize("args,text,end_to_end", [
    (["report.dir=/etc"], "report.dir: '/etc' is outside", True),
    (["report.dir=../../x"], "report.dir: '../../x' is outside", False),
    (["nope=1"], "nope: unknown key", False),
])
def test_report_config_errors(tmp_path, refused_in_process, args, text, end_to_end):
    """Through the console script once; the other refusals of the same check in process."""
    if end_to_end:
        proc = run_studies(["report", *args], cwd=tmp_path)
        _one_line_refusal(proc, tmp_path, text)
    else:
        refused_in_process("report", args, tmp_path, "report", text)
        assert mlflow_runs(tmp_path) == []


def test_hydra_flags_and_sweeps_still_reach_hydra(tmp_path):
    proc = run_studies(["run", "--cfg", "job", "wind.speed=7"], cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert "speed: 7" in proc.stdout
    proc = run_studies(["run", "--help"], cwd=tmp_path)
    assert proc.returncode == 0 and "wind" in proc.stdout, proc.stderr


# ---------------------------------------------------------------- MARIN: repeated stamps repaired

MARIN = SHARED_DATA / "kvlcc2_free_running" / "MARIN_FREE_KVLCC2_zz_20_m.dat"


def test_marin_repeated_time_stamps_are_repaired_not_refused(tmp_path):
    from studies.data import load_manoeuvre
    from studies.errors import DataError

    if not MARIN.exists():
        pytest.skip(f"MARIN data not available: {MARIN}")
    raw = [line.split() for line in MARIN.read_text().splitlines()[2:] if line.split()]
    stamps = np.array([float(r[0]) for r in raw])
    assert np.any(np.diff(stamps) == 0), "the file is expected to repeat time stamps"
    record = load_manoeuvre(MARIN)
    t = record["t"].to_numpy(float)
    assert np.all(np.diff(t) > 0) and np.isfinite(record.to_numpy(float)).all()
    assert len(record) > 100
    # the same repeat in a CSV in the data contract is refused, with the row
    table = record.iloc[:200].copy()
    table.loc[table.index[50], "t"] = table["t"].iloc[49]
    table.to_csv(tmp_path / "repeat.csv", index=False)
    with pytest.raises(DataError, match=r"repeat.csv, column 't', row 50"):
        load_manoeuvre(tmp_path / "repeat.csv")


@pytest.mark.slow
def test_marin_file_is_accepted_by_studies_run(tmp_path):
    if not MARIN.exists():
        pytest.skip(f"MARIN data not available: {MARIN}")
    proc = run_studies(["run", f"data.path={MARIN}", "vessel=kvlcc2", "validate.manoeuvres=[]",
                        "tracking.experiment=marin", f"hydra.run.dir={tmp_path / 'run'}"], cwd=tmp_path)
    assert "duplicated" not in proc.stderr and "Traceback" not in proc.stderr, proc.stderr[-2000:]
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert [status for _, status, _ in mlflow_runs(tmp_path)] == ["FINISHED"]
