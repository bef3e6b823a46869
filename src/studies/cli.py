"""The ``studies`` command: sub-commands that are Hydra apps.

``studies run [overrides]``      one study (``-m`` for a sweep)
``studies simulate [overrides]`` a manoeuvre of a logged/registered model (``model_uri=``)
``studies bench``                performance figures as JSON

Bad input (an unknown key or option, an unparsable override, an impossible
value, a data file outside the data contract, a path to write outside the
project) is reported as one line on stderr with exit status 2, before any
MLflow run exists (:mod:`studies.config_check` composes every job's config
first); ``verbose=true`` shows the traceback instead. A run that fails later
is marked FAILED in MLflow with its error (one line, exit status 1). In a
sweep the other jobs go on; the sweep ends with a one-line summary of the
failed jobs and exit status 1. SIGINT/SIGTERM mark the running runs KILLED
(:mod:`studies.interrupt`, :mod:`studies.runtime.jobstate`) and exit with 128 + the
signal; ``resume=true`` then skips the jobs that already have a FINISHED run
with the same ``config_hash`` tag (:mod:`studies.runtime.resume`).
"""

from __future__ import annotations

import contextlib
import json
import os
import sys
from pathlib import Path

# Only light modules at the top: numpy must not be loaded before main() sets
# one BLAS thread per process, and `studies --help` or `studies ui` should not
# pay for the scientific stack; the workflows, MLflow and Hydra are imported
# by the sub-command that needs them.
from . import config  # noqa: F401  (registers the schemas and the user's conf/ folder with Hydra)
from . import interrupt
from .config_check import check_arguments, verbose_requested
from .errors import StudiesError
from .progress import ENV_TOTAL
from .runtime import jobstate
from .runtime.jobstate import JobState

__all__ = ["main"]

USAGE = """usage: studies <command> [key=value ...]

commands:
  run      identify a manoeuvring model from simulated or measured data and log it to MLflow
  discover show what a model gets wrong on measured data, name the cause, extend, measure the gain
  simplify derive the simplified model (correlation + PAWN, Li et al. 2023) and log its derivation
  report   write reports/<experiment>/index.md and index.html from the MLflow runs
  simulate simulate a manoeuvre with a logged or registered model (model_uri=...), as a run validates
  ui       start the MLflow UI on the project's store (127.0.0.1:5000)
  bench    print the performance figures as JSON

Options are Hydra overrides, e.g.
  studies run method=ls wind.speed=12 wind.direction=45 noise.wind_speed_error=-0.05
  studies run data.path=my_zigzag.csv vessel=mariner
  studies run -m wind.speed=4,8,12,16
  studies run -m wind.speed=4,8,12,16 resume=true   # after an interruption: run the rest
  studies run tracking.register=mariner_ls           # also register the identified model
  studies simulate model_uri=models:/mariner_ls/1 manoeuvre=turning_35

studies --version prints the version; studies <command> --help the command's own
options with their units and defaults (studies <command> --help-all: every option).
"""


def _fail(error: Exception, verbose: bool) -> None:
    if verbose:
        raise error
    print(f"studies: error: {_one_line(error)}", file=sys.stderr)
    sys.exit(2)


def _one_line(error) -> str:
    """An error as one line (first line, plus the last one when they differ)."""
    text = str(error)
    lines = [line.strip() for line in text.strip().splitlines() if line.strip()]
    if not lines:
        return type(error).__name__ if isinstance(error, BaseException) else ""
    line = lines[0] if len(lines) == 1 or lines[-1] == lines[0] else f"{lines[0]} ... {lines[-1]}"
    return line[:1000]


def _job_info():
    """(multirun, job number or None, this job's overrides)."""
    from hydra.core.hydra_config import HydraConfig
    from hydra.types import RunMode

    hydra_cfg = HydraConfig.get()
    multirun = hydra_cfg.mode == RunMode.MULTIRUN
    num = hydra_cfg.job.get("num") if multirun else None
    return multirun, num, [str(o) for o in hydra_cfg.overrides.task]


