"""``studies report``: comparison pages from the MLflow runs of one experiment.

Everything comes from the store (run params, metrics, tags and artifacts),
so a report can be rebuilt on any machine that sees the store; the command
line reads the runs (:func:`studies.runtime.tracking.read_experiment`) and
hands them to :func:`build_report`. The page holds:

- the runs, with failed and killed ones marked as such;
- coefficient deviation tables in the thesis' layout (Tables 4.6-4.14: rows
  = coefficients, column groups = condition, columns = methods), averaged
  over repeated runs (seeds) of one cell;
- posterior intervals where a method gave them (Bayes);
- system performance: validation fitness (thesis eq. 3.43) against the
  condition, per validation manoeuvre and method (Figs 4.1-4.3), averaged
  over the runs whose prediction stayed bounded, diverged runs counted;
- the speed MAE over the other manoeuvres (Li et al. Fig. 10): per cell the
  mean over bounded predictions and the number of diverged ones;
- trajectory and velocity overlays of every method against the reference at
  the two extreme conditions (Figs 4.4-4.12), redrawn from the runs'
  ``validation_<manoeuvre>.csv`` artifacts;
- which method wins where (Table 5.1 style), generated from the numbers;
- the predictive bands of ``method=bayes`` runs: per run and validation
  record the coverage of the 50/80/90/95 % bands, width, interval score and
  CRPS, pooled per model and discrepancy setting into a calibration figure and a
  sentence on whether the bands can be trusted on these records
  (:mod:`studies.report.calibration`).

``index.md`` is the page; ``index.html`` is the same Markdown rendered
(CommonMark with tables, raw HTML from the store shown as text), with every
run linked to its page in the MLflow UI.
"""

from __future__ import annotations

import shutil
import tempfile
from collections import defaultdict
from pathlib import Path

import numpy as np
import pandas as pd
from jinja2 import Environment, select_autoescape
from markdown_it import MarkdownIt

from ..plotting import draw
from .calibration import LEVELS, band_rows, calibration_sentences, plot_calibration, pooled_calibration
from .figures import plot_fitness, plot_mae, plot_overlays
from .tables import (condition_label, condition_number_table, condition_order, deviation_table,
                     divergence_table, fitness_table, mae_display, mae_table, markdown_table, method_label,
                     speed_mae_cells, winners)

__all__ = ["build_report"]

STATUS_NOTE = {"FAILED": "failed", "KILLED": "killed", "RUNNING": "running or crashed"}


def _none(value):
    return None if value in (None, "", "null", "None") else value


IGNORED_PARAMS = ("method.", "seed", "run_name", "tracking.", "report.", "verbose", "preset",
                  "simplify.", "resume")


def _varying_keys(runs) -> list[str]:
    """The config keys (besides method, seed and bookkeeping) whose values differ between runs."""
    keys = set().union(*(r.params for r in runs)) if runs else set()
    return [k for k in sorted(keys) if not k.startswith(IGNORED_PARAMS)
            and len({r.params.get(k) for r in runs}) > 1]


def _condition_key(runs, condition: str | None) -> str | None:
    """The key whose values make the report's rows: ``condition`` when given,
    else the runs' own ``report.condition`` (presets set it), else the one key
    that varies. When several vary, the report does not guess (it would pool
    different conditions into one row): ``LookupError`` names them."""
    if condition:
        return condition
    if any(_none(r.params.get("report.condition")) for r in runs):
        return None                     # each run says (see _summarise_runs)
    varying = _varying_keys(runs)
    if len(varying) > 1:
        raise LookupError(f"report.condition: the runs differ in {', '.join(varying)}; say which "
                          f"makes the rows, e.g. report.condition={varying[0]} (several keys with commas)")
    return varying[0] if varying else None


def _summarise_runs(runs, condition_key: str | None = None) -> list[dict]:
    out = []
    inferred = _condition_key(runs, condition_key)
    for run in runs:
        key = condition_key or _none(run.params.get("report.condition")) or inferred
        series = _none(run.params.get("report.series")) or "method.name"
        method = run.params.get(series) or run.tags.get("method", "?")
        if key and "," in key:
            condition = " | ".join(run.params.get(k.strip(), "?") for k in key.split(","))
        elif key:
            condition = run.params.get(key, "?")
        else:
            condition = run.tags.get("manoeuvre") or "all"
        out.append({"run": run, "method": method, "condition_key": key, "condition": condition,
                    "metrics": run.metrics, "status": run.status})
    return out


