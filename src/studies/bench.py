"""``studies bench``: run the benchmarks of ``benchmarks/`` and collect their figures.

Each ``benchmarks/bench_*.py`` defines ``run() -> dict`` of named figures
(DESIGN.md: ``sim_40001_steps_ms``, ``ga_200_generations_s``,
``bayes_regression_s``, ``sweep_thesis_s``). Figures are medians or single
timings on the machine at hand; compare ratios within one run.
"""

from __future__ import annotations

import importlib.util
import os
import platform
import time
from pathlib import Path

__all__ = ["run_benchmarks", "benchmark_dir", "BENCH_HELP"]

BENCH_HELP = """studies bench [NAME ...]: performance figures as JSON (every benchmarks/bench_NAME.py, or those named)

  studies bench simulator ga        two of them
  studies bench discover key=value  hit rates of studies discover with intervals (studies bench discover --help)
"""


def benchmark_dir() -> Path:
    """``benchmarks/`` of the source tree (editable install) or of the working directory."""
    for candidate in (Path(__file__).resolve().parents[2] / "benchmarks", Path.cwd() / "benchmarks"):
        if candidate.is_dir():
            return candidate
    raise FileNotFoundError("no benchmarks/ directory next to the source tree or in the working directory")


def run_benchmarks(names: list[str] | None = None) -> dict:
    """Run ``bench_<name>.py`` for each name (all when empty) and merge their figures."""
    folder = benchmark_dir()
    files = sorted(folder.glob("bench_*.py"))
    if names:
        wanted = {n.removeprefix("bench_").removesuffix(".py") for n in names}
        known = {f.stem.removeprefix("bench_") for f in files}
        unknown = sorted(wanted - known)
        if unknown:
            raise ValueError(f"unknown benchmark {', '.join(unknown)}; known: {', '.join(sorted(known))}")
        files = [f for f in files if f.stem.removeprefix("bench_") in wanted]
    out = {"machine": {"cpus": os.cpu_count(), "python": platform.python_version(),
                       "processor": platform.processor() or platform.machine()}}
    for path in files:
        spec = importlib.util.spec_from_file_location(path.stem, path)
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        t0 = time.perf_counter()
        figures = module.run()
        figures[f"{path.stem}_wall_s"] = time.perf_counter() - t0
        out.update(figures)
    return out
