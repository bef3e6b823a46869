"""One 40 001-step RK4 zig-zag 20/20 of the full Mariner model (4000 s at 0.1 s).

Reports the median of repeated back-to-back runs of the compiled integrator alone
(``sim_40001_steps_ms``) and of the whole ``simulate`` call that also builds
the record (``simulate_record_40001_ms``), after a warm-up that compiles.
"""

import time

import numpy as np

from studies.models import abkowitz
from studies.simulate import simulate, zigzag
from studies.simulate.integrator import rk4_simulate
from studies.simulate.simulator import prepare
from studies.vessels import get_vessel


def run(repeats: int = 21) -> dict:
    vessel = get_vessel("mariner")
    model = abkowitz()
    man = zigzag(20, 20, duration=4000.0, dt=0.1)
    inputs = prepare(model, vessel, man, None, None, -1.0)
    coef = model.vector(vessel.coefficients)
    states, _ = rk4_simulate(coef, *inputs.args())
    assert states.shape[0] == 40001
    core, whole = [], []
    for _ in range(repeats):
        t0 = time.perf_counter()
        rk4_simulate(coef, *inputs.args())
        core.append(time.perf_counter() - t0)
    for _ in range(repeats):
        t0 = time.perf_counter()
        simulate(model, vessel.coefficients, vessel, man)
        whole.append(time.perf_counter() - t0)
    return {"sim_40001_steps_ms": 1000 * float(np.median(core)),
            "simulate_record_40001_ms": 1000 * float(np.median(whole))}
