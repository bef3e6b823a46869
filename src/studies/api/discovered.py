"""``studies.discover``: what a model gets wrong on measured records, the cause,
the extension and its gain, from Python.

The discovery is the command line's own job (:mod:`studies.api.jobs`):
``studies.discover(train, validate, model="mmg")`` and ``studies discover
model=mmg data.path=[...] validate.path=[...]`` name the same cause with the
same numbers.
"""

from __future__ import annotations

from collections.abc import Mapping

__all__ = ["discover", "Discovered"]


class Discovered(Mapping):
    """A discovery's verdict: ``discovery.json`` as a read-only mapping, with names for what is read most.

    Keys are DESIGN.md's (``cause``, ``parameters`` with
    ``parameter_units``, ``confidence``, ``class``, ``class_probability``,
    ``gain_pct`` with ``gain_interval_pct``, ``detection_limits``,
    ``next_manoeuvre``, ``outside_training``, ...). The gain is measured on
    whole held-out replays; ``explains_validation`` is true only when the
    extension predicts no held-out characteristic worse.

    Attributes
    ----------
    metrics : dict
        The run's flat metrics.
    report : str
        The discovery's page (``report.md``), Markdown.
    directory : Path
        The folder of its files (figures when kept, ``settling/``).
    run_id : str or None
        The MLflow run when tracked.
    """

    def __init__(self, job, settings, place):
        self._data = dict(job.discovery)
        self.metrics = dict(job.metrics)
        self.name = job.name
        self.run_id = job.run_id
        self.settings = settings
        self.directory = place.out_dir
        page = self.directory / "report.md"
        self.report = page.read_text() if page.is_file() else ""

    def __getitem__(self, key):
        return self._data[key]

    def __iter__(self):
        return iter(self._data)

    def __len__(self) -> int:
        return len(self._data)

    @property
    def cause(self) -> str:
        """The verdict: a cause of the catalogue, ``none`` or ``outside_training_states``."""
        return self._data["cause"]

    @property
    def confidence(self):
        """The probability of the verdict (of its class when the class has more than one member)."""
        return self._data.get("confidence")

    @property
    def parameters(self) -> dict:
        """The named cause's fitted parameters (units in ``self["parameter_units"]``)."""
        return dict(self._data.get("parameters") or {})

    @property
    def members(self) -> list:
        """The class: the named cause first, then the causes the records cannot tell from it."""
        return list(self._data.get("class") or [self.cause])

    @property
    def gain_pct(self):
        """What the extension gains on the held-out records' whole replays [%]."""
        return self._data.get("gain_pct")

    def lines(self) -> list[str]:
        """The verdict as the command line prints it."""
        from ..console import discovery_lines

        return discovery_lines(self._data)

    def _repr_markdown_(self) -> str:
        where = f"run `{self.run_id}`" if self.run_id else "not logged"
        return (f"**{self.name}** ({where})\n\n```\n" + "\n".join(self.lines()) + "\n```\n\n"
                "The whole page: `.report` (Markdown).\n")

    def _repr_html_(self) -> str:
        from markdown_it import MarkdownIt

        return MarkdownIt("commonmark", {"html": False}).render(self._repr_markdown_())

    def __repr__(self) -> str:
        return f"<Discovered {self.cause!r} (confidence {self.confidence}) run {self.run_id}>"


def discover(train, validate=None, *, model: str | None = "mmg", vessel: str | None = None,
             simulation=None, track: bool | None = None, out_dir=None, overrides=(), **settings) -> Discovered:
    """Show what ``model`` gets wrong on measured records, name the cause, extend, measure the gain.

    Parameters
    ----------
    train : path, DataFrame or list of them
        Records the model is identified from and the causes fitted to (``data.path``).
    validate : path, DataFrame or list of them, optional
        Held-out records the verdict is judged on (``validate.path``);
        without them a share of ``train`` is held out (``discover.holdout``).
    model : str
        The baseline (``mmg``, ``abkowitz``, ``roll`` for roll decays).
    vessel : str, optional
        As for :func:`studies.identify`.
    simulation : path or DataFrame, optional
        Another simulator's run (``simulation.path``).
    track, out_dir, overrides, **settings
        As for :func:`studies.identify` (``discover={"injected": ...}``,
        ``discover__splits=3``).
    """
    from .jobs import run_discovery
    from .records import as_paths, vessel_of
    from .where import where

    place = where(track, out_dir)
    with place.removed_on_failure():
        given = {"model": model, "vessel": vessel or vessel_of(train, validate),
                 "data.path": as_paths(train, place.out_dir, "train")}
        if validate is not None:
            given["validate.path"] = as_paths(validate, place.out_dir, "validate")
        if simulation is not None:
            given["simulation.path"] = as_paths([simulation], place.out_dir, "simulation")[0]
        typed, params = place.settings("discover", given, settings, overrides)
        with place.figures():
            job = run_discovery(typed, params, place.root, place.out_dir, place.opener(typed),
                                "studies.discover", place.tracked)
    return place.tie(Discovered(job, typed, place))
