"""Shared helpers of the reliability suite: a deterministic hypothesis profile, file hashes,
and a runner for the command line in a subprocess (what a user sees: exit code, stderr)."""

import hashlib
import importlib
import os
import pkgutil
import signal
import subprocess
import sys
from pathlib import Path

from hypothesis import HealthCheck, Phase, settings

import cq_fairing.core
from tests.conftest import REPO, data_path

# Import every core module once, outside the tests' ``simplefilter("error")`` blocks: the
# lazily imported modules are then compiled here, and a compile-time warning in one of them
# (defect D1) is pinned by its own test instead of failing every test that imports lazily.
for _module in pkgutil.iter_modules(cq_fairing.core.__path__):
    importlib.import_module(f"cq_fairing.core.{_module.name}")

__all__ = ["fuzz", "sha256", "run_cli", "REPO", "data_path"]

FUZZ_SCALE = float(os.environ.get("CQ_FAIRING_FUZZ_SCALE", "1"))


def fuzz(examples):
    """The fuzz profile with ``examples`` cases (times ``CQ_FAIRING_FUZZ_SCALE``).

    Derandomized (the same cases on every run), no example database, no shrinking (a
    failure prints the generated case and its reproduction blob; shrinking folded nets
    took over five minutes).  ``CQ_FAIRING_FUZZ_SCALE=10`` gives a ten times longer run.
    """
    return settings(
        derandomize=True, deadline=None, database=None, print_blob=True,
        phases=[Phase.explicit, Phase.generate],
        max_examples=max(1, int(examples * FUZZ_SCALE)),
        suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much,
                               HealthCheck.data_too_large],
    )


def interruptible():
    """``preexec_fn`` giving the child the default SIGINT disposition of a terminal.

    A test run started in the background of a non-interactive shell (``cmd &``) inherits
    SIGINT *ignored*, and so would every child: Ctrl-C could never reach it.  The tests
    that send SIGINT model a user at a terminal, so they restore the default first.
    """
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def sha256(path):
    """Hex digest of a file's bytes."""
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def run_cli(*args, timeout=300, cwd=None):
    """Run ``python -m cq_fairing.cli *args``; returns the CompletedProcess (text)."""
    env = dict(os.environ, PYTHONPATH=str(REPO), PYTHONWARNINGS="default")
    return subprocess.run([sys.executable, "-m", "cq_fairing.cli", *map(str, args)],
                          capture_output=True, text=True, timeout=timeout, cwd=cwd, env=env)