def _run_job(cfg, body) -> dict:
    """Run ``body(cfg, root, out_dir, on_create)`` as one job of `studies`.

    Single run: bad input (:class:`StudiesError`) is one line and exit 2, any
    other error one line and exit 1 (tracebacks with ``verbose=true``).
    Sweep job: a failure is recorded for the launcher's summary and the job
    returns ``{"status": "failed", ...}`` so that the other jobs go on.
    SIGINT/SIGTERM end the job (its run KILLED) and propagate.
    """
    from contextlib import nullcontext

    from hydra.core.hydra_config import HydraConfig
    from hydra.utils import get_original_cwd

    verbose = cfg.get("verbose", False) is True
    multirun, num, overrides = _job_info()
    root = Path(get_original_cwd())
    out_dir = Path(HydraConfig.get().runtime.output_dir)
    state = jobstate.current()
    created = {}

    def on_create(run_id, uri):
        created["run_id"] = run_id
        if record is not None:
            record.set_run(run_id, uri)

    record = None
    try:
        with (state.job(num, overrides) if state else nullcontext()) as record, interrupt.job():
            if state is not None and state.stopped():
                raise interrupt.Interrupted(interrupt.received() or 15)
            result = body(cfg, root, out_dir, on_create)
    except KeyboardInterrupt:
        if state is not None:
            run_id = created.get("run_id")
            state.write_result(num, {"status": "killed" if run_id else "not started",
                                     "overrides": overrides, "run_id": run_id})
        raise
    except Exception as error:  # noqa: BLE001 - reported as one line, run marked FAILED
        run_id = created.get("run_id")
        line = _one_line(error) if isinstance(error, StudiesError) else \
            f"{type(error).__name__}: {_one_line(error)}"
        if run_id:
            line += f" (run {run_id} marked FAILED)"
        if not multirun:
            if verbose:
                raise
            print(f"studies: error: {line}", file=sys.stderr)
            sys.exit(2 if isinstance(error, StudiesError) else 1)
        if state is None:
            raise
        if verbose:
            import traceback

            traceback.print_exc()
        result = {"status": "failed", "error": line, "run_id": run_id}
    result = {**result, "overrides": overrides, "out_dir": str(out_dir)}
    if state is not None:
        state.write_result(num, result)
    if result["status"] == "skipped" and not multirun:
        print(f"[studies] skipped: already finished as run {result['run_id']} (resume=true)",
              file=sys.stderr)
    return result


def _settings(cfg):
    """The job's typed settings (:mod:`studies.config`): Hydra's config
    converted once, every value checked by its dataclass."""
    from omegaconf import OmegaConf

    return OmegaConf.to_object(cfg)


def _params(cfg) -> dict:
    """The job's resolved configuration as plain containers (MLflow params, config hash)."""
    from omegaconf import OmegaConf

    return OmegaConf.to_container(cfg, resolve=True)


def _resumable(settings, params: dict, root):
    """``(config_hash, id of a FINISHED run with it or None)``."""
    from .runtime import tracking
    from .runtime.resume import config_hash

    digest = config_hash(params, root)
    done = None
    if settings.resume:
        done = tracking.find_finished_run(settings.tracking.uri, root, settings.tracking.experiment, digest)
    return digest, done


def _study(cfg, root: Path, out_dir: Path, on_create) -> dict:
    """One `studies run` job: check, (skip,) prepare, open the run, execute, log."""
    from .config.paths import check_output_paths
    from .runtime import tracking

    settings = _settings(cfg)
    params = _params(cfg)
    check_output_paths(settings, root, out_dir)
    tracking.check_store(settings.tracking.uri, root)
    digest, done = _resumable(settings, params, root)
    if done:
        return {"status": "skipped", "run_id": done, "config_hash": digest}
    with _figures_beside():
        return _study_body(settings, params, digest, root, out_dir, on_create)