#: tables a measured run writes, set in the report as they are: (artifact, title, index, columns)
MEASURED_TABLES = (
    ("published.csv", "Predictions beside published ones (prediction minus measurement, %)", "record",
     ["turn of the record", "rudder [deg]", "quantity", "mmg", "abkowitz", "published", "source"]),
    ("comparison.csv", "MMG against Abkowitz on the validation records (prediction minus measurement)",
     "record", ["quantity", "mmg", "abkowitz"]),
    ("cross_validation.csv", "Each training record held out in turn (prediction minus measurement)",
     "record", None),
)


def _measured_tables(items: list[dict], scratch: Path) -> list[tuple[str, str]]:
    """Sections from the tables measured runs write (:data:`MEASURED_TABLES`), one per run."""
    out = []
    for artifact, title, index, columns in MEASURED_TABLES:
        for i in items:
            local = i["run"].artifact(artifact, scratch / i["run"].run_id / "tables")
            if local is None:
                continue
            table = pd.read_csv(local)
            if artifact == "cross_validation.csv":
                table = table.pivot_table(index="record", columns="quantity", values="value", sort=False)
            else:
                table = table.set_index(index)[[c for c in columns if c in table.columns]]
            label = getattr(i["run"], "name", i["run"].run_id)
            out.append((f"{title}: run {label}", markdown_table(table, index)))
    return out


def _inclusion_table(items: list[dict]) -> pd.DataFrame | None:
    """Terms x runs of SINDy's inclusion probabilities (``sindy/<dof>/inclusion/<term>`` metrics)."""
    rows = []
    for i in items:
        label = f"{method_label(i['method'])} {i['condition']}".strip()
        for key, value in i["metrics"].items():
            parts = key.split("/")
            if len(parts) == 4 and parts[0] == "sindy" and parts[2] == "inclusion":
                rows.append({"term": f"{parts[1]}: {parts[3]}", "run": label, "inclusion": value})
    if not rows:
        return None
    return pd.DataFrame(rows).pivot_table(index="term", columns="run", values="inclusion", aggfunc="mean",
                                          sort=False)


def _mean_tables(tables: list[pd.DataFrame]) -> pd.DataFrame:
    if len(tables) == 1:
        return tables[0]
    stacked = pd.concat(tables)
    numeric = stacked.groupby("name", sort=False)[["value", "lower", "upper", "true", "deviation_pct"]].mean()
    return numeric.reset_index()


def _divergence_note(counts: pd.DataFrame, key: str | None) -> str:
    """A line under a fitness table naming the cells with diverged runs."""
    cells = [f"{method_label(m)} at {condition_label(key, c)}: {counts.loc[c, m]:g}"
             for c in counts.index for m in counts.columns if counts.loc[c, m] > 0]
    if not cells:
        return ""
    return ("\nDiverged runs, left out of the mean (a cell shows - when all diverged): "
            + "; ".join(cells) + ".\n")


def _summary_sentences(win: pd.DataFrame, key: str | None) -> list[str]:
    if win.empty:
        return []
    counts = pd.Series([m for cell in win.to_numpy().ravel() for m in str(cell).split(" = ")]).value_counts()
    lines = [f"Over {win.size} (condition, manoeuvre) cells, the lowest validation fitness is reached by "
             + ", ".join(f"{m} in {n}" for m, n in counts.items()) + " (ties counted for each)."]
    for man in win.columns:
        col = win[man]
        groups = defaultdict(list)
        for cond, method in col.items():
            groups[method].append(condition_label(key, cond))
        lines.append(f"{man}: " + "; ".join(f"{m} wins at {', '.join(c)}" for m, c in groups.items()) + ".")
    return lines


