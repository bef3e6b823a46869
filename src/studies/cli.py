"""The ``studies`` command: sub-commands that are Hydra apps.

``studies run [overrides]``      one study (``-m`` for a sweep)
``studies bench``                performance figures as JSON

Bad input (config values, data files) is reported as one line on stderr with
exit status 2, before any MLflow run exists; ``verbose=true`` shows the
traceback instead.
"""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path

__all__ = ["main"]

USAGE = """usage: studies <command> [key=value ...]

commands:
  run      identify a manoeuvring model from simulated or measured data and log it to MLflow
  simplify derive the simplified model (correlation + PAWN, Li et al. 2023) and log how
  report   write reports/<experiment>/index.md and index.html from the MLflow runs
  ui       start the MLflow UI on the project's store (127.0.0.1:5000)
  bench    print the performance figures as JSON

Options are Hydra overrides, e.g.
  studies run method=ls wind.speed=12 wind.direction=45 noise.wind_speed_error=-0.05
  studies run data.path=my_zigzag.csv vessel=mariner
  studies run -m wind.speed=4,8,12,16
"""


def _fail(error: Exception, verbose: bool) -> None:
    if verbose:
        raise error
    print(f"studies: error: {error}", file=sys.stderr)
    sys.exit(2)


def _run_task(cfg) -> None:
    from hydra.core.hydra_config import HydraConfig
    from hydra.utils import get_original_cwd

    from . import tracking
    from .errors import StudiesError
    from .workflows.manoeuvring import execute, prepare, run_name, run_tags

    verbose = bool(cfg.get("verbose", False))
    root = Path(get_original_cwd())
    out_dir = Path(HydraConfig.get().runtime.output_dir)
    from omegaconf import OmegaConf

    params = OmegaConf.to_container(cfg, resolve=True)
    if str(cfg.model.name) == "roll":
        from .workflows.roll_run import execute_roll, prepare_roll

        try:
            roll = prepare_roll(cfg)
        except StudiesError as error:
            _fail(error, verbose)
        name = cfg.get("run_name") or f"{roll.method} roll {'+'.join(roll.terms)} " + (
            ", ".join(Path(p).stem for p in roll.data_paths) or "synthetic") + f" seed={roll.seed}"
        tags = {"method": roll.method, "model": "roll", "manoeuvre": "roll_decay",
                "data": "measured" if roll.data_paths else "simulated", "preset": cfg.get("preset") or "none"}
        with tracking.start_run(str(cfg.tracking.experiment), name, cfg.tracking.uri, root, params,
                                tags) as run:
            metrics = execute_roll(roll, out_dir)
            run.log_outputs(metrics, out_dir)
    else:
        try:
            study = prepare(cfg, root)
        except StudiesError as error:
            _fail(error, verbose)
        name = run_name(cfg, study.settings)
        with tracking.start_run(str(cfg.tracking.experiment), name, cfg.tracking.uri, root, params,
                                run_tags(cfg, study.settings)) as run:
            metrics = execute(study, out_dir)
            run.log_outputs(metrics, out_dir)
    run_id = run.run_id
    summary = {k: v for k, v in metrics.items()
               if k.startswith(("deviation/", "runtime/", "validation/", "simulation/"))
               or k.endswith(("/fitness", "/rmse_deg", "cpu_s"))}
    print(f"run '{name}' ({run_id}) -> {out_dir}")
    print(json.dumps(summary, indent=1, sort_keys=True))


def _simplify_task(cfg) -> None:
    from hydra.core.hydra_config import HydraConfig
    from hydra.utils import get_original_cwd

    from .errors import StudiesError
    from .workflows.simplify import ensure_definition

    root = Path(get_original_cwd())
    out_dir = Path(HydraConfig.get().runtime.output_dir)
    try:
        path = ensure_definition(cfg, root, out_dir, force=True)
    except StudiesError as error:
        _fail(error, bool(cfg.get("verbose", False)))
    print(f"simplified model written: {path}")
    print((out_dir / "simplification.json").read_text())


def _report_task(cfg) -> None:
    from hydra.utils import get_original_cwd

    from .report.builder import build_report

    root = Path(get_original_cwd())
    name = cfg.report.get("experiment") or None
    try:
        path = build_report(cfg.tracking.uri, root, name, root / str(cfg.report.dir))
    except LookupError as error:
        _fail(error, bool(cfg.get("verbose", False)))
    print(f"report written: {path} and {path.with_suffix('.html')}")


def _hydra(task, config_name: str, command: str, args: list[str]) -> None:
    import hydra

    sys.argv = [f"studies {command}"] + args
    app = hydra.main(version_base="1.3", config_path="conf", config_name=config_name)(task)
    app()


def _ui(args: list[str]) -> int:
    """``studies ui [tracking.uri=URI] [host=127.0.0.1] [port=5000]``."""
    from .ui import serve

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
    os.environ.setdefault("MLFLOW_DISABLE_TELEMETRY", "true")
    # a local Ray instance started by hydra/launcher=ray needs no auth token file
    os.environ.setdefault("RAY_AUTH_MODE", "disabled")
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv or argv[0] in ("-h", "--help", "help"):
        print(USAGE)
        return 0
    command, rest = argv[0], argv[1:]
    if command == "run":
        _hydra(_run_task, "config", command, rest)
        return 0
    if command == "simplify":
        _hydra(_simplify_task, "config", command, rest)
        return 0
    if command == "report":
        _hydra(_report_task, "report", command, rest)
        return 0
    if command == "ui":
        return _ui(rest)
    if command == "bench":
        from .bench import run_benchmarks

        print(json.dumps(run_benchmarks(rest), indent=1))
        return 0
    print(f"studies: error: unknown command '{command}'\n\n{USAGE}", file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(main())
