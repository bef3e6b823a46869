"""Ship manoeuvring studies: identify a manoeuvring model's hydrodynamic
coefficients from simulated or measured records, predict with it, and find
what it gets wrong on measured records.

The same studies as the ``studies`` command line, from Python (a notebook):

    load(source, vessel=None)            records from files (MARIN/HSVA .dat, CSV, Parquet) or DataFrames
    identify(records=None, validate=None, model=..., method=..., **settings)
                                         identify a model (studies run): an Identified
    discover(train, validate=None, model="mmg", **settings)
                                         name what the model gets wrong (studies discover): a Discovered
    sweep(grid, records=None, **settings)
                                         one job per combination of settings (studies run -m): a Sweep
    settings(command="run", **settings)  the command line's typed settings for these keywords

    Identified   .coefficients (DataFrame with intervals), .metrics, .simulate(manoeuvre),
                 .replay(record), .characteristics(what), .plot(what) (a matplotlib Figure),
                 .bands (the held-out records' predictive bands, method="bayes")
    Discovered   the verdict (discovery.json as a mapping): .cause, .confidence, .members,
                 .parameters, .gain_pct, .report (the page, Markdown)
    ConfigError, DataError   what a bad setting or record raises (one line)

Settings are the command line's (``studies run --help``): a config group's
option as a string (``model="mmg"``), a group's settings as a dict or with
``__`` (``wind={"speed": 12}``, ``wind__speed=12``). Nothing is logged to
MLflow unless a run is active (``with mlflow.start_run():``) or
``track=True``. Units: SI, angles in radians in the data, coefficients in
the prime system. Walk-through: docs/python.md.
"""

from __future__ import annotations

__all__ = ["load", "identify", "discover", "sweep", "settings", "Identified", "Discovered", "Sweep",
           "ConfigError", "DataError"]

#: where each public name lives: imported on first use (``import studies`` stays light)
_EXPORTS = {
    "load": "studies.api.records:load",
    "identify": "studies.api.identified:identify",
    "discover": "studies.api.discovered:discover",
    "sweep": "studies.api.sweeps:sweep",
    "settings": "studies.api.settings:typed_settings",
    "Identified": "studies.api.identified:Identified",
    "Discovered": "studies.api.discovered:Discovered",
    "Sweep": "studies.api.sweeps:Sweep",
    "ConfigError": "studies.errors:ConfigError",
    "DataError": "studies.errors:DataError",
}


def __getattr__(name: str):
    target = _EXPORTS.get(name)
    if target is None:
        raise AttributeError(f"module 'studies' has no attribute {name!r}")
    import importlib

    module, _, attribute = target.partition(":")
    value = getattr(importlib.import_module(module), attribute)
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(__all__))
