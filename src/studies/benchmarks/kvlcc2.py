"""State estimation and identification on the MARIN KVLCC2 files (when present).

``ekf_kinematic_tc35_s``: one EKF/RTS pass (kinematic process model, with
the likelihood search of the process-noise scale: 14 filter runs) over the
35 deg turning circle, 15 288 samples. ``ekf_model_tc35_s``: the same with
an identified Abkowitz model as process model. ``kvlcc2_identify_ekf_s``:
the whole estimation and least squares of ``data.derivative=ekf`` (kinematic
pass, two model iterations) on zz_10 + zz_20. Empty when the shared data
folder is absent. Compilation is done in a warm-up.
"""

import time
from pathlib import Path

from studies.identification.kalman import kalman_smooth
from studies.identification.ls import LeastSquares
from studies.models import abkowitz
from studies.vessels import get_vessel
from studies.workflows.measured import identify_measured, load_measured
from studies.benchmarks import shared_data

DATA = shared_data("kvlcc2_free_running")


def run() -> dict:
    files = {n: DATA / f"MARIN_FREE_KVLCC2_{n}_m.dat" for n in ("zz_10", "zz_20", "tc_35")}
    if not all(p.is_file() for p in files.values()):
        return {}
    vessel, model = get_vessel("kvlcc2"), abkowitz()
    recs = dict(zip(files, load_measured(list(files.values()))))
    kalman_smooth(recs["zz_10"].iloc[:400].reset_index(drop=True))            # compile
    t0 = time.perf_counter()
    result, _ = identify_measured(model, vessel, [recs["zz_10"], recs["zz_20"]], "ekf",
                                  LeastSquares(), None, None, 2, "speed")
    identify = time.perf_counter() - t0
    t0 = time.perf_counter()
    kalman_smooth(recs["tc_35"])
    kinematic = time.perf_counter() - t0
    t0 = time.perf_counter()
    kalman_smooth(recs["tc_35"], model=model, values=result.params, vessel=vessel)
    with_model = time.perf_counter() - t0
    return {"ekf_kinematic_tc35_s": kinematic, "ekf_model_tc35_s": with_model,
            "kvlcc2_identify_ekf_s": identify}
