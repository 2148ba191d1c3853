"""collector.backend=ray across two Ray nodes (slow; needs the optional extra
`pip install -e .[ray]`, which `make test-slow` installs).

``ray.cluster_utils.Cluster`` starts two real Ray nodes on this machine, each a raylet
with its own object store and one CPU, so each remote collector (one CPU each) is placed
on its own node, as on a cluster of machines. Sandbox settings: no dashboard, a small object
store (the default takes 30 % of RAM per node); the nodes and the driver share this
machine's address (forcing the nodes onto 127.0.0.1 leaves the driver unable to reach them).
"""

from __future__ import annotations

import pytest
import torch

from explore_rl.envs import make_env
from explore_rl.trainer.a2c import Learner, make_collector, train
from tests.trainer.test_a2c import config_for

NODE = {"num_cpus": 1, "object_store_memory": 200 * 1024**2}
HEAD = {**NODE, "include_dashboard": False}


def node_id(collector) -> str:
    """Runs inside a remote collector: the Ray node it lives on."""
    import ray

    return ray.get_runtime_context().get_node_id()


def on_each_worker(collector, fn) -> list:
    """``fn(remote collector)`` evaluated on every Ray worker of ``collector``."""
    import ray

    return ray.get([remote.__ray_call__.remote(fn) for remote in collector.remote_collectors])


@pytest.mark.slow
def test_two_ray_nodes_collect_receive_weights_and_train(tmp_path):
    import ray
    from ray.cluster_utils import Cluster

    cluster = Cluster(initialize_head=True, head_node_args=HEAD)
    cluster.add_node(**NODE)
    cluster.wait_for_nodes()
    try:
        on_cluster = ["collector=ray", "collector.workers=2", f"collector.ray_address={cluster.address}",
                      "algo.steps_per_update=3", "planning.actions.max_frontiers=2"]
        config = config_for(*on_cluster)
        torch.manual_seed(0)
        learner = Learner(config, make_env(config).action_spec)
        collector = make_collector(config, learner.actor)
        try:
            collector.update_policy_weights_()
            batches = iter(collector)
            first = next(batches)
            workers_nodes = on_each_worker(collector, node_id)
            nodes = {node["NodeID"] for node in ray.nodes() if node["Alive"]}
            assert first.shape == (2, 3)  # one row per remote collector: both produced a batch
            assert len(set(workers_nodes)) == 2 and set(workers_nodes) == nodes, (workers_nodes, nodes)
            assert learner.update(first) is not None  # a real update changes the weights
            collector.update_policy_weights_()
            second = next(batches)
        finally:
            collector.shutdown()
        with torch.no_grad():  # the actions of both nodes were sampled by the updated actor
            updated = learner.actor.get_dist(second).log_prob(second["action"])
            before_update = learner.actor.get_dist(first).log_prob(first["action"])
        torch.testing.assert_close(second["action_log_prob"], updated, rtol=1e-4, atol=1e-4)
        assert not torch.allclose(first["action_log_prob"], before_update, atol=1e-6)

        state = train(config_for(*on_cluster, "train.frames=12"), tmp_path / "run")
        assert state.updates == 2 and state.frames == 12
        assert (tmp_path / "run" / "checkpoints" / "last.pt").is_file()
    finally:
        ray.shutdown()
        cluster.shutdown()

