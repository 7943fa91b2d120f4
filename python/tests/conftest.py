"""Shared fixtures: one device context per session, the potmap command (the C++ results the
bindings are compared with) and small data made on the spot."""

import json
import os
import subprocess

import numpy as np
import pytest

import potmap


@pytest.fixture(scope="session")
def ctx():
    return potmap.Context(disk_cache=False)


@pytest.fixture(scope="session")
def cli():
    """Runs the potmap command built beside the module; returns its stdout."""
    path = os.environ.get("POTMAP_CLI")
    assert path and os.path.exists(path), "POTMAP_CLI must name the potmap command (set by CTest)"

    def run(*args, json_out=False):
        done = subprocess.run([path, *map(str, args)], capture_output=True, text=True, timeout=300)
        assert done.returncode == 0, f"potmap {' '.join(map(str, args))} failed:\n{done.stderr}"
        return json.loads(done.stdout) if json_out else done.stdout

    return run


@pytest.fixture(scope="session")
def data_dir():
    path = os.environ.get("POTMAP_DATA", os.path.join(os.path.dirname(__file__), "../../../shared/data"))
    assert os.path.isdir(path), f"real data folder {path} missing"
    return path


@pytest.fixture(scope="session")
def scene():
    return potmap.synthetic_scene(seed=3, spacing=1.0, test_points=500)


@pytest.fixture(scope="session")
def town_scans():
    """Six simulated scans of town1 (360 beams, 20 m)."""
    sim = potmap.simulate(potmap.Town.builtin("town1"), scans=6, spacing=3.0, seed=1)
    return sim.scans


@pytest.fixture
def rng():
    return np.random.default_rng(7)
