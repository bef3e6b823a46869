"""``studies.identify``: a model identified from records (or from a simulated
study), as an object to look at, simulate and compare in a notebook.

The identification is the command line's own job (:mod:`studies.api.jobs`):
``studies.identify(records, model="mmg")`` and ``studies run model=mmg
data.path=[...]`` give the same coefficients and metrics.
"""

from __future__ import annotations

import math

import pandas as pd

from ..errors import ConfigError

__all__ = ["identify", "Identified"]


class Identified:
    """An identified model, what it was identified from and how it predicts.

    Attributes
    ----------
    coefficients : DataFrame
        One row per coefficient (index ``name``): ``value`` (prime system,
        SAE/ITTC axes, rudder positive to port), ``lower``/``upper`` (the
        method's interval where it gives one, else NaN), and ``true``,
        ``deviation_pct`` for a simulated study whose truth is known.
    metrics : dict
        The run's flat metrics (``metrics.json``): per validation record or
        manoeuvre, fitness (thesis eq. 3.43), position RMSE [m], advance and
        tactical diameter errors [%], overshoot errors [deg]; CPU times [s].
    model : IdentifiedModel or None
        The simulable model (``identified_model.json``); None for a roll decay.
    settings : RunConfig
        The typed settings the identification ran with.
    name, run_id, model_uri : str or None
        The run's name; its MLflow run and logged model when tracked.
    directory : Path
        The folder holding the run's files (a temporary one when untracked
        and no ``out_dir`` was given: it goes with this object).
    training, validation : list of DataFrame
        The records identified from and predicted (measured studies), at the
        scale the study worked at.
    bands : DataFrame
        The held-out records' predictive bands when the method draws them.
    """

    def __init__(self, job, settings, place):
        from ..workflows.identified_model import IDENTIFIED_MODEL_FILE, IdentifiedModel

        self.settings = settings
        self.name = job.name
        self.run_id = job.run_id
        self.model_uri = (job.logged or {}).get("uri")
        self.metrics = dict(job.metrics)
        self.directory = place.out_dir
        table = self.directory / "coefficients.csv"
        self.coefficients = pd.read_csv(table).set_index("name") if table.is_file() else pd.DataFrame()
        path = self.directory / IDENTIFIED_MODEL_FILE
        self.model = IdentifiedModel.read(path) if path.is_file() else None
        prepared = job.prepared
        self.training = list(getattr(prepared, "records", []) or [])
        self.validation = list(getattr(prepared, "validation_records", []) or [])
        self._simulated = not settings.data.path

    # ------------------------------------------------------------ prediction

    def _simulable(self):
        if self.model is None:
            raise ConfigError(f"{self.settings.model.name}: this model has no simulator here "
                              "(roll decays: see the run's decay figures and metrics)")
        return self.model

    def simulate(self, manoeuvre="turning_35", **settings) -> pd.DataFrame:
        """A manoeuvre simulated as a run validates: a name of ``conf/manoeuvre/``
        (``turning_35``, ``zigzag_20_20``, the user's own) with its settings
        replaced by ``settings`` (``duration=600.0`` [s], ``rudder_deg=25``), or a
        :class:`~studies.simulate.Manoeuvre`. States in the data contract."""
        from ..simulate.manoeuvres import Manoeuvre
        from ..workflows.settings import named_manoeuvre

        model = self._simulable()
        if isinstance(manoeuvre, Manoeuvre):
            if settings:
                raise ConfigError("simulate: settings go with a manoeuvre's name, not a Manoeuvre")
            return model.simulate(manoeuvre)
        return model.simulate(named_manoeuvre(str(manoeuvre), settings))

    def replay(self, record) -> pd.DataFrame:
        """A record's own rudder (and propeller rate) replayed from its first state
        (the record at the model's scale; a path is read with :func:`studies.load`)."""
        from .records import load

        if not isinstance(record, pd.DataFrame):
            record = load(record)
        return self._simulable().replay(record)

    def characteristics(self, what="turning_35") -> pd.DataFrame:
        """Advance and tactical diameter [m] of a turn, overshoots [deg] of a zig-zag.

        ``what`` is a manoeuvre's name (the model's prediction alone) or a
        record (its replay beside the record: ``predicted``, ``measured``,
        ``error``, ``error_pct``)."""
        from ..analysis.characteristics import characteristics

        if isinstance(what, pd.DataFrame) or not isinstance(what, str):
            record = what if isinstance(what, pd.DataFrame) else None
            if record is None:
                from .records import load
                record = load(what)
            predicted = characteristics(self.replay(record))
            measured = characteristics(record)
            rows = {k: {"predicted": v, "measured": measured.get(k, math.nan)} for k, v in predicted.items()
                    if isinstance(v, (int, float))}
            table = pd.DataFrame(rows).T
            table["error"] = table["predicted"] - table["measured"]
            table["error_pct"] = 100.0 * table["error"] / table["measured"].abs()
            return table
        values = characteristics(self.simulate(what))
        return pd.DataFrame({"predicted": {k: v for k, v in values.items() if isinstance(v, (int, float))}})

    @property
    def bands(self) -> pd.DataFrame:
        """The predictive bands of the held-out records (``method="bayes"`` with
        ``validate`` records, or roll decays held out): one row per record, one
        column per statistic the run logged (``coverage_50`` ... ``coverage_95``,
        width, interval score, CRPS, ``trusted``, ``outside_training``; units as in
        ``docs/outputs.md``). Empty when the run drew no bands."""
        rows: dict = {}
        for key, value in self.metrics.items():
            record, sep, statistic = key.partition("/band/")
            if sep and "/" not in statistic:
                rows.setdefault(record, {})[statistic] = value
        return pd.DataFrame.from_dict(rows, orient="index").rename_axis("record")

    # ---------------------------------------------------------------- figures

    def plot(self, what=None):
        """A figure (matplotlib ``Figure``, not written anywhere): the track
        (north against east [m]), heading and rudder [deg] against time [s].

        ``what``: a record (measured beside its replay), a manoeuvre's name
        (the model's prediction), or None: the first validation record of a
        measured study, else ``turning_35``."""
        import numpy as np
        from matplotlib.figure import Figure

        if what is None:
            what = self.validation[0] if self.validation else "turning_35"
        if isinstance(what, pd.DataFrame):
            measured, predicted = what, self.replay(what)
            title = str(what.attrs.get("name", "record"))
        else:
            measured, predicted, title = None, self.simulate(what), str(what)
        fig = Figure(figsize=(10, 4.8), layout="constrained")
        axes = fig.subplot_mosaic([["track", "psi"], ["track", "delta"]])
        for frame, label, style in ((measured, "measured", "k-"), (predicted, "identified", "C1-")):
            if frame is None:
                continue
            axes["track"].plot(frame["y0"], frame["x0"], style, lw=1, label=label)
            axes["psi"].plot(frame["t"], np.degrees(frame["psi"]), style, lw=1)
            axes["delta"].plot(frame["t"], np.degrees(frame["delta"]), style, lw=1)
        axes["track"].set(xlabel="east y0 [m]", ylabel="north x0 [m]", aspect="equal", title=title)
        axes["track"].legend(loc="best", fontsize=8)
        axes["psi"].set(ylabel="heading [deg]")
        axes["delta"].set(xlabel="t [s]", ylabel="rudder [deg]")
        return fig

    # ---------------------------------------------------------------- display

    def _repr_markdown_(self) -> str:
        from ..console import run_lines
        from ..markdown import markdown_table

        where = f"run `{self.run_id}`" if self.run_id else "not logged (track=True, or an active MLflow run, logs it)"
        head = (f"**{self.name}**: {self.settings.model.name} model by {self.settings.method.name}, "
                f"vessel {self.settings.vessel.name}; {where}")
        table = self.coefficients.dropna(axis=1, how="all")
        trained = set(self.settings.train.manoeuvres or [self.settings.manoeuvre.name]) if self._simulated else set()
        lines = run_lines(self.metrics, trained)
        body = markdown_table(table, "name") if not table.empty else "(no coefficient table)"
        return head + "\n\n" + body + "\n\n```\n" + "\n".join(lines) + "\n```\n"

    def _repr_html_(self) -> str:
        from markdown_it import MarkdownIt

        return MarkdownIt("commonmark", {"html": False}).enable("table").render(self._repr_markdown_())

    def __repr__(self) -> str:
        return f"<Identified {self.name!r}: {len(self.coefficients)} coefficients, run {self.run_id}>"


