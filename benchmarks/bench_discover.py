"""Discovery: time of one discovery with the full catalogue and hit rates on
hidden effects.

Hit rate: over seeds (magnitudes drawn at random per seed, see
:mod:`studies.scenarios.hidden`), the fraction of discoveries that name the
right cause with the parameter within 20 % (angles within 0.2 rad). Set
``STUDIES_BENCH_SEEDS`` (default 2; 0 leaves the manoeuvring causes out) and ``STUDIES_BENCH_NOISE`` (default
"0,0.05") to choose the effort; the runs use all cores. Roll decays
(``roll_quadratic_damping``, ``roll_cubic_damping``) are scored the same way
at 1 % and 5 % noise (``STUDIES_BENCH_ROLL_SEEDS``, default 10; 0 leaves them out).

Noise families: ``STUDIES_BENCH_FAMILIES`` (default "li2023", comma-separated
names of :data:`studies.environment.sensor_noise.NOISE_FAMILIES`) adds the
measurement-noise models the discovery was not developed on. Figures per
cause, noise level and family:

- ``discover_hit_rate/<cause>/noise=<n>/<family>``; for ``li2023`` the key
  has no family suffix (today's names, so older results compare), and at
  noise 0 the families coincide (no noise at all) and run once, under the
  suffix-free key;
- ``discover_confusion``: ``{"noise=<n>[/<family>]": {true cause: {named
  cause: count}}}``;
- ``discover_second_cause_rate``: over the runs with one cause hidden (not
  ``none``) whose first cause is right, the fraction that also name a
  second cause (a non-null ``second_cause`` in discovery.json: spurious,
  since only one was hidden); ``discover_second_cause_rate/noise=<n>[/<family>]``
  per setting. ``None`` when no run qualifies.

Hidden effects beyond the development cases: ``STUDIES_BENCH_MISSING=any``
hides, for ``missing_term``, a term drawn from the whole extended library
(any DOF, 5-15 % of its DOF's force, either sign) instead of the cubic yaw
damping ``Nrrr``; ``STUDIES_BENCH_PAIRS=1`` adds every pair of causes that
can act together (:func:`studies.scenarios.hidden.hidden_pairs`; or a
comma-separated list ``a+b,c+d``): a pair is a hit when the verdict names
both with both parameters right.

Scenarios: ``STUDIES_BENCH_SCENARIOS=varied`` (the default) draws, per seed,
how the records are made besides the effect and the sensor noise
(:func:`studies.scenarios.hidden.draw_scenario`): sampling 0.1, 0.2 or 0.5 s,
records of 400-900 s, which turning circle and zig-zag train (either side)
and which manoeuvre validates, process noise in half the cases;
``fixed`` keeps the development set-up (a 20/20 zig-zag and a 35 deg
turning circle to train, a 10/10 zig-zag to validate, 600 s at 0.1 s).

Seeds: development uses seeds 100, 101, ... (the tests use smaller seeds).
``STUDIES_BENCH_HELDOUT=1`` draws seeds 1000, 1001, ... instead (manoeuvring
and roll causes alike): held-out seeds that development never looks at, to
check hit rates without tuning to the development seeds. Report them only
as a final check; ``discover_seed_base`` in the output says which range ran.
Once a held-out range has been looked at, it is no longer held out:
``STUDIES_BENCH_SEED_BASE=<n>`` starts at any other seed (1000-1001 and 2000
have been read, and 2100-2101, 2200, 2300 and 2400 since).
"""

import os
import tempfile
import time
from pathlib import Path

import numpy as np
from hydra import initialize_config_module
from joblib import Parallel, delayed

from studies.config import compose_settings
from studies.scenarios.hidden import (HIDDEN_CAUSES, HIDDEN_ROLL_CAUSES, draw_scenario, hidden_pairs,
                                     hidden_records, hidden_roll_decays, parameters_match, write_records)
from studies.environment.sensor_noise import check_sensor_noise
from studies.vessels import get_vessel
from studies.workflows.kinds import execute_discover, prepare_discover


#: first seed of the development runs and of the held-out runs (STUDIES_BENCH_HELDOUT=1)
DEVELOPMENT_SEED, HELDOUT_SEED = 100, 1000


def _one(cause, seed, noise, family="li2023", missing="Nrrr", scenarios="fixed"):
    """One discovery on hidden records: a dict of the setting, the hit, the named first and
    second causes and the discovery's wall time [s]. ``cause`` may be a pair ``"a+b"``: a
    hit names both (the pair as the verdict, in either order) with both parameters right.
    ``scenarios``: ``varied`` draws the records' scenario from the seed, ``fixed`` keeps the
    development set-up."""
    import numba

    numba.set_num_threads(1)        # one process per core: no threads within it
    vessel = get_vessel("mariner")
    scenario = draw_scenario(seed, cause) if scenarios == "varied" else None
    records, truth = hidden_records(vessel, cause, seed=seed, noise=noise, noise_family=family,
                                    missing=missing, scenario=scenario)
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        paths = write_records(records, tmp)
        with initialize_config_module("studies.conf", version_base="1.3"):
            # a propeller's side force is judged against the symmetric baseline
            model = ["model=symmetric"] if "propeller_asymmetry" in cause.split("+") else []
            cfg = compose_settings("discover", overrides=[f"data.path=[{paths[0]},{paths[1]}]",
                                                 f"validate.path=[{paths[2]}]", f"seed={seed}", *model])
        t0 = time.perf_counter()
        d, _ = execute_discover(prepare_discover(cfg, tmp), tmp / "out")
        elapsed = time.perf_counter() - t0
    second = d.get("second_cause") or {}
    if "+" in cause:
        named = second.get("cause", d["cause"])
        hit = (set(named.split("+")) == set(cause.split("+"))
               and parameters_match(cause, second.get("parameters", {}), truth))
    else:
        named = d["cause"]
        hit = d["cause"] == cause and parameters_match(cause, d["parameters"], truth)
    return {"cause": cause, "noise": noise, "family": family, "seed": seed, "hit": bool(hit),
            "named": named, "second": second.get("cause"), "elapsed": elapsed,
            "scenario": repr(scenario) if scenario is not None else "fixed"}


