"""Batched Sinkhorn on the device against the double-precision reference."""

import threading
import time

import numpy as np

import potmap


def problems(rng, k=6):
    out = []
    for i in range(k):
        n, m = 20 + 7 * i, 30 + 3 * i
        out.append((rng.normal(size=(n, 2)), rng.normal(size=(m, 2)) + 0.3))
    return out


def test_batch_equals_the_reference(ctx, rng):
    probs = problems(rng)
    results = potmap.sinkhorn(ctx, [s for s, _ in probs], [t for _, t in probs], epsilon=0.05,
                              max_iterations=5000, options=potmap.SinkhornOptions(want_coupling=True, want_barycentric=True))
    assert len(results) == len(probs)
    for (s, t), r in zip(probs, results):
        ref = potmap.sinkhorn_reference(potmap.SinkhornProblem(s, t, epsilon=0.05, max_iterations=5000))
        assert r.converged and ref.converged
        assert abs(r.cost - ref.cost) < 1e-4 * (1 + ref.cost)
        assert r.coupling.shape == (len(s), len(t))
        assert abs(r.coupling.sum() - 1) < 1e-4
        np.testing.assert_allclose(r.coupling, ref.coupling, atol=1e-5)
        np.testing.assert_allclose(r.barycentric, ref.barycentric, atol=1e-3)
        cost = potmap.sinkhorn_cost(potmap.SinkhornProblem(s, t))
        assert abs((ref.coupling * cost).sum() - ref.cost) < 1e-9


def test_batch_class_with_weights_rotation_and_extra_points(ctx, rng):
    s, t = rng.normal(size=(15, 2)), rng.normal(size=(18, 2))
    a = rng.uniform(1, 2, 15)
    a /= a.sum()
    b = potmap.SinkhornBatch()
    i = b.add(s, t, source_weights=a, angle=0.4, epsilon=0.02, extra_points=s[:4] + 0.01)
    j = b.add(potmap.SinkhornProblem(t, s, epsilon=0.1, normalise_cost=True))
    assert (i, j) == (0, 1) and len(b) == 2
    r = b.run(ctx, want_coupling=True, want_barycentric=True)
    ref = potmap.sinkhorn_reference(b.problem(0))
    np.testing.assert_allclose(r[0].coupling.sum(axis=1), a, atol=1e-5)
    assert abs(r[0].cost - ref.cost) < 1e-4 * (1 + ref.cost)
    assert r[0].extra_mapped.shape == (4, 2)
    oos = potmap.out_of_sample_map(b.problem(0), ref.barycentric, s[:4] + 0.01)
    np.testing.assert_allclose(r[0].extra_mapped, oos, atol=1e-3)
    assert r[1].cost <= 1.0  # normalised cost


def test_gil_is_released_during_the_solve(ctx, rng):
    """Another Python thread runs while the device solves: with the GIL held it could not."""
    src = [rng.normal(size=(300, 2)) for _ in range(40)]
    dst = [rng.normal(size=(300, 2)) for _ in range(40)]
    span = {}

    def solve():
        span["start"] = time.perf_counter()
        potmap.sinkhorn(ctx, src, dst, epsilon=0.002, max_iterations=3000, tolerance=1e-9)
        span["end"] = time.perf_counter()

    worker = threading.Thread(target=solve)
    stamps = []
    worker.start()
    while worker.is_alive():
        stamps.append(time.perf_counter())
        time.sleep(0.001)
    worker.join()
    inside = [s for s in stamps if span["start"] < s < span["end"]]
    length = span["end"] - span["start"]
    assert length > 0.05, f"the solve took {length:.3f} s: too short to tell"
    assert inside and inside[-1] - inside[0] > 0.5 * length, (
        f"the main thread ran for {inside[-1] - inside[0] if inside else 0:.3f} s of {length:.3f} s")
