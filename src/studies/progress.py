"""Sweep progress: which job is running and how many are left.

A Hydra callback. In the launching process it counts the jobs of the sweep
(the product of the swept values) and passes the count to the jobs through
the environment; each job then prints ``[studies] job 3/16 started: ...`` and
``[studies] job 3/16 finished in 12.3 s`` (or ``failed in 2.1 s: <error>``, or
``skipped: already finished as run <id>`` with ``resume=true``) on stderr.
"""

from __future__ import annotations

import os
import sys
import time

from hydra.experimental.callback import Callback

from .stages import QUIET_ENV

__all__ = ["SweepProgress", "count_jobs"]

ENV_TOTAL = "STUDIES_SWEEP_JOBS"


def count_jobs(overrides: list[str]) -> int | None:
    """Number of jobs of a basic sweep over ``overrides`` (None if unknown)."""
    try:
        from hydra.core.override_parser.overrides_parser import OverridesParser

        parsed = OverridesParser.create().parse_overrides(overrides)
    except Exception:
        return None
    total = 1
    for o in parsed:
        if o.is_sweep_override():
            try:
                total *= len(list(o.sweep_string_iterator()))
            except Exception:
                return None
    return total


class SweepProgress(Callback):
    """Prints job start/end lines with the job's number out of the sweep's."""

    def on_multirun_start(self, config, **kwargs) -> None:
        overrides = list(config.hydra.overrides.task)
        params = config.hydra.sweeper.get("params") or {}
        overrides += [f"{k}={v}" for k, v in params.items()
                      if not any(o.split("=")[0].lstrip("+~") == k for o in overrides)]
        total = count_jobs(overrides)
        # the jobs print their start and end, not their stages
        os.environ[QUIET_ENV] = "1"
        if total:
            os.environ[ENV_TOTAL] = str(total)
            print(f"[studies] sweep of {total} jobs", file=sys.stderr, flush=True)

    def on_job_start(self, config, **kwargs) -> None:
        self._t0 = time.perf_counter()
        num = config.hydra.job.get("num")
        if num is None:
            return
        total = os.environ.get(ENV_TOTAL, "?")
        overrides = " ".join(config.hydra.overrides.task)
        print(f"[studies] job {num + 1}/{total} started: {overrides}", file=sys.stderr, flush=True)

    def on_job_end(self, config, job_return, **kwargs) -> None:
        num = config.hydra.job.get("num")
        if num is None:
            return
        total = os.environ.get(ENV_TOTAL, "?")
        status = getattr(job_return, "status", None)
        failed = status is not None and status.name == "FAILED"
        # `studies run` jobs return {"status": finished|failed|skipped, ...} (studies.cli)
        outcome = {}
        if not failed:
            try:
                value = job_return.return_value
            except BaseException:  # noqa: BLE001 - the value is only read for the message
                value = None
            outcome = value if isinstance(value, dict) else {}
        elapsed = time.perf_counter() - getattr(self, "_t0", time.perf_counter())
        label = f"[studies] job {num + 1}/{total}"
        if outcome.get("status") == "skipped":
            print(f"{label} skipped: already finished as run {outcome.get('run_id')}",
                  file=sys.stderr, flush=True)
        elif failed or outcome.get("status") == "failed":
            error = outcome.get("error") or str(getattr(job_return, "_return_value", "")).split("\n")[0]
            print(f"{label} failed in {elapsed:.1f} s: {error}", file=sys.stderr, flush=True)
        else:
            print(f"{label} finished in {elapsed:.1f} s", file=sys.stderr, flush=True)
