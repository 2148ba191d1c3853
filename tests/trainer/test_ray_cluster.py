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

from explore_rl.trainer.a2c import train
from tests.trainer.test_a2c import config_for
from tests.trainer.test_ray import assert_acted_with_the_new_weights, batches_around_a_weight_change

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
                      "algo.steps_per_update=3", "planning.actions.max_frontiers=2",
                      "algo.lr=1e-2"]  # one update visibly changes the policy
        config = config_for(*on_cluster)
        workers_nodes, nodes = [], set()

        def ask_nodes(collector) -> None:
            workers_nodes.extend(on_each_worker(collector, node_id))
            nodes.update(node["NodeID"] for node in ray.nodes() if node["Alive"])

        def update(learner, batch) -> None:
            assert batch.shape == (2, 3)  # one row per remote collector: both produced a batch
            assert learner.update(batch) is not None  # a real A2C update changes the weights

        learner, first, second = batches_around_a_weight_change(config, update, ask_nodes)
        assert len(set(workers_nodes)) == 2 and set(workers_nodes) == nodes, (workers_nodes, nodes)
        assert_acted_with_the_new_weights(learner, first, second)  # on both nodes

        state = train(config_for(*on_cluster, "train.frames=12"), tmp_path / "run")
        assert state.updates == 2 and state.frames == 12
        assert (tmp_path / "run" / "checkpoints" / "last.pt").is_file()
    finally:
        ray.shutdown()
        cluster.shutdown()