def _study_body(settings, params, digest, root: Path, out_dir: Path, on_create) -> dict:
    """The job (:func:`studies.api.jobs.run_identification`) in a run of the store, then its console lines."""
    from .api.jobs import run_identification
    from .console import run_lines

    job = run_identification(settings, params, root, out_dir, _opener(settings, root, on_create),
                             "studies run", digest)
    print(f"run '{job.name}' ({job.run_id}) -> {out_dir}")
    print(_browse(settings, root))
    if job.logged:
        print(f"model {job.logged['uri']}" + (f", registered as {job.logged['registered']}"
                                              if job.logged["registered"] else ""))
    simulated = not settings.data.path
    trained_on = set(settings.train.manoeuvres or [settings.manoeuvre.name]) if simulated else set()
    print("\n".join(run_lines(job.metrics, trained_on)))
    return {"status": "finished", "run_id": job.run_id, "config_hash": digest}


def _opener(settings, root: Path, on_create):
    """``open_run(name, params, tags)``: the command line's run, always in the store of ``tracking.uri``."""
    from .runtime import tracking

    def open_run(name: str, params: dict, tags: dict):
        return tracking.start_run(settings.tracking.experiment, name, settings.tracking.uri, root,
                                  params, tags, on_create=on_create)

    return open_run


@contextlib.contextmanager
def _figures_beside(workers: int = 1):
    """One job's figures drawn by ``workers`` other processes while it computes
    (:class:`studies.plotting.Drawer`); in a sweep's jobs they are drawn in the
    job's own process (the sweep already keeps every core busy)."""
    from hydra.core.hydra_config import HydraConfig
    from hydra.types import RunMode

    from .plotting import DRAWER

    single = not HydraConfig.initialized() or HydraConfig.get().mode != RunMode.MULTIRUN
    if single:
        DRAWER.start(workers)
    try:
        yield
    finally:
        DRAWER.close()


def _browse(settings, root: Path) -> str:
    """Where the run was logged and how to browse it."""
    from .runtime import tracking

    uri = tracking.resolve_uri(settings.tracking.uri, root)
    if uri.startswith(("http://", "https://")):
        return f"logged to {uri} (experiment '{settings.tracking.experiment}'): open it in a browser"
    return (f"logged to {uri} (experiment '{settings.tracking.experiment}'): browse with `studies ui`, "
            f"compare with `studies report report.experiment={settings.tracking.experiment}`")


def _console(values: dict) -> str:
    """``key  value`` lines, numbers to 4 significant digits (the files keep them all)."""
    from .console import number

    width = max((len(k) for k in values), default=0)
    return "\n".join(f"  {k:<{width}}  {number(v)}" for k, v in sorted(values.items())
                     if v is not None)


def _run_task(cfg):
    return _run_job(cfg, _study)


def _simplify(cfg, root: Path, out_dir: Path, on_create) -> dict:
    from .api.jobs import recorder
    from .workflows.settings import check_output_paths
    from .workflows.simplify import ensure_definition

    settings = _settings(cfg)
    check_output_paths(settings, root, out_dir)
    path = ensure_definition(settings, root, recorder(settings, root), out_dir, force=True)
    print(f"simplified model written: {path}")
    print((out_dir / "simplification.json").read_text())
    return {"status": "finished"}


def _simplify_task(cfg):
    return _run_job(cfg, _simplify)


def _discover(cfg, root: Path, out_dir: Path, on_create) -> dict:
    """One `studies discover` job: load and check inputs, then one tracked run."""
    from .config.paths import check_output_paths
    from .runtime import tracking

    settings = _settings(cfg)
    check_output_paths(settings, root, out_dir)
    tracking.check_store(settings.tracking.uri, root)
    with _figures_beside():
        return _discover_body(cfg, settings, root, out_dir, on_create)


def _discover_body(cfg, settings, root: Path, out_dir: Path, on_create) -> dict:
    """The discovery (:func:`studies.api.jobs.run_discovery`) in a run of the store, then its console lines."""
    from .api.jobs import run_discovery
    from .console import discovery_lines

    job = run_discovery(settings, _params(cfg), root, out_dir, _opener(settings, root, on_create))
    print(f"discovery '{job.name}' ({job.run_id}) -> {out_dir}")
    print(_browse(settings, root))
    print("\n".join(discovery_lines(job.discovery)))
    print(f"the page: {out_dir / 'report.md'}")
    return {"status": "finished", "run_id": job.run_id}


