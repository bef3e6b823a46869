"""emcee on the 40-coefficient regression of the 4000 s zig-zag (about 40 000
rows), 10 000 posterior samples per DOF after burn-in, default settings."""

import time

from studies.identification import BayesianRegression, build_problems
from studies.models import abkowitz
from studies.simulate import simulate, zigzag
from studies.vessels import get_vessel


def run() -> dict:
    vessel = get_vessel("mariner")
    model = abkowitz()
    rec = simulate(model, vessel.coefficients, vessel, zigzag(20, 20, duration=4000.0))
    problems = build_problems(model, vessel, rec)
    t0 = time.perf_counter()
    result = BayesianRegression(n_samples=10000, seed=0).fit(problems)
    elapsed = time.perf_counter() - t0
    return {"bayes_regression_s": elapsed,
            "bayes_rows": float(problems["X"].n_rows),
            "bayes_converged_dofs": float(sum(result.metrics.get(f"bayes/{d}/converged", 0.0)
                                              for d in "XYN"))}
