"""``studies report report.compare=<paper>``: a paper's published tables beside the project's runs.

Each paper has a module here (:data:`REPRODUCTIONS`) that knows which MLflow
experiments (the presets of the paper) hold the project's runs, and turns
them and the published values (:mod:`studies.papers`) into sections of one
page: per table the published and the project's numbers side by side, sign
and trend agreement, magnitude ratios, and a sentence per disagreement with
its cause. The page opens with what the project substitutes for the paper
(ship, data, settings) and where its conventions differ. Like
:mod:`studies.report.builder` it reads the store only.

A paper module provides

``EXPERIMENTS``
    the MLflow experiments it reads (tuple of names);
``COMMANDS``
    the commands that make those runs (printed when they are missing);
``sections(runs, out) -> list of (title, markdown)``
    ``runs`` maps each experiment to its runs (:class:`StoredRun`, sweeps'
    parent runs left out); figures go into ``out``;
``substitutions(runs) -> list of str`` and ``conventions(runs) -> list of str``
    sentences for the page's opening.
"""

from __future__ import annotations

import shutil
from pathlib import Path

from ...errors import ConfigError
from ...papers import get_paper
from ..builder import _report_directory, _write_html
from . import li2023, roll_paper, svm_paper, thesis

__all__ = ["REPRODUCTIONS", "experiments", "build_reproduction"]

#: ``report.compare`` value -> the module that compares that paper
REPRODUCTIONS = {"thesis": thesis, "svm_paper": svm_paper, "roll_paper": roll_paper, "li2023": li2023}


def _module(paper_id: str):
    get_paper(paper_id)
    try:
        return REPRODUCTIONS[paper_id]
    except KeyError:
        raise ConfigError(f"report.compare: no reproduction of '{paper_id}'; known: "
                          f"{', '.join(sorted(REPRODUCTIONS))}") from None


def experiments(paper_id: str) -> tuple:
    """The MLflow experiments whose runs the comparison with ``paper_id`` reads."""
    return tuple(_module(paper_id).EXPERIMENTS)


def build_reproduction(paper_id: str, runs: dict, report_dir) -> Path:
    """Write ``<report_dir>/reproduce_<paper>/index.md`` (and ``index.html``).

    Parameters
    ----------
    paper_id : str
        ``thesis``, ``svm_paper`` (:data:`REPRODUCTIONS`).
    runs : dict
        ``{experiment: [StoredRun, ...]}`` for every experiment of
        :func:`experiments` (an empty list where the store has none).
    report_dir : path

    Returns
    -------
    Path of ``index.md``.
    """
    module = _module(paper_id)
    paper = get_paper(paper_id)
    out = _report_directory(Path(report_dir), f"reproduce_{paper_id}")
    if out.exists():
        shutil.rmtree(out)
    out.mkdir(parents=True)
    missing = [e for e in module.EXPERIMENTS if not runs.get(e)]
    lines = [f"# Reproduction: {paper.citation}", ""]
    counted = ", ".join(f"`{e}` ({len(runs.get(e) or [])} runs)" for e in module.EXPERIMENTS)
    lines += [f"The project's runs come from the MLflow experiments {counted}; the published values "
              f"from `studies/papers/` (table and page, or section, of each number in its file).", ""]
    if missing:
        lines += ["Experiments with no runs in the store (their sections are left out): "
                  + ", ".join(f"`{e}`" for e in missing) + ". The runs are made by:", ""]
        lines += [f"    {c}" for c in module.COMMANDS] + [""]
    sections = [("What the project substitutes for the paper",
                 "\n".join(f"- {s}" for s in module.substitutions(runs)) + "\n"),
                ("Where the conventions differ",
                 "\n".join(f"- {s}" for s in module.conventions(runs)) + "\n")]
    sections += module.sections(runs, out)
    md = "\n".join(lines) + "\n".join(f"\n## {title}\n\n{body}" for title, body in sections)
    (out / "index.md").write_text(md)
    _write_html(out / "index.html", f"reproduction of {paper_id}", md)
    return out / "index.md"
