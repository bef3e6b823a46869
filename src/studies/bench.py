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

__all__ = ["run_benchmarks", "benchmark_dir"]


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
