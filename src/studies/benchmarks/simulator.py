"""One 40 001-step RK4 zig-zag 20/20 of the full Mariner model (4000 s at 0.1 s).

Reports the median of repeated back-to-back runs of the compiled integrator alone
(``sim_40001_steps_ms``) and of the whole ``simulate`` call that also builds
the record (``simulate_record_40001_ms``), after a warm-up that compiles.
``sim_mmg_40001_steps_ms`` is the same zig-zag with the compiled MMG simulator
of the KVLCC2 (full scale, published coefficients, constant propeller rate;
absent when the shared KVLCC2 MMG data are not there).
"""

import time

import numpy as np

from studies.models import abkowitz
from studies.models.mmg import mmg
from studies.simulate import simulate, zigzag
from studies.simulate.integrator import rk4_simulate
from studies.simulate.mmg import YAW_SIGN, hull_vector, mmg_inputs, rk4_mmg
from studies.simulate.simulator import prepare
from studies.vessels import get_vessel
from studies.vessels.kvlcc2_mmg import DEFAULT_DATA_DIR, kvlcc2_mmg


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
    out = {"sim_40001_steps_ms": 1000 * float(np.median(core)),
           "simulate_record_40001_ms": 1000 * float(np.median(whole))}
    if (DEFAULT_DATA_DIR / "ship_data.yml").is_file():
        out["sim_mmg_40001_steps_ms"] = _mmg(man, repeats)
    return out


def _mmg(man, repeats: int) -> float:
    """Median time [ms] of the compiled MMG RK4 alone over the same zig-zag."""
    ship = kvlcc2_mmg(full_scale=True)
    k, a = mmg_inputs(ship)
    hull = hull_vector(mmg(), ship.coefficients)
    mode, cmd, params = man.rudder_programme(YAW_SIGN)
    x0 = np.array([ship.speed, 0, 0, 0, 0, 0, 0], dtype=float)
    args = (hull, k, a, x0, man.step, cmd, mode, params, ship.rps, ship.speed)
    states, diverged = rk4_mmg(*args)
    assert states.shape[0] == 40001 and diverged < 0
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        rk4_mmg(*args)
        times.append(time.perf_counter() - t0)
    return 1000 * float(np.median(times))
