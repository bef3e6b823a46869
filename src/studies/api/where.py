"""Where a Python call writes and logs, by MLflow's conventions.

``track=None`` (the default)
    inside an active ``mlflow.start_run()``: the study is logged to that run
    (params, tags, metrics, files, the model, the records as datasets: what
    the command line logs); with no active run: nothing is logged.
``track=True``
    the active run if there is one, else a new run in the store of
    ``tracking.uri`` (``mlruns/`` under the working directory by default),
    as ``studies run`` would open.
``track=False``
    nothing is logged, even inside an active run.

``out_dir``: the folder the study writes its files into (tables, figures,
``identified_model.json``). Not given: a tracked study writes where the
command line would (``outputs/<date>/<time>/``); an untracked one writes
into a temporary folder, removed with the result, and draws no figures
(``.plot()`` makes them on demand).
"""

from __future__ import annotations

import contextlib
import shutil
import tempfile
import weakref
from datetime import datetime
from pathlib import Path

__all__ = ["Where", "where"]


class Where:
    """The choice for one call: ``tracked``, ``out_dir``, ``opener(settings, root)``."""

    def __init__(self, track: bool | None, out_dir, root: Path):
        from ..runtime.tracking import active_run

        self.root = Path(root)
        self.active = active_run() if track is not False else None
        self.tracked = self.active is not None or track is True
        self.temporary = out_dir is None and not self.tracked
        if out_dir is not None:
            self.out_dir = Path(out_dir).expanduser().resolve()
        elif self.tracked:
            now = datetime.now()
            self.out_dir = self.root / "outputs" / now.strftime("%Y-%m-%d") / now.strftime("%H-%M-%S-%f")
        else:
            self.out_dir = Path(tempfile.mkdtemp(prefix="studies-"))
        self.out_dir.mkdir(parents=True, exist_ok=True)

    def opener(self, settings, on_create=None):
        """``open_run(name, params, tags)`` for :mod:`studies.api.jobs`."""
        from ..runtime import tracking

        def open_run(name: str, params: dict, tags: dict):
            if self.active is not None:
                return tracking.into_active_run(params, tags)
            if self.tracked:
                return tracking.start_run(settings.tracking.experiment, name, settings.tracking.uri,
                                          self.root, params, tags, on_create=on_create)
            return contextlib.nullcontext(tracking.Untracked())

        return open_run

    def settings(self, command: str, given: dict, settings: dict, overrides=()):
        """``(typed, params)`` of the job (:func:`studies.api.settings.compose`), its
        configuration kept beside its files, where it writes and logs checked."""
        from ..config.paths import check_output_paths
        from ..runtime import tracking
        from .settings import compose, overrides_of

        typed, params = compose(command, {**given, **settings}, overrides, self.root)
        self.keep_config(params, overrides_of({**given, **settings}, overrides))
        check_output_paths(typed, self.root, self.out_dir)
        if self.tracked and self.active is None:
            tracking.check_store(typed.tracking.uri, self.root)
        return typed, params

    @contextlib.contextmanager
    def removed_on_failure(self):
        """A temporary folder is removed when the job fails (nothing is left behind)."""
        try:
            yield
        except BaseException:
            if self.temporary:
                shutil.rmtree(self.out_dir, ignore_errors=True)
            raise

    def keep_config(self, params: dict, overrides: list) -> None:
        """A tracked study's configuration beside its files, as the command line keeps it
        (``.hydra/config.yaml``, ``.hydra/overrides.yaml``, logged as the ``hydra/`` artifacts)."""
        if not self.tracked:
            return
        import yaml

        folder = self.out_dir / ".hydra"
        folder.mkdir(exist_ok=True)
        (folder / "config.yaml").write_text(yaml.safe_dump(params, sort_keys=False))
        (folder / "overrides.yaml").write_text(yaml.safe_dump([str(o) for o in overrides]))

    def figures(self):
        """The figures of the job: drawn when they are kept, skipped in a temporary folder."""
        from ..plotting import DRAWER

        return DRAWER.skipping() if self.temporary else contextlib.nullcontext()

    def tie(self, result):
        """A temporary folder lives as long as ``result`` (returned)."""
        if self.temporary:
            weakref.finalize(result, shutil.rmtree, str(self.out_dir), True)
        return result


def where(track: bool | None, out_dir, root=None) -> Where:
    """:class:`Where` for one call (``root``: the working directory by default)."""
    return Where(track, out_dir, Path.cwd() if root is None else root)
