"""``studies.sweep``: what ``studies run -m`` does, from Python, as a table.

One job per combination of the swept values, run one after another in this
process (imports and compiled code are paid once). Each job is what
:func:`studies.identify` (or :func:`studies.discover`) runs with the fixed
settings and its combination; the table has one row per job: the swept
values, the run id when tracked, and the job's metrics. Tracked jobs
(``track=True``, or an active MLflow run) each get a run of their own, the
active run's children when there is one (MLflow's ``mlflow.parentRunId``),
as the command line's sweeps are children of their sweep's run.
"""

from __future__ import annotations

import itertools

import pandas as pd

from ..errors import ConfigError

__all__ = ["sweep", "Sweep"]


class Sweep:
    """The jobs of a sweep: ``table`` (one row each), ``results`` (the
    :class:`~studies.api.identified.Identified` or
    :class:`~studies.api.discovered.Discovered` objects, in order)."""

    def __init__(self, table: pd.DataFrame, results: list):
        self.table = table
        self.results = results

    def _repr_html_(self) -> str:
        return self.table._repr_html_()

    def __repr__(self) -> str:
        return f"<Sweep of {len(self.results)} jobs>\n{self.table!r}"


def sweep(grid: dict, records=None, validate=None, *, command: str = "run", track: bool | None = None,
          **settings) -> Sweep:
    """Run one job per combination of ``grid``'s values.

    Parameters
    ----------
    grid : dict
        Setting -> list of values (``{"wind.speed": [0, 8, 16], "method": ["ls", "svm"]}``;
        keys as for :func:`studies.identify`'s settings, dots or ``__``).
    records, validate
        As for :func:`studies.identify` (for ``command="discover"``: ``train``, ``validate``).
    command : str
        ``run`` (identify) or ``discover``.
    track : bool or None
        As for :func:`studies.identify`; tracked jobs get a run each.
    **settings
        Fixed settings of every job.
    """
    if command not in ("run", "discover"):
        raise ConfigError(f"command: 'run' or 'discover', got {command!r}")
    if not grid or any(not isinstance(v, (list, tuple)) or not v for v in grid.values()):
        raise ConfigError("grid: setting -> a non-empty list of values")
    from ..runtime.tracking import active_run

    parent = active_run() if track is not False else None
    keys = list(grid)
    rows, results = [], []
    for values in itertools.product(*(grid[k] for k in keys)):
        job = dict(zip(keys, values))
        kwargs = {**settings, **{k.replace(".", "__"): v for k, v in job.items()}}
        if parent is not None:                 # a child run per job (MLflow's nested runs)
            import mlflow

            with mlflow.start_run(nested=True, experiment_id=parent.info.experiment_id):
                result = _run(command, records, validate, None, kwargs)
        else:
            result = _run(command, records, validate, track, kwargs)
        results.append(result)
        metrics = {k: v for k, v in result.metrics.items() if isinstance(v, (int, float))}
        rows.append({**job, "run_id": result.run_id, **metrics})
    return Sweep(pd.DataFrame(rows), results)


def _run(command: str, records, validate, track, kwargs: dict):
    from .discovered import discover
    from .identified import identify

    if command == "run":
        return identify(records, validate, track=track, **kwargs)
    return discover(records, validate, track=track, **kwargs)