def build_report(name: str, runs, report_dir, condition: str | None = None) -> Path:
    """Write the comparison page of one experiment's runs.

    Parameters
    ----------
    name : str
        The experiment's name: the page's title and the directory under
        ``report_dir``.
    runs : list of StoredRun
        The experiment's runs as read from the store, newest first (the
        second item of :func:`studies.runtime.tracking.read_experiment`):
        each with ``name``, ``run_id``, ``status``, ``params``, ``metrics``,
        ``tags`` and ``artifact(path, destination)``.
    report_dir : str or os.PathLike
        Directory of the reports.
    condition : str, optional
        The swept config key whose values make the rows (``wind.speed``, or
        several separated by commas); default the runs' own
        ``report.condition``, else the one key that varies between them.

    Returns
    -------
    Path
        ``<report_dir>/<name>/index.md``; ``index.html`` is written beside it.

    Raises
    ------
    LookupError
        ``<report_dir>/<name>`` exists and is not a report, or several keys
        vary between the runs and ``condition`` does not say which to use.
    """
    items = _summarise_runs(runs, condition)
    out = _report_directory(Path(report_dir), name)
    if out.exists():
        shutil.rmtree(out)
    out.mkdir(parents=True)
    finished = [i for i in items if i["status"] == "FINISHED"]
    key = next((i["condition_key"] for i in items if i["condition_key"]), None)
    sections = []

    sections.append(("Runs", markdown_table(_run_rows(items, key), "run")))

    scratch = Path(tempfile.mkdtemp(prefix="studies-report-"))
    try:
        cells = defaultdict(list)
        curves = defaultdict(dict)
        for i in finished:
            local = i["run"].artifact("coefficients.csv", scratch / i["run"].run_id)
            if local is not None:
                cells[(i["condition"], i["method"])].append(pd.read_csv(local))
        entries = [{"condition": c, "method": m, "table": _mean_tables(t)} for (c, m), t in cells.items()]
        for e in entries:
            e["condition"] = condition_label(key, e["condition"])
        has_truth = any(e["table"]["deviation_pct"].notna().any() for e in entries)
        if has_truth:
            dev = deviation_table(entries)
            dev.columns = pd.MultiIndex.from_tuples([(c, method_label(m)) for c, m in dev.columns])
            sections.append(("Deviation of the identified coefficients [%] (100 (identified - true) / true)",
                             markdown_table(dev, "coefficient")))
        with_bounds = [e for e in entries if e["table"]["lower"].notna().any()]
        if with_bounds:
            rows = []
            for e in with_bounds:
                t = e["table"]
                for _, r in t.iterrows():
                    rows.append({"condition": e["condition"], "method": method_label(e["method"]),
                                 "coefficient": r["name"], "median": r["value"], "5 %": r["lower"],
                                 "95 %": r["upper"], "true": r["true"],
                                 "covered": bool(r["lower"] <= r["true"] <= r["upper"]) if np.isfinite(r["true"]) else ""})
            post = pd.DataFrame(rows).set_index("coefficient")
            sections.append(("Posterior intervals (5 % - 95 %)", markdown_table(post, "coefficient")))

        for title, table in _measured_tables(finished, scratch):
            sections.append((title, table))

        inclusion = _inclusion_table(finished)
        if inclusion is not None:
            sections.append(("SINDy: inclusion probability of each term (share of the block-bootstrap draws "
                             "that keep it; kept when >= the run's method.inclusion)",
                             markdown_table(inclusion, "term")))

        manoeuvres = sorted({k.split("/")[0] for i in finished for k in i["metrics"]
                             if k.endswith("/fitness") and not k.startswith(("training", "ga/"))})
        tables = {}
        figures = []
        for man in manoeuvres:
            per_cell = defaultdict(list)
            diverged = defaultdict(int)
            for i in finished:
                v = i["metrics"].get(f"{man}/fitness")
                if v is None:
                    continue
                if i["metrics"].get(f"{man}/diverged", 0.0):
                    diverged[(i["condition"], i["method"])] += 1
                else:
                    per_cell[(i["condition"], i["method"])].append(v)
            cells = set(per_cell) | set(diverged)
            rows = [{"condition": c, "method": m,
                     "metrics": {f"{man}/fitness": float(np.mean(per_cell[(c, m)])) if per_cell[(c, m)]
                                 else np.nan}} for c, m in cells]
            table = fitness_table(rows, man)
            tables[man] = table
            if not table.empty:
                counts = divergence_table(table, diverged)
                path = out / f"fitness_{man}.png"
                draw(plot_fitness, table, key, man, path, counts)
                figures.append(path.name)
                shown = table.rename(index=lambda c: condition_label(key, c), columns=method_label)
                sections.append((f"Validation fitness, {man} (thesis eq. 3.43)",
                                 markdown_table(shown, "condition") + _divergence_note(counts, key)
                                 + f"\n![fitness {man}]({path.name})\n"))
        mae = speed_mae_cells(finished)
        if mae:
            table, counts, validated = mae_table(mae)
            path = out / "mae_speed.png"
            draw(plot_mae, table, counts, key, path)
            shown = mae_display(table, counts, validated).rename(index=lambda c: condition_label(key, c))
            sections.append(("Validation MAE of speeds on the other manoeuvres [m/s] (mean over the bounded "
                             "predictions of all seeds; diverged predictions counted, not averaged)",
                             markdown_table(shown, "condition") + "\n![mae](mae_speed.png)\n"))
            conditioning = condition_number_table(finished)
            if not conditioning.empty:
                shown = conditioning.rename(index=lambda c: condition_label(key, c))
                sections.append(("Condition number of the regression per DOF (median over seeds)",
                                 markdown_table(shown, "condition")))
        win = winners(tables)
        if not win.empty:
            shown = win.rename(index=lambda c: condition_label(key, c))
            text = "\n".join(f"- {s}" for s in _summary_sentences(win, key))
            sections.append(("Which method wins where",
                             markdown_table(shown, "condition") + "\n" + text + "\n"))

        bands = _band_section(items, key, out)
        if bands:
            sections.append(("Predictive bands and their calibration", bands))
        for title, body in _held_out_calibration(finished, scratch, out):
            sections.append((title, body))

        conditions = sorted({i["condition"] for i in finished}, key=lambda c: (_as_float(c), str(c)))
        extremes = [conditions[0], conditions[-1]] if len(conditions) > 1 else conditions
        overlay_md = []
        for cond in extremes:
            for man in manoeuvres:
                runs_here = {}
                for i in finished:
                    if i["condition"] == cond and i["method"] not in runs_here:
                        local = i["run"].artifact(f"validation_{man}.csv", scratch / i["run"].run_id)
                        if local is not None:
                            runs_here[i["method"]] = pd.read_csv(local)
                if runs_here:
                    fname = f"overlay_{_slug(cond)}_{man}.png"
                    title = _overlay_title(man, key, cond, len(conditions))
                    draw(plot_overlays, runs_here, title, out / fname)
                    figures.append(fname)
                    overlay_md.append(f"![{title}]({fname})")
        if overlay_md:
            sections.append(("Trajectories and velocities at the extreme conditions",
                             "\n\n".join(overlay_md) + "\n"))
    finally:
        shutil.rmtree(scratch, ignore_errors=True)

    header = (f"# {name}\n\n{len(items)} runs ({len(finished)} finished) from the MLflow store; "
              f"condition: `{key or 'none'}`. Each run links to its page in the MLflow UI "
              f"(for a local store, start it with `studies ui`).\n")
    md = header + "\n".join(f"\n## {title}\n\n{body}" for title, body in sections)
    (out / "index.md").write_text(md)
    _write_html(out / "index.html", name, md)
    return out / "index.md"


