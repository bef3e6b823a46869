"""A signal whose raise Python drops is not lost, and not printed as an error.

Python prints and ignores an exception raised in a ``__del__`` method or a
weakref callback; a SIGINT that arrives just then (seen with SQLAlchemy's
registry callbacks while MLflow opens its store) must still stop the job
before its next store write, or at its end, without a traceback on stderr
that would read as a failure. Each case runs in its own
process so that the handlers are not installed in the test runner.
"""

import subprocess
import sys

import pytest

SCRIPT = """
import os, signal
from studies import interrupt

class Dropper:
    def __del__(self):
        os.kill(os.getpid(), signal.SIGINT)
        for _ in range(1000):       # the handler runs here and its exception is dropped
            pass

wrote = []
try:
    with interrupt.job():
        Dropper()
        print("survived the dropped raise", flush=True)
        if {write}:
            with interrupt.critical():
                wrote.append("outputs")
        print("job body ended", flush=True)
except interrupt.Interrupted as error:
    print(f"interrupted by {{signal.Signals(error.signum).name}}, wrote {{wrote}}", flush=True)
"""


@pytest.mark.parametrize("write", [True, False])
def test_a_dropped_interrupt_is_raised_before_the_next_store_write_or_at_the_job_end(write):
    proc = subprocess.run([sys.executable, "-c", SCRIPT.format(write=write)], capture_output=True,
                          text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.splitlines()
    assert lines[0] == "survived the dropped raise", (proc.stdout, proc.stderr)
    assert "Traceback" not in proc.stderr and "Exception ignored" not in proc.stderr, proc.stderr
    assert lines[-1] == "interrupted by SIGINT, wrote []", (proc.stdout, proc.stderr)
    assert ("job body ended" in lines) is not write     # with a write: stopped before it


def test_a_handled_interrupt_is_not_raised_again_by_the_killed_write():
    script = """
import os, signal
from studies import interrupt
try:
    with interrupt.job():
        os.kill(os.getpid(), signal.SIGINT)
        for _ in range(1000):
            pass
except interrupt.Interrupted:
    interrupt.acknowledge()
    with interrupt.critical():
        print("marked KILLED", flush=True)
"""
    proc = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0 and proc.stdout.strip() == "marked KILLED", (proc.stdout, proc.stderr)


def test_other_exceptions_dropped_in_a_finaliser_are_still_printed():
    script = """
from studies import interrupt

class Broken:
    def __del__(self):
        raise ValueError("a real error in a finaliser")

interrupt.install()
Broken()
print("done", flush=True)
"""
    proc = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0 and proc.stdout.strip() == "done", (proc.stdout, proc.stderr)
    assert "ValueError: a real error in a finaliser" in proc.stderr, proc.stderr
