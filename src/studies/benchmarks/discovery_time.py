"""Discovery: median time of one ``studies discover`` (DESIGN.md's
``discover_single_s``, ``discover_pair_s``, ``discover_kvlcc2_s``).

Single causes and pairs on three simulated Mariner records of the bench's
scenarios (3 % Li et al. noise, seeds 9100-9102: timing only, their verdicts
are not read), and the MARIN KVLCC2 records on the MMG baseline. Hit rates
with intervals are ``studies bench discover`` (:mod:`studies.bench_discovery`).
"""

from pathlib import Path

import numpy as np

from studies.bench_discovery import MARIN, real_case, simulated_case
from studies.scenarios.injected import Injection
from studies.benchmarks import shared_data

SINGLES = ("current", "rudder_offset", "environmental_bias")
PAIRS = ("current+rudder_offset", "rudder_offset+environmental_bias", "wind_speed_bias+environmental_bias")
MARIN_FOLDER = shared_data("kvlcc2_free_running")


def run() -> dict:
    # a discovery as a user runs it: nothing stated beforehand (discover.injected)
    single = [simulated_case(c, "li2023", 9100 + i, 0.03, "single", state=False)["elapsed"]
              for i, c in enumerate(SINGLES)]
    pair = [simulated_case(p, "li2023", 9100 + i, 0.03, "pair", state=False)["elapsed"] for i, p in enumerate(PAIRS)]
    out = {"discover_single_s": float(np.median(single)), "discover_pair_s": float(np.median(pair))}
    if all((MARIN_FOLDER / f).is_file() for f in MARIN):
        out["discover_kvlcc2_s"] = real_case(str(MARIN_FOLDER), Injection())["elapsed"]
    return out
