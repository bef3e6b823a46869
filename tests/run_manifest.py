"""What a finished command left behind: its files, and its MLflow run's params,
metrics, tags and artifacts, by name (not by value).

``tests/test_outputs_kept.py`` compares a command's manifest with the one
stored in ``tests/manifests/`` (written by an earlier version of `studies`):
a change that speeds a command up must not drop anything a user or a script
reads. Regenerate a stored manifest only when an output is removed on
purpose (``python tests/run_manifest.py NAME -- ARGS``, from a scratch folder).
"""

from __future__ import annotations

import json
import sqlite3
import subprocess
import sys
from pathlib import Path

MANIFESTS = Path(__file__).resolve().parent / "manifests"

#: tags whose presence depends on the machine (a git work tree) or the moment
VOLATILE_TAGS = ("mlflow.source.git.commit",)


def _rows(db: Path, query: str, run_id: str) -> list[str]:
    with sqlite3.connect(db) as con:
        return sorted({row[0] for row in con.execute(query, (run_id,))})


def manifest(project: Path) -> dict:
    """The manifest of the only run in ``project``'s default store and of its output folder."""
    db = project / "mlruns" / "mlflow.db"
    with sqlite3.connect(db) as con:
        runs = [row[0] for row in con.execute("SELECT run_uuid FROM runs")]
    assert len(runs) == 1, f"expected one run in {db}, found {len(runs)}"
    run_id = runs[0]
    outputs = sorted(project.glob("outputs/*/*"))
    assert len(outputs) == 1, f"expected one output folder, found {outputs}"
    files = sorted(p.relative_to(outputs[0]).as_posix() for p in outputs[0].rglob("*")
                   if p.is_file() and not p.name.endswith(".log"))
    artifacts = sorted(p.relative_to(a).as_posix()
                       for a in project.glob(f"mlruns/artifacts/*/{run_id}/artifacts")
                       for p in a.rglob("*") if p.is_file())
    return {
        "files": files,
        "artifacts": artifacts,
        "params": _rows(db, "SELECT key FROM params WHERE run_uuid = ?", run_id),
        "metrics": _rows(db, "SELECT key FROM latest_metrics WHERE run_uuid = ?", run_id),
        "tags": [t for t in _rows(db, "SELECT key FROM tags WHERE run_uuid = ?", run_id) if t not in VOLATILE_TAGS],
        "logged_models": len(list(project.glob("mlruns/artifacts/*/models/*/artifacts/MLmodel"))),
    }


def missing(stored: dict, now: dict) -> dict:
    """What ``stored`` lists and ``now`` does not (new outputs are allowed)."""
    out = {}
    for key, names in stored.items():
        if isinstance(names, list):
            gone = sorted(set(names) - set(now.get(key, [])))
            if gone:
                out[key] = gone
        elif now.get(key, 0) < names:
            out[key] = f"{now.get(key, 0)} < {names}"
    return out


if __name__ == "__main__":
    name, args = sys.argv[1], sys.argv[sys.argv.index("--") + 1:]
    subprocess.run([sys.executable, "-m", "studies", *args], check=True)
    MANIFESTS.mkdir(exist_ok=True)
    (MANIFESTS / f"{name}.json").write_text(json.dumps(manifest(Path.cwd()), indent=1) + "\n")