def _discover_task(cfg):
    return _run_job(cfg, _discover)


def _simulate(cfg, root: Path, out_dir: Path, on_create) -> dict:
    """One `studies simulate` job: a manoeuvre of a logged, registered or
    published model, with the files and figures of a run's validation."""
    from dataclasses import asdict

    from .runtime import tracking
    from .workflows.identified_model import published_model
    from .workflows.model_simulation import simulate_model
    from .workflows.settings import named_manoeuvre

    settings = _settings(cfg)
    tracking.check_store(settings.tracking.uri, root)
    given = {k: v for k, v in asdict(settings.manoeuvre).items() if k != "name" and v is not None}
    manoeuvre = named_manoeuvre(settings.manoeuvre.name, given)
    if settings.model_uri:
        identified = tracking.load_model(settings.model_uri, settings.tracking.uri, root)
        label = settings.model_uri
    else:
        identified = published_model(settings.vessel.name)
        label = f"published {settings.vessel.name}"
    metrics = simulate_model(identified, manoeuvre, out_dir, label,
                             against_reference=bool(settings.model_uri))
    print(f"simulated {manoeuvre.name} with {label} -> {out_dir}")
    print(_console(metrics))
    return {"status": "finished"}


def _simulate_task(cfg):
    return _run_job(cfg, _simulate)


def _report_task(cfg) -> None:
    from hydra.utils import get_original_cwd

    from .plotting import DRAWER
    from .report.builder import build_report
    from .runtime import tracking
    from .config.paths import output_path

    root = Path(get_original_cwd())
    verbose = cfg.get("verbose", False) is True
    try:
        # the page's figures are drawn by two worker processes while the runs are read
        # and the tables assembled (a sweep's report holds a dozen figures or more)
        with _figures_beside(workers=2):
            settings = _settings(cfg)
            report_dir = output_path(settings.report.dir, "report.dir", root)
            tracking.check_store(settings.tracking.uri, root)
            if settings.report.compare:
                path = _reproduction(settings, root, report_dir)
            else:
                name, runs = tracking.read_experiment(settings.tracking.uri, root,
                                                      settings.report.experiment or None)
                path = build_report(name, tracking.select_sweep(runs, settings.report.sweep), report_dir,
                                    settings.report.condition)
            DRAWER.finish()
    except (LookupError, StudiesError) as error:
        _fail(error, verbose)
    print(f"report written: {path} and {path.with_suffix('.html')}")


def _reproduction(settings, root: Path, report_dir: Path) -> Path:
    """``report.compare=<paper>``: the runs of every experiment of the paper
    (all of their jobs, none where the store has no such experiment) into
    its reproduction report."""
    from .report.reproduction import build_reproduction, experiments
    from .runtime import tracking

    paper = settings.report.compare
    runs = {}
    for experiment in experiments(paper):
        try:
            _, found = tracking.read_experiment(settings.tracking.uri, root, experiment)
        except LookupError:
            found = []
        runs[experiment] = tracking.select_sweep(found, "all") if found else []
    if not any(runs.values()):
        raise LookupError(f"report.compare={paper}: the store has no runs of "
                          f"{', '.join(experiments(paper))}; run the paper's presets first")
    return build_reproduction(paper, runs, report_dir)


def _varying(results: list[dict]) -> dict:
    """Per job number, the overrides that differ between the jobs of the sweep."""
    common = None
    for r in results:
        here = set(r.get("overrides") or [])
        common = here if common is None else common & here
    common = common or set()
    return {r.get("num"): " ".join(o for o in (r.get("overrides") or []) if o not in common)
            for r in results}


