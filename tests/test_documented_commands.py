"""Every command line the README and ``docs/`` show is accounted for, and passes the
command line's own checks as written.

Each documented ``studies ...`` line (:func:`documented_commands.documented_commands`)
is either run as written by ``test_documented_runs.py``,
``test_documented_discover.py``, ``test_documented_roll.py`` or the README's tour
test, or, when it takes minutes to hours (the presets over all the KVLCC2 records,
the discovery bench over seeds, a report of such a preset's runs), checked: every
job's settings composed and validated as the command line does before it runs
anything. Here all of them are checked, in process, in the folder a newcomer has
(the examples' files beside the shared data): the commands the examples run in the
fast loop, so that a documented command the current settings refuse fails it; the
checked-only ones with the slow tests.
"""

from __future__ import annotations

import pytest

import documented_commands as documented
from documented_commands import SHARED

pytestmark = pytest.mark.skipif(not (SHARED / "data").is_dir(), reason="the shared data folder is absent")


@pytest.fixture(scope="module")
def project(tmp_path_factory):
    folder = documented.examples_folder(tmp_path_factory.mktemp("newcomer"))
    documented.user_presets(folder)
    return folder


def test_the_pages_show_the_commands_this_test_knows():
    commands = documented.documented_commands()
    texts = {c.text for c in commands}
    # the README's examples, the roll ones among them, and the docs' presets are read
    assert "studies run model=roll method=nls_svm data.path=[decay1.csv] validate.path=[decay2.csv]" in texts
    assert any(c.page.startswith("docs/") and "experiment=kvlcc2_cross_facility" in c.text for c in commands)
    assert not [c for c in commands if c.text in documented.TEMPLATES]
    for command in commands:
        reason = documented.not_run(command)
        assert reason is None or len(reason) > 10, command


def _params():
    """Every documented command; those checked only (the long presets, the benches: seconds
    each to compose) are slow tests, the ones the examples run are in the fast loop."""
    return [pytest.param(c, id=str(c), marks=pytest.mark.slow) if documented.not_run(c) else pytest.param(c, id=str(c))
            for c in documented.documented_commands()]


@pytest.mark.parametrize("command", _params())
def test_every_documented_command_passes_the_checks_as_written(command, project):
    documented.check(command, project)


def test_every_command_that_is_not_checked_only_is_run_by_one_module():
    run = {c.text for which in ("runs", "discover", "roll") for c in documented.runnable(which)}
    for command in documented.documented_commands():
        assert (command.text in run) != (documented.not_run(command) is not None), command


def test_a_roll_study_takes_the_roll_method_when_none_is_given(hydra):
    """The regression behind this test: `model=roll` kept the manoeuvring default `ls`."""
    from hydra import compose

    assert compose("config", overrides=["model=roll"]).method.name == "nls"
    assert compose("discover", overrides=["model=roll"]).method.name == "nls"
    assert compose("config", overrides=["model=roll", "method=bayes"]).method.name == "bayes"
    assert compose("config", overrides=[]).method.name == "ls"
    assert compose("config", overrides=["experiment=kvlcc2_roll_calibration"]).method.name == "bayes"
