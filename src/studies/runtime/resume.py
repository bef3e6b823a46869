"""Config hashes: which runs of a sweep are already done (``resume=true``).

Every run is tagged ``config_hash``: a digest of the job's resolved
configuration without the keys that do not change what is computed
(``hydra.*``, ``run_name``, ``verbose``, ``resume``, ``tracking.*``), and of
the contents of the data files it names (``data.path``, ``validate.path``,
``simulation.path``), so that an edited file is not taken for a done
job. With ``resume=true`` a job whose hash has a FINISHED run in the
experiment is skipped; FAILED, KILLED and RUNNING (crashed) runs do not
count, so those jobs run again.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Mapping, Sequence
from pathlib import Path

__all__ = ["config_hash", "IGNORED_KEYS"]

IGNORED_KEYS = ("hydra", "run_name", "verbose", "resume", "tracking")
FILE_KEYS = ("data.path", "validate.path", "simulation.path")


def _file_digest(path: str, root: Path) -> str:
    p = Path(path).expanduser()
    if not p.is_absolute():
        p = root / p
    digest = hashlib.sha256()
    try:
        with open(p, "rb") as handle:
            for block in iter(lambda: handle.read(1 << 20), b""):
                digest.update(block)
    except OSError:
        return "missing"
    return digest.hexdigest()


def _plain(node):
    """Nested mappings and sequences as dicts and lists (values resolved)."""
    if isinstance(node, Mapping):
        return {str(k): _plain(v) for k, v in node.items()}
    if isinstance(node, Sequence) and not isinstance(node, (str, bytes)):
        return [_plain(v) for v in node]
    return node


def config_hash(config: dict, root=".") -> str:
    """16 hex digits identifying what a job computes.

    ``config`` is the job's resolved configuration: nested mappings and
    sequences (plain containers, as logged to MLflow, or any mapping type).
    """
    data = _plain(config)
    for key in IGNORED_KEYS:
        data.pop(key, None)
    files = {}
    for key in FILE_KEYS:
        node = data
        for part in key.split("."):
            node = node.get(part) if isinstance(node, dict) else None
        if node in (None, ""):
            continue
        paths = node if isinstance(node, list) else [node]
        files[key] = [_file_digest(str(p), Path(root)) for p in paths]
    text = json.dumps({"config": data, "files": files}, sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:16]
