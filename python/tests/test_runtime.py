"""Device set-up from Python: PoCL's pinned workers and the context's host helper."""

import os
import subprocess
import sys

import potmap


def _pin_twice(env):
    code = "import potmap; print(potmap.pin_pocl_workers(), potmap.pin_pocl_workers())"
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env,
                          timeout=120)
    assert done.returncode == 0, done.stderr
    return done.stdout.split()


def test_pin_pocl_workers_sets_the_variable_once_and_keeps_the_users():
    env = {k: v for k, v in os.environ.items() if k != "POCL_AFFINITY"}
    env["PYTHONPATH"] = os.pathsep.join(sys.path)
    assert _pin_twice(env) == ["True", "False"]  # set, then already set
    env["POCL_AFFINITY"] = "0"
    assert _pin_twice(env) == ["False", "False"]  # the user's value stays