def identify(records=None, validate=None, *, model: str | None = None, method: str | None = None,
             vessel: str | None = None, track: bool | None = None, out_dir=None, overrides=(),
             **settings) -> Identified:
    """Identify a model: what ``studies run`` does, from Python.

    Parameters
    ----------
    records : path, DataFrame or list of them, optional
        Training records (``data.path``); :func:`studies.load`'s frames or
        the user's own in the data contract. None: the simulated study of the
        settings (the README's main job with the defaults: the Mariner's
        20/20 zig-zag, least squares).
    validate : path, DataFrame or list of them, optional
        Records to predict (``validate.path``).
    model, method, vessel : str, optional
        Options of the config groups (``model="mmg"``, ``method="bayes"``,
        ``vessel="kvlcc2"``); the vessel defaults to what :func:`studies.load`
        was told, else to what the records' files say.
    track : bool or None
        Where results are logged (:mod:`studies.api.where`): None logs to the
        active MLflow run if there is one, True also opens a run, False never logs.
    out_dir : path, optional
        Folder for the run's files (default: a temporary one when untracked).
    overrides : list of str
        Command-line overrides as written (``["wind.speed=12"]``).
    **settings
        Any other setting, as a dict per group or with ``__``
        (``noise={"measurement": 0.01}``, ``kalman__iterations=3``).

    Returns
    -------
    Identified
        Bad settings or records raise the command line's one-line
        :class:`~studies.errors.ConfigError` or :class:`~studies.errors.DataError`
        before anything is logged.
    """
    from .jobs import run_identification
    from .records import as_paths, vessel_of
    from .where import where

    place = where(track, out_dir)
    with place.removed_on_failure():
        given = {"model": model, "method": method, "vessel": vessel or vessel_of(records, validate)}
        if records is not None:
            given["data.path"] = as_paths(records, place.out_dir, "records")
        if validate is not None:
            given["validate.path"] = as_paths(validate, place.out_dir, "validate")
        typed, params = place.settings("run", given, settings, overrides)
        digest = None
        if place.tracked:
            from ..runtime.resume import config_hash

            digest = config_hash(params, place.root)
        with place.figures():
            job = run_identification(typed, params, place.root, place.out_dir, place.opener(typed),
                                     "studies.identify", digest, place.tracked)
    return place.tie(Identified(job, typed, place))