def _setting(noise, family) -> str:
    """Key suffix of a noise level and family: ``noise=<n>``, with ``/<family>`` unless li2023 or noise 0."""
    return f"noise={noise:g}" if family == "li2023" or noise == 0 else f"noise={noise:g}/{family}"


def _jobs(causes, noises, families, seeds, base, missing="Nrrr", scenarios="fixed") -> list[tuple]:
    """(cause, seed, noise, family, missing, scenarios) per run; noise 0 once (every family leaves
    the records clean)."""
    settings = list(dict.fromkeys((n, "li2023" if n == 0 else f) for n in noises for f in families))
    return [(c, base + s, n, f, missing, scenarios) for c in causes for n, f in settings for s in range(seeds)]


def _confusion(results) -> dict:
    """{setting: {true cause: {named cause: count}}}."""
    out = {}
    for r in results:
        row = out.setdefault(_setting(r["noise"], r["family"]), {}).setdefault(r["cause"], {})
        row[r["named"]] = row.get(r["named"], 0) + 1
    return out


def _second_cause_rate(results):
    """Fraction of runs with one cause hidden and named first that name a second cause (None: no run)."""
    right = [r for r in results if r["cause"] != "none" and "+" not in r["cause"] and r["named"] == r["cause"]]
    return float(np.mean([r["second"] is not None for r in right])) if right else None


def _manoeuvring_figures(results) -> dict:
    out = {"discover_one_600s_records_s_median": float(np.median([r["elapsed"] for r in results])),
           "discover_confusion": _confusion(results),
           "discover_second_cause_rate": _second_cause_rate(results)}
    settings = list(dict.fromkeys(_setting(r["noise"], r["family"]) for r in results))
    for setting in settings:
        runs = [r for r in results if _setting(r["noise"], r["family"]) == setting]
        out[f"discover_second_cause_rate/{setting}"] = _second_cause_rate(runs)
        for cause in dict.fromkeys(r["cause"] for r in runs):
            out[f"discover_hit_rate/{cause}/{setting}"] = float(np.mean([r["hit"] for r in runs
                                                                         if r["cause"] == cause]))
    return out


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
    families = [f.strip() for f in os.environ.get("STUDIES_BENCH_FAMILIES", "li2023").split(",") if f.strip()]
    for family in families:
        check_sensor_noise(family, 0.0)
    base = HELDOUT_SEED if os.environ.get("STUDIES_BENCH_HELDOUT", "0") == "1" else DEVELOPMENT_SEED
    base = int(os.environ.get("STUDIES_BENCH_SEED_BASE", base))
    missing = os.environ.get("STUDIES_BENCH_MISSING", "Nrrr")
    scenarios = os.environ.get("STUDIES_BENCH_SCENARIOS", "varied")
    if scenarios not in ("varied", "fixed"):
        raise ValueError(f"STUDIES_BENCH_SCENARIOS must be varied or fixed, got {scenarios!r}")
    pairs = os.environ.get("STUDIES_BENCH_PAIRS", "0")
    causes = list(HIDDEN_CAUSES) + (hidden_pairs() if pairs == "1" else
                                    [p for p in pairs.split(",") if "+" in p])
    jobs = _jobs(causes, noises, families, seeds, base, missing, scenarios)
    out = {"discover_seeds_per_cause": seeds, "discover_seed_base": base, "discover_noise_families": families,
           "discover_missing_term": missing, "discover_scenarios": scenarios}
    if jobs:        # STUDIES_BENCH_SEEDS=0 leaves the manoeuvring causes out
        out.update(_manoeuvring_figures(Parallel(n_jobs=-1)(delayed(_one)(*job) for job in jobs)))
    roll_seeds = int(os.environ.get("STUDIES_BENCH_ROLL_SEEDS", "10"))
    if roll_seeds < 1:
        return out
    roll = Parallel(n_jobs=-1)(delayed(_one_roll)(c, base + s, n) for c in HIDDEN_ROLL_CAUSES
                               for n in (0.01, 0.05) for s in range(roll_seeds))
    for cause in HIDDEN_ROLL_CAUSES:
        for n in (0.01, 0.05):
            hits = [r[2] for r in roll if r[0] == cause and r[1] == n]
            out[f"discover_hit_rate/{cause}/noise={n:g}"] = float(np.mean(hits))
    return out
