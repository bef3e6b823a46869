"""Discovery: time of one discovery with the full catalogue and hit rates on
hidden effects.

Hit rate: over seeds (magnitudes drawn at random per seed, see
:mod:`studies.discover.hidden`), the fraction of discoveries that name the
right cause with the parameter within 20 % (angles within 0.2 rad). Set
``STUDIES_BENCH_SEEDS`` (default 2; 0 leaves the manoeuvring causes out) and ``STUDIES_BENCH_NOISE`` (default
"0,0.05") to choose the effort; the runs use all cores. Roll decays
(``roll_quadratic_damping``, ``roll_cubic_damping``) are scored the same way
at 1 % and 5 % noise (``STUDIES_BENCH_ROLL_SEEDS``, default 10; 0 leaves them out).
"""

import os
import tempfile
import time
from pathlib import Path

import numpy as np
from hydra import initialize_config_module
from joblib import Parallel, delayed

from studies.config import compose_settings
from studies.discover.hidden import (HIDDEN_CAUSES, HIDDEN_ROLL_CAUSES, hidden_records,
                                     hidden_roll_decays, parameters_match, write_records)
from studies.vessels import get_vessel
from studies.workflows.kinds import execute_discover, prepare_discover


def _one(cause, seed, noise):
    vessel = get_vessel("mariner")
    records, truth = hidden_records(vessel, cause, seed=seed, noise=noise)
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        paths = write_records(records, tmp)
        with initialize_config_module("studies.conf", version_base="1.3"):
            # a propeller's side force is judged against the symmetric baseline
            model = ["model=symmetric"] if cause == "propeller_asymmetry" else []
            cfg = compose_settings("discover", overrides=[f"data.path=[{paths[0]},{paths[1]}]",
                                                 f"validate.path=[{paths[2]}]", f"seed={seed}", *model])
        t0 = time.perf_counter()
        d, _ = execute_discover(prepare_discover(cfg, tmp), tmp / "out")
        elapsed = time.perf_counter() - t0
    hit = d["cause"] == cause and parameters_match(cause, d["parameters"], truth)
    return cause, noise, seed, hit, elapsed


def _one_roll(cause, seed, noise):
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        paths, truth = hidden_roll_decays(cause, tmp, seed, noise)
        with initialize_config_module("studies.conf", version_base="1.3"):
            cfg = compose_settings("discover", overrides=["model=roll", f"data.path=[{paths[0]}]",
                                                 f"validate.path=[{paths[1]}]"])
        d, _ = execute_discover(prepare_discover(cfg, tmp), tmp / "out")
    return cause, float(noise), bool(d["cause"] == cause and parameters_match(cause, d["parameters"], truth))


def run() -> dict:
    seeds = int(os.environ.get("STUDIES_BENCH_SEEDS", "2"))
    noises = [float(x) for x in os.environ.get("STUDIES_BENCH_NOISE", "0,0.05").split(",")]
    jobs = [(c, s, n) for c in HIDDEN_CAUSES for n in noises for s in range(seeds)]
    out = {"discover_seeds_per_cause": seeds}
    if jobs:        # STUDIES_BENCH_SEEDS=0 leaves the manoeuvring causes out
        results = Parallel(n_jobs=-1)(delayed(_one)(c, 100 + s, n) for c, s, n in jobs)
        out["discover_one_600s_records_s_median"] = float(np.median([r[4] for r in results]))
        for cause in HIDDEN_CAUSES:
            for n in noises:
                hits = [r[3] for r in results if r[0] == cause and r[1] == n]
                out[f"discover_hit_rate/{cause}/noise={n:g}"] = float(np.mean(hits))
    roll_seeds = int(os.environ.get("STUDIES_BENCH_ROLL_SEEDS", "10"))
    if roll_seeds < 1:
        return out
    roll = Parallel(n_jobs=-1)(delayed(_one_roll)(c, 100 + s, n) for c in HIDDEN_ROLL_CAUSES
                               for n in (0.01, 0.05) for s in range(roll_seeds))
    for cause in HIDDEN_ROLL_CAUSES:
        for n in (0.01, 0.05):
            hits = [r[2] for r in roll if r[0] == cause and r[1] == n]
            out[f"discover_hit_rate/{cause}/noise={n:g}"] = float(np.mean(hits))
    return out
