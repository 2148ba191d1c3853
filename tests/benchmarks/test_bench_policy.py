"""Smoke test of benchmarks/bench_policy.py: it runs (``--smoke``: tiny batch, hidden 16)
and its JSON last line holds the figures RESULTS.md quotes. Figures are not checked,
except that the dense and PyG networks agreed."""

from __future__ import annotations

import sys
from pathlib import Path

from tests.benchmarks.smoke import ROOT, run_script

KEYS = ["ms_train_step_dense", "ms_train_step_pyg", "speedup_train", "ms_train_step_dense_1000",
        "ms_train_step_pyg_1000", "speedup_train_1000", "ms_decision_300", "ms_decision_800",
        "ms_decision_300_pyg", "ms_decision_800_pyg", "max_abs_diff_vs_pyg"]


def test_bench_policy_smoke(tmp_path: Path) -> None:
    result = run_script("benchmarks/bench_policy.py", "--smoke", cwd=tmp_path)
    assert result["smoke"] is True
    missing = [key for key in KEYS if key not in result]
    assert not missing, f"JSON last line lacks {missing} (has {sorted(result)})"
    assert set(result["ms_train_step_dense"]) == set(result["ms_train_step_pyg"]) == {"16"}
    assert result["ms_decision_300"] > 0 and result["ms_decision_800"] > 0
    assert result["max_abs_diff_vs_pyg"] < 1e-4  # same weights, same outputs


def test_synthetic_graphs_follow_the_encoder_contract() -> None:
    import importlib

    import numpy as np
    from scipy.sparse.csgraph import connected_components

    sys.path.insert(0, str(ROOT / "benchmarks"))  # the script and its `from common import ...`
    try:
        bench = importlib.import_module("bench_policy")
    finally:
        sys.path.remove(str(ROOT / "benchmarks"))
    rng = np.random.default_rng(3)
    for n in (30, 300, 800):
        graph = bench.synthetic_exploration_graph(n, rng)
        assert graph.x.shape == (n, 4) and graph.adj.shape == (n, n)
        assert np.array_equal(graph.adj, graph.adj.T) and np.all(np.diag(graph.adj) == 0)
        assert connected_components(graph.adj > 0)[0] == 1
        identity = graph.x[:, 3]
        assert np.sum(identity == 0) == 1 and 5 <= np.sum(identity == 1) <= 20
        assert np.array_equal(graph.action_mask, identity == 1)
        current = np.flatnonzero(identity == 0)[0]
        assert graph.x[current, 1] == 0  # distance to the current pose
        chain = np.diag(graph.adj, 1)[: current]
        assert np.allclose(chain, 0.5, atol=1e-5)  # keyframes 0.5 m apart