#: figures of a run's calibration page over held-out records (studies.workflows.band_calibration)
CALIBRATION_FIGURES = ("pit.png", "calibration_pooled.png")


def _held_out_calibration(items: list[dict], scratch: Path, out: Path) -> list[tuple[str, str]]:
    """The calibration page of every run that held each record out with its band
    (``calibration.md``, :mod:`studies.workflows.band_calibration`): its tables,
    verdicts and figures (copied beside the report as ``<figure>_<run id>.png``)."""
    sections = []
    for i in items:
        run = i["run"]
        local = run.artifact("calibration.md", scratch / run.run_id / "calibration")
        if local is None:
            continue
        body = local.read_text().split("\n", 1)[1].replace("\n## ", "\n### ")
        for figure in CALIBRATION_FIGURES:
            found = run.artifact(figure, scratch / run.run_id / "calibration")
            if found is not None:
                name = f"{Path(figure).stem}_{run.run_id[:8]}.png"
                shutil.copyfile(found, out / name)
                body += f"\n![{figure}]({name})\n"
        label = getattr(run, "name", run.run_id)
        sections.append((f"Calibration of the bands, each record held out in turn: run {label}", body))
    return sections


def _band_section(items: list[dict], key: str | None, out: Path) -> str:
    """Per-record coverage of the predictive bands, pooled calibration, figure and verdicts."""
    rows = band_rows(items)
    if rows.empty:
        return ""
    pooled = pooled_calibration(rows)
    draw(plot_calibration, rows, pooled, out / "calibration.png")
    table = pd.DataFrame({
        "run": rows["run"], "condition": [condition_label(key, c) for c in rows["condition"]],
        "record": rows["record"], "discrepancy": np.where(rows["discrepancy"], "yes", "no"),
        **{f"{lv} %": rows[f"coverage_{lv}"].round(2) for lv in LEVELS},
        "90 % width": rows["width"].round(3), "width / manoeuvre": rows["width_over_extent"].round(3),
        "covered until [s]": rows["covered_until_s"].round(0),
        "interval score": rows["interval_score"].round(3), "CRPS": rows["crps"].round(3),
        "outside training": rows["outside_training"].round(2),
        "trusted": np.where(rows["trusted"], "yes", "no")}).set_index("run")
    text = "\n".join(f"- {s}" for s in calibration_sentences(pooled))
    return ("Share of each validation record inside its 50/80/90/95 % predictive band (a manoeuvre: "
            "the joint band of x0 and y0, width in metres; a roll decay: phi(t), width in degrees). "
            "One record's coverage is close to all or nothing, because the prediction's errors are "
            "correlated over the record: calibration is read from many records.\n\n"
            + markdown_table(table, "run") + "\n" + text + "\n\n![calibration](calibration.png)\n")


