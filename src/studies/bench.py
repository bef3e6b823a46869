"""``studies bench``: run the benchmarks of :mod:`studies.benchmarks` and collect their figures.

Each module of :mod:`studies.benchmarks` defines ``run() -> dict`` of named
figures (DESIGN.md: ``sim_40001_steps_ms``, ``ga_200_generations_s``,
``bayes_regression_s``, ``sweep_thesis_s``). Figures are medians or single
timings on the machine at hand; compare ratios within one run. The
benchmarks ship inside the package, so ``studies bench`` works from an
installed wheel as from the source tree.
"""

from __future__ import annotations

import importlib
import os
import platform
import time

from .benchmarks import NAMES
from .errors import ConfigError

__all__ = ["run_benchmarks", "BENCH_HELP"]

BENCH_HELP = f"""studies bench [NAME ...]: performance figures as JSON (every benchmark but those run on request, or those named)

  names: {', '.join(NAMES)} (sweep: on request only, it takes minutes)
  studies bench simulator ga        two of them
  studies bench discover key=value  hit rates of studies discover with intervals (studies bench discover --help)
"""


def _module(name: str):
    return importlib.import_module(f"studies.benchmarks.{name}")


def run_benchmarks(names: list[str] | None = None) -> dict:
    """Run the named benchmarks (all but those run on request when empty) and merge their figures.

    Raises
    ------
    ConfigError
        A name that is not a benchmark of :data:`studies.benchmarks.NAMES`.
    """
    wanted = [n.removeprefix("bench_").removesuffix(".py") for n in names or []]
    unknown = sorted(set(wanted) - set(NAMES))
    if unknown:
        raise ConfigError(f"unknown benchmark {', '.join(unknown)}; known: {', '.join(NAMES)}")
    chosen = wanted or [n for n in NAMES if not getattr(_module(n), "ON_REQUEST", False)]
    out = {"machine": {"cpus": os.cpu_count(), "python": platform.python_version(),
                       "processor": platform.processor() or platform.machine()}}
    for name in chosen:
        module = _module(name)
        t0 = time.perf_counter()
        figures = module.run()
        figures[f"bench_{name}_wall_s"] = time.perf_counter() - t0
        out.update(figures)
    return out
