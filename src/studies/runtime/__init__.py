"""What runs around a study: recording it and keeping a sweep in order.

- :mod:`~studies.runtime.tracking`: the MLflow store (the only module that
  imports mlflow): runs, their outputs, the experiments a report reads;
- :mod:`~studies.runtime.jobstate`: the state of a sweep's jobs shared
  between the launcher and its workers (results, runs left open, stopping);
- :mod:`~studies.runtime.resume`: the config hash that lets ``resume=true``
  skip finished jobs;
- :mod:`~studies.runtime.ui`: ``studies ui``, the MLflow UI on the store.
"""