def _run_rows(items: list[dict], key: str | None) -> pd.DataFrame:
    """One row per run in condition order (then method): its name linked to
    its page in the MLflow UI, method, condition, status, error, run id."""
    rows = [{
        "run": _run_link(i["run"]), "method": method_label(i["method"]),
        "condition": condition_label(key, i["condition"]), "status": _status(i["status"]),
        "error": _note(i), "run id": f"`{i['run'].run_id}`",
    } for i in items]
    rows.sort(key=lambda r: (condition_order(r["condition"]), r["method"]))
    return pd.DataFrame(rows).set_index("run")


def _status(status: str) -> str:
    """``FINISHED``, or the other statuses in bold words (``**failed**``)."""
    return status if status == "FINISHED" else f"**{STATUS_NOTE.get(status, status)}**"


def _run_link(run) -> str:
    """``[name](url)`` of a run's page in the MLflow UI (its name alone without one)."""
    name = _table_text(run.name)
    url = getattr(run, "url", None)
    return f"[{name.replace('[', '(').replace(']', ')')}]({url})" if url else name


def _table_text(text) -> str:
    """Text from the store made safe for one cell of a Markdown table."""
    return str(text).replace("|", "/").replace("\n", " ")


def _overlay_title(manoeuvre: str, key: str | None, condition, n_conditions: int) -> str:
    """Title of an overlay figure: the validation manoeuvre at the condition;
    without a swept key the condition is the training manoeuvre, named only
    when the runs differ in it."""
    if key is not None:
        return f"{manoeuvre} at {condition_label(key, condition)}"
    if n_conditions > 1 and condition != "all":
        return f"{manoeuvre}, trained on {condition}"
    return manoeuvre


def _note(item) -> str:
    """The run's error, or which predictions diverged (counted in the tables, left out of their means)."""
    error = item["run"].tags.get("error", "")
    if error:
        return _table_text(error)
    diverged = sorted(k.rsplit("/", 1)[0] for k, v in item["metrics"].items()
                      if k.endswith("/diverged") and k != "validation/diverged" and v)
    if diverged:
        from ..analysis.metrics import DIVERGED_PENALTY

        return (f"diverged: {', '.join(diverged)} (counted; its metrics hold the penalty "
                f"{DIVERGED_PENALTY:g}, left out of the means)")
    return ""


def _report_directory(report_dir: Path, name: str) -> Path:
    """``<report_dir>/<experiment>``, kept inside ``report_dir`` whatever the
    experiment is called; an existing directory is only replaced when it holds
    a report (``index.md``), never another directory of the user's."""
    safe = name if name not in ("", ".", "..") and not any(c in name for c in "/\\\0") else _slug(name)
    safe = safe if safe not in ("", ".", "..") else "experiment"
    out = report_dir / safe
    if out.exists() and (not out.is_dir() or (any(out.iterdir()) and not (out / "index.md").exists())):
        raise LookupError(f"{out} exists and is not a report written by studies report; "
                          "move it or choose another report.dir")
    return out


def _as_float(x):
    try:
        return float(x)
    except (TypeError, ValueError):
        return float("inf")


def _slug(text) -> str:
    return "".join(ch if ch.isalnum() or ch in "-." else "_" for ch in str(text))


def _write_html(path: Path, name: str, md: str) -> None:
    """``index.html``: the Markdown page rendered (CommonMark with tables; raw
    HTML in the Markdown, e.g. from an error message, is shown as text)."""
    body = MarkdownIt("commonmark", {"html": False}).enable("table").render(md)
    template = Environment(autoescape=select_autoescape(["html"])).from_string(HTML)
    path.write_text(template.render(name=name, body=body))


HTML = """<!doctype html>
<html lang="en"><head><meta charset="utf-8"><title>{{ name }}</title>
<style>
body { font-family: sans-serif; margin: 2em; max-width: 1400px; }
table { border-collapse: collapse; font-size: 0.85em; margin-bottom: 1em; }
th, td { border: 1px solid #ccc; padding: 2px 6px; text-align: right; }
th:first-child, td:first-child { text-align: left; }
code { font-size: 0.9em; }
img { max-width: 100%; }
</style></head>
<body>
{{ body | safe }}
</body></html>
"""
