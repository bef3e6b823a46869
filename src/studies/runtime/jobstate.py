"""What the jobs of one ``studies run`` (or sweep) tell the launching process.

The ``studies`` command creates a private directory for each invocation and
passes its path to the jobs in the environment (``STUDIES_JOB_STATE``); the
joblib launcher's worker processes inherit it. In it:

- ``active-<pid>-<job>.json``: written when a job starts, updated with its
  MLflow run id when the run exists, removed when the job is over (its run
  closed). On SIGINT/SIGTERM the launcher forwards the signal to these
  processes and waits until their files are gone; a run still listed in a
  file afterwards (its worker was killed before it could close the run) is
  marked KILLED by the launcher.
- ``stop``: created by the launcher on the first signal; a job that sees it
  does not start.
- ``result-<job>.json``: how each job ended (finished, failed, skipped),
  with its error line and run id: the sweep's summary.

Jobs launched where the directory is not visible (a remote Ray cluster) do
without: they behave as plain Hydra jobs.
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import signal
import tempfile
import time
from pathlib import Path

__all__ = ["ENV_STATE", "JobState", "current"]

ENV_STATE = "STUDIES_JOB_STATE"
GRACE_S = 60.0


def _write_json(path: Path, data: dict) -> None:
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    tmp.write_text(json.dumps(data))
    os.replace(tmp, path)


def _read_json(path: Path) -> dict | None:
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError):
        return None


def _alive(pid: int) -> bool:
    """True while ``pid`` runs (a zombie counts as dead)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    try:
        with open(f"/proc/{pid}/stat") as handle:
            return handle.read().rsplit(")", 1)[1].split()[0] != "Z"
    except (OSError, IndexError):
        return True


class JobState:
    """The state directory of one invocation of ``studies``."""

    def __init__(self, path: str | os.PathLike):
        self.path = Path(path)

    # ---------------------------------------------------------------- launcher side
    @classmethod
    def create(cls) -> "JobState":
        state = cls(tempfile.mkdtemp(prefix="studies-jobs-"))
        os.environ[ENV_STATE] = str(state.path)
        return state

    def remove(self) -> None:
        if os.environ.get(ENV_STATE) == str(self.path):
            del os.environ[ENV_STATE]
        shutil.rmtree(self.path, ignore_errors=True)

    def active(self) -> list[dict]:
        out = []
        for path in sorted(self.path.glob("active-*.json")):
            data = _read_json(path)
            if data is not None:
                data["_file"] = str(path)
                out.append(data)
        return out

    def results(self) -> list[dict]:
        out = [_read_json(p) for p in self.path.glob("result-*.json")]
        return sorted((r for r in out if r), key=lambda r: (r.get("num") is None, r.get("num") or 0))

    def stop_jobs(self, signum: int, grace: float = GRACE_S) -> None:
        """Stop new jobs, signal the running ones, wait until they closed their runs."""
        (self.path / "stop").touch()
        signalled = set()
        deadline = time.monotonic() + grace
        while time.monotonic() < deadline:
            running = [a for a in self.active()
                       if int(a.get("pid", 0)) != os.getpid() and _alive(int(a.get("pid", 0)))]
            if not running:
                return
            for a in running:
                pid = int(a["pid"])
                if pid not in signalled:
                    signalled.add(pid)
                    try:
                        os.kill(pid, signal.SIGTERM)
                    except OSError:
                        pass
            time.sleep(0.05)

    def unclosed_runs(self) -> list[dict]:
        """Runs of jobs that did not remove their ``active`` file (worker killed)."""
        return [a for a in self.active() if a.get("run_id")]

    # ---------------------------------------------------------------- job side
    def stopped(self) -> bool:
        return (self.path / "stop").exists()

    @contextlib.contextmanager
    def job(self, num: int | None, overrides: list[str]):
        """Announce a running job; yields a :class:`JobRecord`."""
        tag = "single" if num is None else str(num)
        record = JobRecord(self, self.path / f"active-{os.getpid()}-{tag}.json",
                           {"pid": os.getpid(), "num": num, "overrides": list(overrides)})
        record.save()
        try:
            yield record
        finally:
            with contextlib.suppress(OSError):
                record.file.unlink()

    def write_result(self, num: int | None, data: dict) -> None:
        tag = "single" if num is None else str(num)
        _write_json(self.path / f"result-{tag}.json", {"num": num, **data})


class JobRecord:
    """The ``active`` file of one job."""

    def __init__(self, state: JobState, file: Path, data: dict):
        self.state = state
        self.file = file
        self.data = data

    def save(self) -> None:
        _write_json(self.file, self.data)

    def set_run(self, run_id: str, uri: str) -> None:
        self.data.update(run_id=run_id, uri=uri)
        self.save()


def current() -> JobState | None:
    """The state directory announced by the launching ``studies`` process, if visible."""
    path = os.environ.get(ENV_STATE)
    if path and os.path.isdir(path):
        return JobState(path)
    return None
