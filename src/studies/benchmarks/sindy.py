"""SINDy with cross-validation and its ensemble on the three MARIN KVLCC2 records (when present).

``sindy_ensemble_3_records_s``: the identification alone (states and
accelerations already estimated) of the Abkowitz model's terms, threshold
and ridge chosen by the time-block cross-validation, 20 block-bootstrap
draws; ``sindy_extended_3_records_s`` the same with the extended library
(35 candidates per DOF). ``sindy_run_3_records_s``: the whole
``studies run method=sindy`` job on the three records in process (loading,
kinematic smoothing, identification, replays). Medians of 3. Empty when the
shared data folder is absent.
"""

import statistics
import tempfile
import time
from pathlib import Path

from studies.config import compose_settings
from studies.identification.objective import TrajectoryObjective
from studies.identification.sindy import SparseRegression
from studies.models import abkowitz
from studies.vessels import get_vessel
from studies.workflows.kinds import kind_for
from studies.workflows.measured import estimate_all, load_measured, problems_from_estimates
from studies.benchmarks import shared_data

DATA = shared_data("kvlcc2_free_running")


def _median(fn, repeats: int = 3) -> float:
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def run() -> dict:
    files = [DATA / f"MARIN_FREE_KVLCC2_{n}_m.dat" for n in ("zz_10", "zz_20", "tc_35")]
    if not all(p.is_file() for p in files):
        return {}
    vessel, model = get_vessel("kvlcc2"), abkowitz()
    records = load_measured(files)
    estimates = estimate_all(records, "ekf_kinematic")
    problems = problems_from_estimates(model, vessel, records, estimates, weights="speed")
    objective = TrajectoryObjective(model, vessel, records)
    objective.problems_for = lambda other, fixed=None: problems_from_estimates(
        other, vessel, records, estimates, fixed, weights="speed")
    SparseRegression(ensemble=1).fit(problems)                    # imports pysindy
    plain = _median(lambda: SparseRegression().fit(problems))
    extended = _median(lambda: SparseRegression(library="extended").fit(problems, objective))

    def whole_run():
        cfg = compose_settings("config", overrides=["method=sindy", f"data.path=[{','.join(map(str, files))}]",
                                                     "validate.manoeuvres=[]"])
        with tempfile.TemporaryDirectory() as tmp:
            study = kind_for(cfg).prepare(cfg, Path(tmp))
            study.execute(Path(tmp) / "out")

    return {"sindy_ensemble_3_records_s": plain, "sindy_extended_3_records_s": extended,
            "sindy_run_3_records_s": _median(whole_run, 1)}
