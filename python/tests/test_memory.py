"""Reference counts and memory stay flat over loops of 1,000 calls."""

import sys

import numpy as np
import pytest

import potmap


def rss_bytes():
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * 4096


def loop(fn, n=1000):
    for _ in range(50):  # warm up: caches and allocator pools fill first
        fn()
    before = rss_bytes()
    for _ in range(n):
        fn()
    return rss_bytes() - before


def test_evaluate_loop_is_flat(scene, ctx, rng):
    ev = potmap.Evaluator(ctx, scene.map)
    pts = rng.uniform(0, 20, (2000, 2))
    refs = sys.getrefcount(pts)
    grown = loop(lambda: ev.evaluate(pts))
    assert sys.getrefcount(pts) == refs
    assert grown < 4 << 20, f"RSS grew by {grown} bytes over 1000 evaluations"


def test_errors_loop_is_flat(scene, ctx):
    ev = potmap.Evaluator(ctx, scene.map)
    bad = np.zeros((10, 3))
    refs = sys.getrefcount(bad)

    def call():
        with pytest.raises(ValueError):
            ev.evaluate(bad)
        with pytest.raises(potmap.ArgumentError):
            potmap.score(np.array([2.0]), np.array([1]))

    grown = loop(call)
    assert sys.getrefcount(bad) == refs
    assert grown < 4 << 20


def test_map_and_sinkhorn_loops_are_flat(scene, ctx, rng):
    src, dst = rng.normal(size=(20, 2)), rng.normal(size=(25, 2))
    refs = sys.getrefcount(src)

    def call():
        m = potmap.KernelMap(scene.map.positions, scene.map.gamma, scene.map.w_mean, scene.map.w_var)
        assert len(m) == len(scene.map)
        potmap.sinkhorn_reference(potmap.SinkhornProblem(src, dst, epsilon=0.05))

    grown = loop(call)
    assert sys.getrefcount(src) == refs
    assert grown < 4 << 20
