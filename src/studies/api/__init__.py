"""The Python interface of ``studies`` (what ``import studies`` offers) and the
jobs it shares with the command line.

``settings.py``   keyword arguments -> the command line's typed settings (same checks, same errors)
``records.py``    records from files or DataFrames, and DataFrames handed to a job as files
``jobs.py``       one identification or discovery job: what ``studies run`` and
                  ``studies discover`` do, with the run they log to chosen by the caller
``identified.py`` :func:`identify` and the :class:`Identified` model it returns
``discovered.py`` :func:`discover` and the :class:`Discovered` verdict it returns
``sweeps.py``     :func:`sweep`: what ``-m`` does, one job per combination, as a table
``where.py``      where a Python call writes and logs (MLflow's conventions)
"""