def _sweep_summary(state, checked) -> int:
    """Print the sweep's outcome; the exit status (1 when a job failed)."""
    results = [r for r in state.results() if r.get("num") is not None]
    if not results:
        return 0
    counts = {}
    for r in results:
        counts[r["status"]] = counts.get(r["status"], 0) + 1
    try:
        total = int(os.environ.get(ENV_TOTAL) or 0) or len(results)
    except ValueError:
        total = len(results)
    total = max(total, len(results))
    parts = ", ".join(f"{n} {s}" for s, n in sorted(counts.items()))
    print(f"[studies] sweep of {total} jobs done: {parts}", file=sys.stderr)
    failed = [r for r in results if r["status"] == "failed"]
    if not failed:
        return 0
    labels = _varying(results)
    detail = "; ".join(f"job {r['num'] + 1} ({labels.get(r['num']) or 'no overrides'}): {r['error']}"
                       for r in failed)
    print(f"studies: error: {len(failed)} of {total} jobs failed: {detail}", file=sys.stderr)
    return 1


def _close_orphans(state, root: Path, reason: str) -> int:
    """Mark KILLED the runs of jobs whose process died with the run open; how many."""
    from .runtime import tracking

    closed = 0
    for active in state.unclosed_runs():
        try:
            closed += tracking.close_if_running(active["uri"], root, active["run_id"], "KILLED", reason)
        except Exception:  # noqa: BLE001 - the store may be unreachable: the run stays RUNNING
            pass
        with contextlib.suppress(OSError):
            Path(active["_file"]).unlink()
    return closed


def _interrupted(state, error: KeyboardInterrupt, root: Path, command: str = "run") -> int:
    """After SIGINT/SIGTERM: close runs whose worker died, say what is left; exit status."""
    signum = getattr(error, "signum", None) or interrupt.received() or 2
    closed = _close_orphans(state, root, "interrupted: the job's process ended before closing its run")
    results = state.results()
    finished = sum(r["status"] in ("finished", "skipped") for r in results)
    killed = sum(r["status"] == "killed" for r in results) + closed
    name = {2: "SIGINT", 15: "SIGTERM"}.get(signum, f"signal {signum}")
    if command != "run":
        print(f"studies: interrupted by {name}", file=sys.stderr)
    else:
        print(f"studies: interrupted by {name}: {finished} job(s) finished, {killed} run(s) marked "
              "KILLED; run the same command with resume=true to run the rest", file=sys.stderr)
    return 128 + signum


def _start_sweep(checked, command: str, args: list[str], root: Path) -> dict | None:
    """The parent run of a sweep of `studies run` or `discover` (None otherwise)."""
    if checked is None or not checked.multirun or command not in ("run", "discover"):
        return None
    from .runtime import tracking

    label = checked.preset or " ".join(a for a in args if not a.startswith("-")) or "defaults"
    experiment = checked.experiment or ("discover" if command == "discover" else "studies")
    return tracking.start_sweep(experiment, checked.tracking_uri, root, f"sweep {label}"[:250],
                                {"command": f"studies {command}", "overrides": " ".join(args)[:5000],
                                 "preset": checked.preset or "none",
                                 **tracking.source_tags(root, f"studies {command}")})


def _end_sweep(sweep: dict | None, state, status: str, error: str | None = None) -> None:
    """Close the parent run with the jobs' outcome; print how to look at the sweep."""
    if sweep is None:
        return
    from .runtime import tracking

    results = [r for r in state.results() if r.get("num") is not None]
    counts = {s: sum(r["status"] == s for r in results) for s in ("finished", "skipped", "failed", "killed")}
    dirs = {str(Path(r["out_dir"]).parent) for r in results if r.get("out_dir")}
    tags = {"multirun_dir": dirs.pop()} if len(dirs) == 1 else {}
    if error:
        tags["error"] = error
    try:
        tracking.end_sweep(sweep, status, {f"jobs/{k}": v for k, v in counts.items()}, tags)
    except Exception as failure:  # noqa: BLE001 - the jobs' runs are recorded; say what is left open
        print(f"studies: warning: the sweep's parent run {sweep['run_id']} could not be closed: "
              f"{_one_line(failure)}", file=sys.stderr)
        return
    experiment = tracking.experiment_of(sweep)
    print(f"[studies] sweep {sweep['sweep_id']} in experiment '{experiment}': "
          f"studies report report.experiment={experiment} report.sweep={sweep['sweep_id']}; "
          f"studies ui to browse it", file=sys.stderr)


