"""Zhu (2021) reproduced: the thesis' wind convention and GA fitness, and its tables.

The thesis' code (its appendix A) computes the relative wind as its eq.
3.17 is printed, and its GA simulates the 20/20 zig-zag again with each
candidate. These tests hold the project to what that changes, measured
against the thesis' own published numbers (``studies/papers``) and on
zig-zags of the independent simulator in ``reference_mariner.py``.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import reference_mariner as ref
from studies.environment.conditions import Environment
from studies.environment.wind import wind_load
from studies.errors import ConfigError
from studies.identification import build_problems, make_identifier
from studies.identification.objective import ClosedLoopObjective, TrajectoryObjective, trajectory_objective
from studies.models.abkowitz import abkowitz
from studies.papers import published
from studies.report.reproduction.thesis import agreement
from studies.simulate import simulate
from studies.simulate.manoeuvres import turning, zigzag, zigzag_of_record
from studies.vessels import get_vessel

VESSEL = get_vessel("mariner")
MODEL = abkowitz()
TRUTH = {n: VESSEL.coefficients[n] for n in MODEL.names}


def _thesis_vessel():
    return dataclasses.replace(VESSEL, wind=dataclasses.replace(VESSEL.wind, convention="zhu2021"))


def _record(frame, name: str) -> pd.DataFrame:
    frame = pd.DataFrame(frame)
    frame.attrs["name"] = name
    return frame


# ------------------------------------------------------------------ wind convention

def test_the_thesis_wind_convention_mirrors_the_side_force_and_keeps_the_surge_force():
    """A wind from the starboard beam (from east, heading north) pushes the ship
    to port with the downwind convention and to starboard as the thesis'
    eq. 3.17 is printed; the surge force is the same."""
    wp = VESSEL.wind.as_array()
    thesis = _thesis_vessel().wind.as_array()
    down = wind_load(7.7, 0.0, 0.0, 12.0, np.pi / 2, wp)
    mirrored = wind_load(7.7, 0.0, 0.0, 12.0, np.pi / 2, thesis)
    assert down[1] < 0 < mirrored[1]
    assert down[0] == pytest.approx(mirrored[0])
    assert abs(mirrored[1]) == pytest.approx(abs(down[1]))


def test_the_thesis_moment_is_mss_blendermann94_without_the_port_extension():
    """For a relative wind from port (gamma < 0) the thesis' moment uses
    (s_L/L - 0.18 (gamma - pi/2)) C_Y, the downwind convention |gamma|."""
    w = VESSEL.wind
    wp, thesis = w.as_array(), _thesis_vessel().wind.as_array()
    # heading north, wind from north-west: the relative wind comes from port ahead
    x1, y1, n1 = wind_load(7.7, 0.0, 0.0, 12.0, -np.pi / 4, wp)
    x2, y2, n2 = wind_load(7.7, 0.0, 0.0, 12.0, -np.pi / 4, thesis)
    u_rw, v_rw = 7.7 + 12.0 * np.cos(-np.pi / 4), -12.0 * np.sin(-np.pi / 4)
    gamma = -np.arctan2(v_rw, u_rw)
    q = 0.5 * w.rho_air * (u_rw ** 2 + v_rw ** 2)
    cy = y2 / (q * w.area_lateral)
    expected = (w.s_l / w.length_overall - 0.18 * (gamma - np.pi / 2)) * cy * q * w.area_lateral * w.length_overall
    assert n2 == pytest.approx(expected, rel=1e-12)
    assert n1 != pytest.approx(n2, rel=1e-3)


def test_a_wind_convention_outside_the_known_ones_is_refused():
    with pytest.raises(ValueError, match="downwind, zhu2021"):
        dataclasses.replace(VESSEL.wind, convention="upwind")


# ------------------------------------------------------------------ zig-zag read from a record

@pytest.mark.parametrize("amplitude", [10.0, 20.0])
def test_the_zigzag_of_an_independent_record_is_read_from_the_record(amplitude):
    record = _record(ref.zigzag_record(amplitude, amplitude, duration=600.0, dt=0.1), f"zz{amplitude:g}")
    found = zigzag_of_record(record)
    assert found is not None
    assert (found.amplitude, found.heading, found.first_sign) == (amplitude, amplitude, 1)
    assert found.duration == pytest.approx(600.0) and found.dt == pytest.approx(0.1)


def test_a_turning_circle_is_not_read_as_a_zigzag_and_the_closed_loop_objective_refuses_it():
    record = _record(simulate(MODEL, TRUTH, VESSEL, turning(35.0, duration=300.0)), "turning_35")
    assert zigzag_of_record(record) is None
    with pytest.raises(ConfigError, match="turning_35.*not a zig-zag"):
        ClosedLoopObjective(MODEL, VESSEL, [record])
    with pytest.raises(ConfigError, match="objective.simulation"):
        trajectory_objective(MODEL, VESSEL, [record], "open_loop")


def test_the_closed_loop_fitness_adds_up_the_reversals_that_a_replayed_rudder_hides():
    """On a zig-zag of the independent simulator (adaptive RK45, exact event
    switching): the true coefficients steer it again up to the reversal
    timing of a stepped simulation (the switch waits for the next 0.1 s
    step, as MSS's ``zigzag.m`` does); a 2 % error in Nr shifts the
    reversals and raises the closed-loop fitness more than tenfold, and more
    than ten times what the replayed rudder shows of the same error."""
    record = _record(ref.zigzag_record(20.0, 20.0, duration=600.0, dt=0.1), "zz20")
    closed = ClosedLoopObjective(MODEL, VESSEL, [record])
    replayed = TrajectoryObjective(MODEL, VESSEL, [record])
    wrong = dict(TRUTH, Nr=1.02 * TRUTH["Nr"])
    assert closed.fitness(wrong) > 10 * closed.fitness(TRUTH)
    assert closed.fitness(wrong) > 10 * replayed.fitness(wrong)
    assert replayed.fitness(TRUTH) < 1e-9


# ------------------------------------------------------------------ the thesis' numbers

def _windy_record(vessel, speed: float, direction: float, error: float) -> pd.DataFrame:
    """The thesis' training record: the 20/20 zig-zag of 4000 s at 0.1 s in a
    steady wind, the anemometer reading ``speed (1 + error)`` (eq. 4.1)."""
    record = simulate(MODEL, TRUTH, vessel, zigzag(20.0, 20.0, duration=4000.0),
                      Environment(speed, np.deg2rad(direction)))
    record["wind_speed"] = speed * (1.0 + error)
    return _record(record, "zigzag_20_20")


def _ls_deviations(vessel, speed: float, direction: float, error: float) -> dict:
    fit = make_identifier("ls", {}).fit(build_problems(MODEL, vessel, [_windy_record(
        vessel, speed, direction, error)], "central"))
    return {n: 100 * (fit.params[n] - TRUTH[n]) / TRUTH[n] for n in MODEL.names}


def _against_thesis(found: dict, key: str, value: float) -> pd.DataFrame:
    thesis = published("thesis", "deviations")
    table = thesis[(thesis["key"] == key) & (thesis["value"] == value) & (thesis["method"] == "ls")]
    return pd.DataFrame({"deviation_pct_thesis": table["deviation_pct"].to_numpy(),
                         "deviation_pct_ours": [found[c] for c in table["coefficient"]]})


@pytest.mark.slow
def test_the_thesis_wind_convention_reproduces_its_least_squares_signs_sizes_and_trends():
    """Tables 4.6-4.14 (LS column) at 4 and 16 m/s, +10 %, 45 and -90 deg.
    With the wind as the thesis computes it, nine in ten deviations of at
    least 2 % have the thesis' sign and about its size, the deviations grow
    with the wind speed as the thesis' do (median |deviation| at 16 m/s above
    that at 4 m/s) and the beam wind (-90 deg) is worse than the quartering
    one (45 deg), as in the thesis; with the downwind convention about one
    sign in three agrees (the side force mirrored)."""
    conditions = {("wind.speed", 4.0): (4.0, 45.0, -0.05), ("wind.speed", 16.0): (16.0, 45.0, -0.05),
                  ("noise.wind_speed_error", 0.10): (12.0, 45.0, 0.10),
                  ("wind.direction", 45.0): (12.0, 45.0, -0.05),
                  ("wind.direction", -90.0): (12.0, -90.0, -0.05)}
    thesis_vessel = _thesis_vessel()
    ours = {cond: _ls_deviations(thesis_vessel, *args) for cond, args in conditions.items()}
    pairs = pd.concat([_against_thesis(found, *cond) for cond, found in ours.items()])
    result = agreement(pairs)
    assert result["compared"] >= 100
    assert result["sign"] >= 0.85
    assert 0.7 <= result["ratio"] <= 1.5

    def median_abs(found):
        return float(np.median(np.abs(list(found.values()))))
    thesis = published("thesis", "deviations")

    def thesis_median(key, value):
        table = thesis[(thesis["key"] == key) & (thesis["value"] == value) & (thesis["method"] == "ls")]
        return float(np.median(np.abs(table["deviation_pct"])))
    for low, high in ((("wind.speed", 4.0), ("wind.speed", 16.0)),
                      (("wind.direction", 45.0), ("wind.direction", -90.0))):
        assert thesis_median(*high) > thesis_median(*low)
        assert median_abs(ours[high]) > median_abs(ours[low])

    downwind = pd.concat([_against_thesis(_ls_deviations(VESSEL, *conditions[cond]), *cond)
                          for cond in (("wind.speed", 16.0), ("wind.direction", -90.0))])
    assert agreement(downwind)["sign"] <= 0.5


@pytest.mark.slow
def test_the_closed_loop_fitness_is_a_narrow_valley_that_joint_redraws_miss():
    """The thesis set-up at 16 m/s: the least-squares start lies above the
    GA's stop (1e-5), so the GA runs; redrawing all 15 genes uniformly within
    +-50 % (the thesis' mutation probability 1) does not find a better point
    in 150 draws, while moving a single gene alone lowers the fitness at
    least threefold."""
    from studies.identification.ga import gene_bounds
    from studies.identification.sensitivity import least_sensitive

    vessel = _thesis_vessel()
    record = _windy_record(vessel, 16.0, 45.0, -0.05)
    problems = build_problems(MODEL, vessel, [record], "central")
    start = make_identifier("ls", {}).fit(problems).params
    objective = ClosedLoopObjective(MODEL, vessel, [record])
    vector = MODEL.vector(start)
    f0 = objective.fitness_many(vector[None])[0]
    assert f0 > 1e-5
    genes, _ = least_sensitive(problems, start, 5, 1024, 0)
    idx = np.array([MODEL.names.index(g) for g in genes])
    low, high = gene_bounds(vector[idx])
    rng = np.random.default_rng(3)
    joint = np.repeat(vector[None], 150, axis=0)
    joint[:, idx] = rng.uniform(low, high, size=(150, len(idx)))
    assert objective.fitness_many(joint).min() > f0
    single = []
    for k, i in enumerate(idx):
        trial = np.repeat(vector[None], 9, axis=0)
        trial[:, i] = np.linspace(low[k], high[k], 9)
        single.append(objective.fitness_many(trial).min())
    assert min(single) < f0 / 3


# ------------------------------------------------------------------ the thesis' records (MSS zigzag.m)

def _mss_zigzag(duration: float = 4000.0, first_sign: int = -1, execute: float = 9.5):
    """The thesis' 20/20 zig-zag as MSS ``zigzag.m`` with ``mariner.m`` runs it: the
    rudder held amidships until 9.5 s (``round(t)`` reaching the 10 s of the thesis'
    call) and then to starboard first (``mariner.m`` takes the command with the
    opposite sign)."""
    return dataclasses.replace(zigzag(20.0, 20.0, duration=duration), first_sign=first_sign, execute=execute)


def test_euler_steps_differenced_forward_are_identified_exactly():
    """MSS ``zigzag.m`` steps by forward Euler and the thesis differences
    forward (eq. 3.9): on such a record the regression sees the model's own
    right-hand side, so least squares returns the published coefficients
    (within 1e-6 relative, to 1e-3 for the weakly excited Xuu and Xuuu); the
    same record differenced centrally, or an RK4 record differenced forward,
    is off by orders of magnitude more. The Euler record holds the rudder
    amidships until 9.5 s and then turns to starboard first, as MSS's does,
    and departs from the RK4 one by the scheme's error; the zig-zag read from
    it for the GA's closed loop has the same execute time and side."""
    euler = simulate(MODEL, TRUTH, VESSEL, _mss_zigzag(600.0), scheme="euler")
    rk4 = simulate(MODEL, TRUTH, VESSEL, _mss_zigzag(600.0))
    assert (euler["delta"].iloc[:96] == 0).all() and euler["delta"].iloc[96] < 0
    assert euler["r"].iloc[300] > 0                                         # starboard first
    read = zigzag_of_record(_record(euler, "zz"))
    assert (read.execute, read.first_sign, read.amplitude, read.heading) == (9.5, -1, 20.0, 20.0)
    assert 1e-4 < np.max(np.abs(euler["v"] - rk4["v"])) < 0.05

    def worst(record, derivative, names):
        params = make_identifier("ls", {}).fit(build_problems(MODEL, VESSEL, [_record(record, "zz")],
                                                              derivative)).params
        return max(abs(params[n] - TRUTH[n]) / abs(TRUTH[n]) for n in names)
    weak = ("Xuu", "Xuuu")
    strong = [n for n in MODEL.names if n not in weak]
    assert worst(euler, "forward", strong) < 1e-6 and worst(euler, "forward", weak) < 1e-3
    assert worst(euler, "central", strong) > 1e-3
    assert worst(rk4, "forward", strong) > 1e-3
    with pytest.raises(ValueError, match="integration scheme must be one of rk4, euler"):
        simulate(MODEL, TRUTH, VESSEL, _mss_zigzag(10.0), scheme="midpoint")


@pytest.mark.slow
def test_the_thesis_ga_changes_the_coefficients_on_the_thesis_records_at_12_m_s():
    """The thesis set-up at 12 m/s: records as MSS makes them (Euler steps,
    starboard first, differenced forward) and the GA's closed-loop fitness
    simulated by RK4, a different program as the thesis' GA code was. The
    start lies far above the stop and 30 generations of the thesis' GA
    (mutation probability 1: a random search) lower the fitness and change
    all 15 genes, as the thesis' GA did in its tables (narrow-valley test
    above: on RK4 records it finds no better draw)."""
    from studies.identification.ga import GeneticRefinement

    vessel = _thesis_vessel()
    record = simulate(MODEL, TRUTH, vessel, _mss_zigzag(), Environment(12.0, np.deg2rad(45.0)), scheme="euler")
    record["wind_speed"] = 12.0 * 0.95
    record = _record(record, "zigzag_20_20")
    problems = build_problems(MODEL, vessel, [record], "forward")
    ga = GeneticRefinement(base="ls", sobol_samples=1024, generations=30)
    result = ga.fit(problems, objective=ClosedLoopObjective(MODEL, vessel, [record]))
    start = ga.start(problems, None).params
    assert result.metrics["ga/initial_fitness"] > 1e-4
    assert result.metrics["ga/best_fitness"] < 0.8 * result.metrics["ga/initial_fitness"]
    moved = [n for n in MODEL.names if abs(result.params[n] - start[n]) > 1e-9 * abs(start[n])]
    assert len(moved) == 15


@pytest.mark.parametrize("key,value,speed,direction,error", [
    ("wind.speed", 16.0, 16.0, 45.0, -0.05), ("wind.direction", 90.0, 12.0, 90.0, -0.05),
    ("noise.wind_speed_error", -0.10, 12.0, 45.0, -0.10)])
def test_records_made_as_mss_makes_them_reproduce_the_thesis_least_squares(key, value, speed, direction, error):
    """Tables 4.6-4.14, least squares, at 16 m/s, at 90 deg and at -10 %:
    on the thesis' records as MSS ``zigzag.m`` makes them (Euler steps, the
    rudder amidships until 9.5 s, then to starboard first; differenced
    forward) every deviation of at least 2 % has the thesis' sign and the
    median difference from the thesis is below half a percentage point; with
    the rudder laid at once, or to port first, the median difference is at
    least twice as large, and the speed-coupled yaw terms (Nvu, Nru, Nud,
    Nuud) are further from the thesis' values."""
    thesis = published("thesis", "deviations")
    table = thesis[(thesis["key"] == key) & (thesis["value"] == value) & (thesis["method"] == "ls")]
    theirs = dict(zip(table["coefficient"], table["deviation_pct"]))
    vessel = _thesis_vessel()
    found = {}
    for label, man in (("mss", _mss_zigzag()), ("at once", _mss_zigzag(execute=0.0)),
                       ("port first", _mss_zigzag(first_sign=1))):
        record = simulate(MODEL, TRUTH, vessel, man, Environment(speed, np.deg2rad(direction)), scheme="euler")
        record["wind_speed"] = speed * (1.0 + error)
        params = make_identifier("ls", {}).fit(build_problems(MODEL, vessel, [_record(record, "zz")],
                                                              "forward")).params
        found[label] = {n: 100 * (params[n] - TRUTH[n]) / TRUTH[n] for n in theirs}
    diff = {k: np.median([abs(v[n] - theirs[n]) for n in theirs]) for k, v in found.items()}
    pairs = pd.DataFrame({"deviation_pct_thesis": list(theirs.values()),
                          "deviation_pct_ours": [found["mss"][n] for n in theirs]})
    assert agreement(pairs)["sign"] == 1.0 and agreement(pairs)["compared"] >= 20
    assert diff["mss"] < 0.5
    assert diff["at once"] > 2 * diff["mss"] and diff["port first"] > 2 * diff["mss"]
    coupled = [n for n in ("Nvu", "Nru", "Nud", "Nuud") if n in theirs]

    def off(label):
        return sum(abs(found[label][n] - theirs[n]) for n in coupled)
    assert off("mss") < off("at once") and off("mss") < off("port first")


# ------------------------------------------------------------------ the reproduction report

class _Run:
    """A finished run as the store gives it back, whose coefficients deviate
    from the published ones by ``deviations`` [%]."""

    def __init__(self, number: int, speed: float, method: str, convention: str, deviations: dict):
        self.run_id = f"{number:032x}"
        self.name = f"{method} wind={speed:g}"
        self.status, self.start_time = "FINISHED", number
        self.params = {"wind.speed": str(speed), "method.name": method, "wind.convention": convention,
                       "objective.simulation": "closed_loop" if convention == "zhu2021" else "replay"}
        if convention == "zhu2021":         # conventions=zhu2021: MSS's records, differenced forward
            self.params.update({"data.scheme": "euler", "data.derivative": "forward",
                                "manoeuvre.first_sign": "-1", "manoeuvre.execute": "9.5"})
        self.metrics = {"zigzag_10_10/fitness": 1e-4, "ga/initial_fitness": 3e-5, "ga/best_fitness": 3e-5,
                        "ga/generations": 200.0}
        self.tags = {}
        self.deviations = deviations

    def artifact(self, path, destination):
        if path != "coefficients.csv":
            return None
        Path(destination).mkdir(parents=True, exist_ok=True)
        names = list(self.deviations)
        true = np.array([TRUTH[n] for n in names])
        value = true * (1 + np.array([self.deviations[n] for n in names]) / 100)
        pd.DataFrame({"name": names, "value": value, "lower": np.nan, "upper": np.nan, "true": true,
                      "deviation_pct": [self.deviations[n] for n in names]}).to_csv(Path(destination) / path,
                                                                                     index=False)
        return Path(destination) / path


def test_the_reproduction_report_measures_agreement_from_the_runs(tmp_path):
    """Runs of the wind-speed preset at 16 m/s whose LS and SVM deviations are
    the thesis' own (thesis set-up) and the thesis' with the sign flipped
    (project set-up): the page gives sign agreement 1.00 and 0.00, the
    magnitude ratio 1.00, and Table 4.6 with both side by side; no
    disagreement is listed for the thesis set-up."""
    from studies.report.reproduction import build_reproduction

    thesis = published("thesis", "deviations")
    runs = []
    for k, method in enumerate(("ls", "svm", "ls_ga", "svm_ga")):
        table = thesis[(thesis["key"] == "wind.speed") & (thesis["value"] == 16.0) & (thesis["method"] == method)]
        dev = dict(zip(table["coefficient"], table["deviation_pct"]))
        runs.append(_Run(2 * k, 16.0, method, "zhu2021", dev))
        runs.append(_Run(2 * k + 1, 16.0, method, "downwind", {c: -d for c, d in dev.items()}))
    page = build_reproduction("thesis", {"thesis_wind_speed": runs}, tmp_path).read_text()
    assert "| 4.6-4.8: wind speed (-5 % error, from 45 deg) | thesis set-up | LS |" in page
    rows = [line for line in page.splitlines() if line.startswith("| 4.6-4.8")]
    thesis_ls = next(r for r in rows if "| thesis set-up | LS |" in r).split("|")
    project_ls = next(r for r in rows if "| project set-up | LS |" in r).split("|")
    assert (thesis_ls[5].strip(), thesis_ls[6].strip()) == ("1.00", "1.00")
    assert project_ls[5].strip() == "0.00"
    assert "## Table 4.6 (thesis p. 39)" in page
    assert "| Xrr | 37.47 / 37.47 / -37.47 |" in page
    assert "No LS or SVM deviation of the thesis set-up disagrees" in page
    assert "`thesis_noise`, `thesis_direction`" in page          # missing experiments named
    assert (tmp_path / "reproduce_thesis" / "index.html").exists()


@pytest.mark.slow
def test_studies_report_compares_a_thesis_sweep_as_a_user_runs_it(tmp_path):
    """``studies run -m experiment=thesis_wind_speed conventions=zhu2021`` at
    16 m/s with LS and SVM, then ``studies report report.compare=thesis``:
    the page holds the least-squares agreement with Table 4.6-4.8 at that
    speed (nine signs in ten) and a cause for every disagreement."""
    from conftest import run_studies

    proc = run_studies(["run", "-m", "experiment=thesis_wind_speed", "conventions=zhu2021", "wind.speed=16",
                        "method=ls,svm", "validate.manoeuvres=[zigzag_10_10]", "hydra.launcher.n_jobs=2"],
                       cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr[-2000:]
    proc = run_studies(["report", "report.compare=thesis"], cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr[-2000:]
    page = (tmp_path / "reports" / "reproduce_thesis" / "index.md").read_text()
    row = next(line for line in page.splitlines()
               if line.startswith("| 4.6-4.8") and "| thesis set-up | LS |" in line).split("|")
    assert int(row[4]) >= 20 and float(row[5]) >= 0.85
    table = page[page.index("## Disagreements"):page.index("## Table 4.6")]
    listed = [line for line in table.splitlines() if line.startswith("| 4.")]
    assert all(line.rstrip(" |").split("|")[-1].strip() for line in listed)


@pytest.mark.slow
def test_a_disagreement_is_called_ill_determined_only_where_the_record_does_not_pin_the_coefficient():
    """The measure behind the causes: on the 12 m/s zig-zag the coefficients
    the thesis and the project agree on (Xrr, Xrv, Nvvr) move by less than a
    point between the record's quarters, the collinear speed terms (Xuu, Xuuu,
    N0uu) by tens of points; a difference beyond twice the spread is not
    explained away."""
    from studies.report.reproduction.thesis import (ILL_DETERMINED, THESIS_SETUP, UNEXPLAINED, _cause,
                                                    _spread_by_condition)

    spread = _spread_by_condition("thesis_wind_speed", 12.0, THESIS_SETUP)
    assert max(spread["Xrr"], spread["Xrv"], spread["Nvvr"]) < 1.0
    assert min(spread["Xuu"], spread["Xuuu"], spread["N0uu"]) > 20.0
    empty = pd.DataFrame()
    assert _cause(-12.5, 14.5, spread["Xuu"], "ls", empty, np.nan, False, True)[0] == ILL_DETERMINED
    assert _cause(44.9, 4.0, spread["Xrr"], "ls", empty, np.nan, False, False)[0] == UNEXPLAINED


def test_the_thesis_page_says_how_many_ga_starts_lie_above_the_stop_as_measured():
    from studies.report.reproduction.thesis import _above_stop

    assert _above_stop([2e-5, 3e-4, 1e-3]) == "every start lies above the stop 1e-05 (3 of 3)"
    assert _above_stop([2e-5, 5e-6, 1e-3]) == "2 of 3 starts lie above the stop 1e-05"


def test_the_calm_water_tables_are_judged_at_their_printed_precision():
    """Tables 4.3-4.5: the same page from altered values changes its verdicts."""
    from studies.papers import published
    from studies.report.reproduction.thesis import calm_verdicts

    paper = published("thesis", "calm")
    assert len(paper) == 40 and set(paper["table"]) == {"4.3", "4.4", "4.5"}
    exact = {(m, r.coefficient): float(r.original) for r in paper.itertuples() for m in ("ls", "svm")}
    found = calm_verdicts(paper, exact).set_index(["coefficient", "method"])
    assert (found.xs("LS", level="method")["verdict"] == "same").all()            # the thesis' LS is exact
    assert found.loc[("Y0uu", "SVM"), "verdict"] == "differs"                      # its SVM: -56 %
    assert "the project's value is the original" in found.loc[("Y0uu", "SVM"), "cause"]
    assert found.loc[("Xu", "SVM"), "verdict"] == "same"
    altered = dict(exact)
    altered[("ls", "Xu")] = -1.90e-3                          # 3 % off: no longer the thesis' -1.84e-3
    altered[("svm", "Y0uu")] = -1.75e-5                       # the thesis' own SVM value
    found = calm_verdicts(paper, altered).set_index(["coefficient", "method"])
    assert found.loc[("Xu", "LS"), "verdict"] == "differs"
    assert "the project's departs" in found.loc[("Xu", "LS"), "cause"]
    assert found.loc[("Y0uu", "SVM"), "verdict"] == "same"


def test_the_cells_the_thesis_names_for_its_validation_figures_are_judged_on_the_runs():
    from studies.report.reproduction.thesis import THESIS_SETUP, figure_claims

    rows = []
    for manoeuvre in ("zigzag_10_10", "zigzag_20_20", "zigzag_40_40"):
        for speed in (4.0, 8.0, 12.0, 16.0):
            for method, fitness in (("ls", 3.0), ("ls_ga", 2.0), ("svm", 1.0), ("svm_ga", 1.5)):
                rows.append({"experiment": "thesis_wind_speed", "setup": THESIS_SETUP, "value": speed,
                             "series": method, "manoeuvre": manoeuvre, "fitness": fitness, "diverged": False,
                             "start": 1})
    table = pd.DataFrame(rows)
    found = figure_claims(table, THESIS_SETUP)
    wind = found[found["figure"] == "4.1"]
    assert (wind["verdict"] == "holds").sum() == 11           # SVM lowest in 9 cells, LS+GA below LS twice
    assert wind[wind["thesis"] == "SVM+GA lowest"]["verdict"].tolist() == ["does not hold"]
    assert (found[found["figure"] != "4.1"]["verdict"] == "not measured").all()
    # the same cells with SVM's prediction diverged at 4 m/s in zig-zag 10/10: that claim fails
    table.loc[(table["value"] == 4.0) & (table["manoeuvre"] == "zigzag_10_10") & (table["series"] == "svm"),
              "diverged"] = True
    again = figure_claims(table, THESIS_SETUP)
    assert (again[again["figure"] == "4.1"]["verdict"] == "holds").sum() == 10
    # SVM within 1 % of LS (the project's SVM often lands on its LS): a tie, not a failure
    table.loc[(table["value"] == 8.0) & (table["series"] == "ls"), "fitness"] = 0.995
    tied = figure_claims(table, THESIS_SETUP)
    assert (tied[tied["figure"] == "4.1"]["verdict"] == "tied").sum() == 3
