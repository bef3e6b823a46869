"""``studies ui``: the MLflow UI on the project's store, on loopback by default."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

from . import tracking

__all__ = ["ui_command", "serve"]


def ui_command(uri: str | None, root, host: str = "127.0.0.1", port: int = 5000) -> list[str]:
    """The ``mlflow server`` command line for the store (artifacts served from it)."""
    uri = tracking.configure(uri, root)
    cmd = [sys.executable, "-m", "mlflow", "server", "--backend-store-uri", uri, "--registry-store-uri", uri,
           "--host", host, "--port", str(port), "--workers", "1"]
    if uri.startswith("sqlite:///"):
        artifacts = Path(uri[len("sqlite:///"):]).parent / "artifacts"
        artifacts.mkdir(parents=True, exist_ok=True)
        cmd += ["--default-artifact-root", artifacts.resolve().as_uri()]
    return cmd


def serve(uri: str | None, root, host: str = "127.0.0.1", port: int = 5000) -> int:
    """Run the UI in the foreground until interrupted; prints the address."""
    cmd = ui_command(uri, root, host, port)
    # no job executor: it serves GenAI evaluation jobs that `studies` never submits,
    # and its worker processes cost several times the memory of the UI itself
    env = dict(os.environ, MLFLOW_DISABLE_TELEMETRY="true", MLFLOW_SERVER_ENABLE_JOB_EXECUTION="false")
    # the server's libraries warn their own maintainers of deprecations (Starlette's WSGI
    # middleware in MLflow, a UserWarning): nothing a user of the UI can act on
    quiet = ("ignore::DeprecationWarning", "ignore:starlette.middleware.wsgi is deprecated")
    env["PYTHONWARNINGS"] = ",".join(w for w in (os.environ.get("PYTHONWARNINGS"), *quiet) if w)
    print(f"MLflow UI for {cmd[cmd.index('--backend-store-uri') + 1]} at http://{host}:{port}", flush=True)
    if host not in ("127.0.0.1", "localhost", "::1"):
        print(f"warning: listening on {host}, reachable from other machines", file=sys.stderr)
    import signal

    # the server starts worker processes of its own: run it in its own process group
    # and end the whole group, so that stopping `studies ui` leaves nothing behind
    proc = subprocess.Popen(cmd, env=env, start_new_session=True, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True, bufsize=1)
    import threading

    threading.Thread(target=_forward, args=(proc.stdout,), daemon=True).start()
    print("press Ctrl+C to stop it", flush=True)

    def _stop(signum, frame):
        raise KeyboardInterrupt

    previous = signal.signal(signal.SIGTERM, _stop)
    try:
        return proc.wait()
    except KeyboardInterrupt:
        return _stop_group(proc)
    finally:
        signal.signal(signal.SIGTERM, previous)
        if proc.poll() is None:
            _stop_group(proc)


#: what the server says that a user of the UI cannot act on: its start-up steps, each request,
#: its registry defaulting to the store, and the localhost-only guard `studies ui` already states
_QUIET = (" INFO:", "Registry store URI not provided", "Security middleware enabled")


def _forward(stream) -> None:
    """Copy the server's output to stderr, less the lines of :data:`_QUIET`
    (warnings and errors are passed on)."""
    for line in stream:
        if not any(mark in line for mark in _QUIET):
            sys.stderr.write(line)
            sys.stderr.flush()


def _stop_group(proc) -> int:
    import signal

    try:
        os.killpg(proc.pid, signal.SIGTERM)
        return proc.wait(timeout=20)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        return proc.wait()
    except ProcessLookupError:
        return proc.wait()
