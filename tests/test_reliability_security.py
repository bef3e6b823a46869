"""Issue 9, item 6: loopback UI, no unsafe loading of user files, no writes outside the project."""

import re
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src" / "studies"

UNSAFE = [
    (r"\bimport\s+(c?pickle|dill|shelve|marshal)\b|\bfrom\s+(c?pickle|dill|shelve|marshal)\b", "pickle-like module"),
    (r"\bpickle\.", "pickle"),
    (r"\bread_pickle\s*\(", "pandas.read_pickle"),
    (r"allow_pickle\s*=\s*True", "numpy allow_pickle"),
    (r"\b(joblib|torch)\.load\s*\(", "pickle-based load"),
    (r"\byaml\.(load|unsafe_load|full_load)\s*\(", "unsafe YAML loading"),
    (r"\byaml\.(Unsafe|Full)?Loader\b", "unsafe YAML loader"),
    (r"(?<![\w.])eval\s*\(", "eval"),
    (r"(?<![\w.])exec\s*\(", "exec"),
    (r"shell\s*=\s*True", "a shell command line"),
    (r"\bos\.system\s*\(", "os.system"),
]


def test_no_unsafe_loading_or_evaluation_in_the_package():
    found = []
    for path in sorted(SRC.rglob("*.py")):
        for number, line in enumerate(path.read_text().splitlines(), 1):
            code = line.split("#", 1)[0]
            for pattern, what in UNSAFE:
                if re.search(pattern, code):
                    found.append(f"{path.relative_to(SRC)}:{number}: {what}: {line.strip()}")
    assert not found, "\n".join(found)


def test_ui_binds_to_loopback_unless_told_otherwise(tmp_path):
    from studies.runtime.ui import ui_command

    cmd = ui_command(None, tmp_path)
    assert cmd[cmd.index("--host") + 1] == "127.0.0.1"
    cmd = ui_command(None, tmp_path, host="0.0.0.0")
    assert cmd[cmd.index("--host") + 1] == "0.0.0.0"


@pytest.mark.parametrize("value,ok", [
    ("reports", True), ("reports/sub", True), (".", True), ("a/../reports", True),
    ("/etc", False), ("../x", False), ("../../x", False), ("reports/../../x", False), ("~/x", False),
    ("", False),
])
def test_written_paths_stay_in_the_project(tmp_path, value, ok):
    from studies.errors import ConfigError
    from studies.workflows.settings import output_path

    if ok:
        assert tmp_path.resolve() in [*output_path(value, "report.dir", tmp_path).parents,
                                      output_path(value, "report.dir", tmp_path)]
    else:
        with pytest.raises(ConfigError, match="report.dir"):
            output_path(value, "report.dir", tmp_path)


def test_absolute_path_inside_the_project_or_run_directory_is_allowed(tmp_path):
    from studies.errors import ConfigError
    from studies.workflows.settings import output_path

    assert output_path(tmp_path / "reports", "report.dir", tmp_path) == (tmp_path / "reports").resolve()
    run_dir = tmp_path.parent / f"{tmp_path.name}-run"
    with pytest.raises(ConfigError):
        output_path(run_dir / "x.json", "simplify.output", tmp_path)
    assert output_path(run_dir / "x.json", "simplify.output", tmp_path, run_dir).name == "x.json"


def test_symlink_out_of_the_project_is_refused(tmp_path):
    from studies.errors import ConfigError
    from studies.workflows.settings import output_path

    project = tmp_path / "project"
    project.mkdir()
    (project / "escape").symlink_to(tmp_path)
    with pytest.raises(ConfigError):
        output_path("escape/reports", "report.dir", project)


@pytest.mark.parametrize("name", ["../../etc", "/abs/path", "..", "a/b"])
def test_report_directory_stays_inside_report_dir(tmp_path, name):
    from studies.report.builder import _report_directory

    out = _report_directory(tmp_path / "reports", name)
    assert out.parent == tmp_path / "reports"


def test_report_never_replaces_a_directory_it_did_not_write(tmp_path):
    from studies.report.builder import _report_directory

    (tmp_path / "src").mkdir()
    (tmp_path / "src" / "code.py").write_text("x = 1\n")
    with pytest.raises(LookupError, match="not a report"):
        _report_directory(tmp_path, "src")
    (tmp_path / "old").mkdir()
    (tmp_path / "old" / "index.md").write_text("# old report\n")
    assert _report_directory(tmp_path, "old") == tmp_path / "old"