def _hydra(task, config_name: str, command: str, args: list[str]) -> int:
    """Check the command line, run the Hydra app, report the outcome in one line."""
    import hydra

    verbose = verbose_requested(args)
    root = Path.cwd()
    try:
        checked = check_arguments(config_name, args, root, command)
        if checked is not None:
            from .runtime import tracking

            tracking.check_store(checked.tracking_uri, root)
    except StudiesError as error:
        _fail(error, verbose)
    verbose = verbose or bool(checked and checked.verbose)
    state = JobState.create()
    interrupt.set_stopper(state.stop_jobs)
    full_error = os.environ.get("HYDRA_FULL_ERROR")
    os.environ["HYDRA_FULL_ERROR"] = "1"      # Hydra's errors reach us (one line below)
    sys.argv = [f"studies {command}"] + args
    app = hydra.main(version_base="1.3", config_path="conf", config_name=config_name)(task)
    sweep = _start_sweep(checked, command, args, root)
    try:
        app()
        if interrupt.received() is not None:    # the launcher's own raise was dropped by Python
            raise interrupt.Interrupted(interrupt.received())    # (it landed in a weakref callback)
        status = _sweep_summary(state, checked)
        _end_sweep(sweep, state, "FAILED" if status else "FINISHED")
        return status
    except KeyboardInterrupt as error:
        code = _interrupted(state, error, root, command)
        _end_sweep(sweep, state, "KILLED")
        return code
    except Exception as error:  # noqa: BLE001 - Hydra or launcher errors
        _end_sweep(sweep, state, "FAILED", _one_line(error))
        if verbose or full_error == "1":
            raise
        from omegaconf.errors import OmegaConfBaseException

        bad_config = isinstance(error, OmegaConfBaseException) or \
            type(error).__module__.startswith("hydra.errors")
        print(f"studies: error: {_one_line(error)}", file=sys.stderr)
        return 2 if bad_config else 1
    finally:
        interrupt.set_stopper(None)
        if state.unclosed_runs():       # a worker died (SIGKILL, out of memory) with its run open
            _close_orphans(state, root, "the job's process died before closing its run")
        if full_error is None:
            os.environ.pop("HYDRA_FULL_ERROR", None)
        else:
            os.environ["HYDRA_FULL_ERROR"] = full_error
        state.remove()


UI_USAGE = """usage: studies ui [tracking.uri=URI] [host=127.0.0.1] [port=5000]

Start the MLflow UI on the project's store and print its address.

  tracking.uri  the store (default: $MLFLOW_TRACKING_URI when set, else mlruns/mlflow.db here)
  host          address to listen on (default 127.0.0.1, this machine only)
  port          port to listen on (default 5000)
"""


