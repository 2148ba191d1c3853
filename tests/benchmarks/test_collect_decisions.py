"""benchmarks/collect_decisions.py: which tasks a resumed collection skips (per scene)."""

from __future__ import annotations

from tests.benchmarks.smoke import load_script


def test_each_scene_has_its_own_tasks_and_old_rows_count_as_office():
    tasks_done_for = load_script("benchmarks/collect_decisions.py").tasks_done_for
    rows = [{"task": 0, "layout": 3}, {"task": 1, "layout": 4, "scene": "office"},
            {"task": 0, "layout": 7, "scene": "building"}, {"session_s": 10.0}]
    assert tasks_done_for(rows, "office") == {0, 1}
    assert tasks_done_for(rows, "building") == {0}
    assert tasks_done_for(rows, "street") == set()


def test_an_actor_in_the_loop_picks_its_most_probable_frontier(tmp_path):
    import torch

    from explore_rl.config import load_config
    from explore_rl.models.actor_file import load_actor
    from tests.policy_files import TINY_MODEL, actor_file

    make_chooser = load_script("benchmarks/collect_decisions.py").make_chooser
    path, _ = actor_file(tmp_path, load_config([*TINY_MODEL, "graph.features=extended"]))
    torch.manual_seed(0)
    n = 8
    adj = torch.zeros(n, n)
    adj[torch.arange(n - 1), torch.arange(1, n)] = 1.0
    td = {"x": torch.rand(n, 10), "adj": adj + adj.T, "node_mask": torch.ones(n, dtype=torch.bool),
          "action_mask": torch.tensor([False, False, False, True, True, False, True, True])}
    actor, _ = load_actor(path)
    with torch.no_grad():
        logits = actor(td["x"], td["adj"], td["node_mask"])
    expected = int(torch.nonzero(td["action_mask"]).flatten()[logits[td["action_mask"]].argmax()])
    assert make_chooser(str(path), sample=False, seed=0)(td) == expected
    sampled = make_chooser(str(path), sample=True, seed=0)
    assert all(bool(td["action_mask"][sampled(td)]) for _ in range(20))


def complete_graph_pick(path, action_mask: list[bool], width: int, columns: list[int], seed: int):
    """A complete graph of random node features ``width`` wide and the actor's greedy frontier reading ``columns``."""
    import torch

    from explore_rl.models.actor_file import load_actor

    torch.manual_seed(seed)
    n = len(action_mask)
    adj = torch.ones(n, n) - torch.eye(n)
    mask = torch.tensor(action_mask)
    td = {"x": torch.rand(n, width) * 4, "adj": adj, "node_mask": torch.ones(n, dtype=torch.bool), "action_mask": mask}
    actor, _ = load_actor(path)
    with torch.no_grad():
        logits = actor(td["x"][:, columns], adj, td["node_mask"])
    return td, int(torch.nonzero(mask).flatten()[logits[mask].argmax()])


def test_an_actor_reads_the_leading_columns_of_a_larger_stored_set(tmp_path):

    from explore_rl.config import load_config
    from tests.policy_files import TINY_MODEL, actor_file

    script = load_script("benchmarks/collect_decisions.py")
    path, _ = actor_file(tmp_path, load_config([*TINY_MODEL, "graph.features=extended"]))
    assert script.actor_reads_stored(str(path), "loops") == ""
    assert "--features paper" in script.actor_reads_stored(str(path), "paper")
    td, expected = complete_graph_pick(path, [False, True, True, True, False, True], 11, list(range(10)), seed=1)
    assert script.make_chooser(str(path), sample=False, seed=0)(td) == expected
    assert script.make_chooser(str(path), sample=False, seed=0, stored="loops")(td) == expected


def test_an_actor_reads_its_columns_of_a_stored_set_by_name(tmp_path):
    """A ``no_covariance`` actor in the loop of an ``extended`` collection reads its 7 columns out of the 10 by
    name (not the leading ones); a stored set without them is refused naming it."""

    from explore_rl.config import load_config
    from explore_rl.graph.features import feature_names
    from tests.policy_files import TINY_MODEL, actor_file

    script = load_script("benchmarks/collect_decisions.py")
    path, _ = actor_file(tmp_path, load_config([*TINY_MODEL, "graph.features=no_covariance"]))
    assert script.actor_reads_stored(str(path), "extended") == ""
    assert "--features paper" in script.actor_reads_stored(str(path), "paper")
    extended = list(feature_names("extended"))
    columns = [extended.index(name) for name in feature_names("no_covariance")]
    td, expected = complete_graph_pick(path, [False, True, True, True, False, True, True], 10, columns, seed=2)
    assert script.make_chooser(str(path), sample=False, seed=0, stored="extended")(td) == expected