def _version() -> str:
    """The installed package's version."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("studies")
    except PackageNotFoundError:
        return "unknown"


def _ui(args: list[str]) -> int:
    """``studies ui [tracking.uri=URI] [host=127.0.0.1] [port=5000]``."""
    from .runtime.ui import serve

    if any(a in ("-h", "--help", "help") for a in args):
        print(UI_USAGE)
        return 0
    options = {"tracking.uri": None, "host": "127.0.0.1", "port": "5000"}
    for arg in args:
        key, sep, value = arg.partition("=")
        if not sep or key not in options:
            print(f"studies: error: ui takes tracking.uri=, host= and port=, got '{arg}'", file=sys.stderr)
            return 2
        options[key] = value
    try:
        port = int(options["port"])
    except ValueError:
        print(f"studies: error: port must be an integer, got '{options['port']}'", file=sys.stderr)
        return 2
    return serve(options["tracking.uri"], Path.cwd(), options["host"], port)


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``studies`` console script."""
    # One BLAS thread per process: the regressions are small and sweeps run one
    # process per core, where multi-threaded BLAS contends and runs many times slower.
    # Set before numpy is loaded; sweep workers inherit it.
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    os.environ.setdefault("MKL_NUM_THREADS", "1")
    os.environ.setdefault("MLFLOW_DISABLE_TELEMETRY", "true")
    # a local Ray instance started by hydra/launcher=ray needs no auth token file
    os.environ.setdefault("RAY_AUTH_MODE", "disabled")
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv or argv[0] in ("-h", "--help", "help"):
        print(USAGE)
        return 0
    if argv[0] in ("-V", "--version"):
        print(f"studies {_version()}")
        return 0
    command, rest = argv[0], argv[1:]
    apps = {"run": (_run_task, "config"), "simplify": (_simplify_task, "config"),
            "discover": (_discover_task, "discover"), "report": (_report_task, "report"),
            "simulate": (_simulate_task, "simulate")}
    if command in apps and any(a in ("-h", "--help", "--help-all") for a in rest):
        from .cli_help import command_help

        print(command_help(command, every="--help-all" in rest))
        return 0
    if command in apps:
        try:
            return _hydra(*apps[command], command, rest)
        except KeyboardInterrupt as error:    # before any job started
            print("studies: interrupted", file=sys.stderr)
            return 128 + getattr(error, "signum", 2)
    if command == "ui":
        return _ui(rest)
    if command == "bench":
        return _bench(rest)
    print(f"studies: error: unknown command '{command}'\n\n{USAGE}", file=sys.stderr)
    return 2


def console_main() -> None:
    """The ``studies`` console script (and ``python -m studies``): :func:`main`,
    then the process ends with its status once its exit handlers have run.

    Python's own teardown of the imported modules (numba, MLflow, SQLAlchemy,
    matplotlib) took 1.5-2 s after every command and writes nothing: the
    exit handlers run (threads joined, Hydra's job log and every logging
    handler flushed and closed) and the process leaves without it. After a
    sweep, the joblib launcher's worker processes, idle once every job has
    returned, are ended first (their own teardown was another 1-2 s).
    """
    argv = sys.argv[1:]
    status = main(argv)
    if any(a in ("-m", "--multirun") for a in argv):
        _end_sweep_workers()
    import atexit
    import threading

    shutdown = getattr(threading, "_shutdown", None)
    if shutdown is None:                    # an interpreter without it: the normal way
        sys.exit(status)
    shutdown()                              # what the interpreter does first: join the threads
    atexit._run_exitfuncs()
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(status if isinstance(status, int) else 1)


def _end_sweep_workers() -> None:
    """End the joblib launcher's idle worker processes (loky's reusable
    executor), if this process started them."""
    if "joblib" not in sys.modules:
        return
    from joblib.externals.loky import reusable_executor

    executor = getattr(reusable_executor, "_executor", None)
    if executor is not None:
        executor.shutdown(wait=True, kill_workers=True)


def _bench(rest: list) -> int:
    """``studies bench [NAME ...]`` and ``studies bench discover [key=value ...]``."""
    from .bench import BENCH_HELP, run_benchmarks

    if rest and rest[0] == "discover":
        from .bench_discovery import HELP, DiscoveryBench, run_discovery_bench

        if "-h" in rest or "--help" in rest:
            print(HELP)
            return 0
        try:
            settings = DiscoveryBench.from_overrides(rest[1:])
        except Exception as error:      # a bad key or value: one line
            print(f"studies: error: {error}", file=sys.stderr)
            return 2
        print(json.dumps(run_discovery_bench(settings), indent=1))
        return 0
    if any(a in ("-h", "--help") for a in rest):
        print(BENCH_HELP)
        return 0
    try:
        figures = run_benchmarks(rest)
    except StudiesError as error:       # an unknown benchmark name
        print(f"studies: error: {error}", file=sys.stderr)
        return 2
    print(json.dumps(figures, indent=1))
    return 0


if __name__ == "__main__":
    console_main()
