"""The on-disk dataset of EM-scored decisions: round trip, growth, bad input, DAgger on disk."""

from __future__ import annotations

import json
from dataclasses import asdict

import numpy as np
import pytest
import torch
from torchrl.data import LazyMemmapStorage, ReplayBuffer

from explore_rl.config import load_config
from explore_rl.envs.keys import ACTION_REWARDS, EM_ACTION, EXPERT
from explore_rl.graph.features import feature_names
from explore_rl.trainer.a2c import Learner
from explore_rl.trainer.dataset import DatasetSchema, DecisionDataset, fixed_rows, padded_batch
from explore_rl.trainer.imitation import DatasetLabels, compact_decisions
from tests.trainer.test_a2c import batch, config_for  # noqa: F401 -- the module's real batch fixture


# the on-disk columns of format explore_rl.decisions/1, as datasets were first written
# (before the env nested the labels under "expert"): they must keep loading
FORMAT_1_COLUMNS = {"x", "edges", "weights", "n_edges", "n_nodes", "action_mask", "action_rewards", "em_action",
                    "layout", "episode", "scene"}


def schema_for(config, capacity: int = 100, max_edges: int = 2048) -> DatasetSchema:
    return DatasetSchema(max_nodes=config.graph.max_nodes, max_edges=max_edges,
                         features=list(feature_names(config.graph.features)), capacity=capacity)


def labelled_rows(batch):  # noqa: F811
    flat = batch.reshape(-1)
    return flat, torch.nonzero((flat[EM_ACTION] >= 0) & flat["action_mask"].any(-1)).flatten()


def test_decisions_written_to_disk_give_the_actor_the_logits_of_the_original_observation(batch, tmp_path):  # noqa: F811
    config = config_for()
    torch.manual_seed(0)
    learner = Learner(config)
    flat, labelled = labelled_rows(batch)
    assert len(labelled) > 0
    dataset = DecisionDataset(tmp_path / "ds", schema_for(config))
    assert dataset.append(compact_decisions(batch), scene="street") == len(labelled)
    reopened = DecisionDataset(tmp_path / "ds")  # a fresh process would see exactly this
    replayed = padded_batch(reopened.rows())
    width = replayed["x"].shape[1]
    assert width == int(flat["node_mask"][labelled].sum(-1).max())
    with torch.no_grad():
        original = learner.actor.get_dist(flat[labelled]).logits
        again = learner.actor.get_dist(replayed).logits
    mask = flat["action_mask"][labelled]
    assert torch.equal(replayed["action_mask"], mask[:, :width]) and not mask[:, width:].any()
    torch.testing.assert_close(again[replayed["action_mask"]], original[mask], rtol=0, atol=1e-6)
    torch.testing.assert_close(replayed[ACTION_REWARDS], flat[ACTION_REWARDS][labelled][:, :width])
    assert torch.equal(replayed[EM_ACTION], flat[EM_ACTION][labelled])
    rows = reopened.rows()
    assert torch.equal(rows["layout"], flat["layout"][labelled])
    assert torch.equal(rows["episode"], flat["episode"][labelled])
    assert reopened.schema.scenes == ["street"] and (rows["scene"] == 0).all()


def test_a_second_writer_appends_and_a_reopened_dataset_has_every_row(batch, tmp_path):  # noqa: F811
    config = config_for()
    decisions = compact_decisions(batch)
    first = DecisionDataset(tmp_path / "ds", schema_for(config))
    first.append(decisions[:3], scene="street")
    del first
    second = DecisionDataset(tmp_path / "ds", schema_for(config))  # another run, same shapes
    assert len(second) == 3
    second.append(decisions, scene="office")
    del second
    reopened = DecisionDataset(tmp_path / "ds")
    assert len(reopened) == 3 + len(decisions)
    rows = reopened.rows()
    expected = decisions[:3] + decisions
    for row, decision in enumerate(expected):
        n = decision["x"].shape[0]
        assert int(rows["n_nodes"][row]) == n
        assert torch.equal(rows["x"][row, :n], decision["x"])
        assert int(rows["em_action"][row]) == int(decision["em_action"])
    assert reopened.schema.scenes == ["street", "office"]
    assert rows["scene"][:3].eq(0).all() and rows["scene"][3:].eq(1).all()


def test_a_dataset_samples_padded_minibatches_the_actor_reads(batch, tmp_path):  # noqa: F811
    config = config_for()
    dataset = DecisionDataset(tmp_path / "ds", schema_for(config), batch_size=4)
    dataset.append(compact_decisions(batch))
    torch.manual_seed(3)
    sample = dataset.sample()
    assert sample.shape == (4,)
    assert (sample["action_mask"] <= sample["node_mask"]).all()
    assert torch.equal(sample["adj"], sample["adj"].transpose(1, 2))
    Learner(config).actor.get_dist(sample)  # no error: the keys and shapes the actor reads


def test_a_dataset_written_with_flat_label_columns_still_loads_with_the_labels_nested(batch, tmp_path):  # noqa: F811
    """The stored forms keep the flat column names (a compact decision, a row on disk), so
    datasets and checkpoint buffers written before the env nested its labels still load;
    a batch made from them carries the labels under ("expert", ...) like the env."""
    config = config_for()
    flat, labelled = labelled_rows(batch)
    decisions = compact_decisions(batch)
    assert {"em_action", "action_rewards"} <= set(decisions[0].keys()) and EXPERT not in decisions[0].keys()
    schema = schema_for(config)
    rows, _ = fixed_rows(decisions, schema, "street")
    assert set(rows.keys()) == FORMAT_1_COLUMNS
    # written as the first dataset code did: TorchRL's buffer over LazyMemmapStorage, dumped
    old = tmp_path / "old"
    old.mkdir()
    (old / "dataset.json").write_text(json.dumps({**asdict(schema), "format": "explore_rl.decisions/1"}))
    buffer = ReplayBuffer(storage=LazyMemmapStorage(schema.capacity, scratch_dir=old / "storage"))
    buffer.extend(rows)
    buffer.dumps(old)
    del buffer
    replayed = padded_batch(DecisionDataset(old).rows())
    assert "em_action" not in replayed.keys() and "action_rewards" not in replayed.keys()
    assert torch.equal(replayed[EM_ACTION], flat[EM_ACTION][labelled])
    width = replayed["x"].shape[1]
    torch.testing.assert_close(replayed[ACTION_REWARDS], flat[ACTION_REWARDS][labelled][:, :width])


def test_decisions_larger_than_the_schema_are_skipped_and_counted(batch):  # noqa: F811
    config = config_for()
    decisions = compact_decisions(batch)
    edges = [d["edges"].shape[1] for d in decisions]
    limit = sorted(edges)[len(edges) // 2]
    rows, dropped = fixed_rows(decisions, schema_for(config, max_edges=limit))
    assert dropped == sum(e > limit for e in edges) > 0
    assert rows.shape[0] == len(decisions) - dropped


def test_bad_dataset_paths_and_shapes_fail_in_one_line(batch, tmp_path):  # noqa: F811
    config = config_for()
    a_file = tmp_path / "file.txt"
    a_file.write_text("not a dataset")
    other = tmp_path / "other"
    other.mkdir()
    (other / "x").write_text("")
    for path, message in ((a_file, "is a file"), (other, "no dataset.json is no dataset")):
        with pytest.raises(ValueError, match=message) as error:
            load_config([f"train.dataset={path}"])
        assert "\n" not in str(error.value)
    with pytest.raises(ValueError, match="train.dataset_capacity"):
        load_config(["train.dataset_capacity=0"])
    with pytest.raises(ValueError, match="no dataset there"):
        DecisionDataset(tmp_path / "missing")
    DecisionDataset(tmp_path / "ds", schema_for(config)).append(compact_decisions(batch))
    wider = schema_for(load_config(["graph.features=extended"]))
    with pytest.raises(ValueError, match="features=") as error:
        DecisionDataset(tmp_path / "ds", wider)
    assert "\n" not in str(error.value)
    with pytest.raises(ValueError, match="no node feature 'path_length'"):
        DecisionDataset(tmp_path / "ds").columns_for(feature_names("extended"))


def test_a_run_with_train_dataset_appends_its_decisions_and_a_new_run_starts_from_them(batch, tmp_path):  # noqa: F811
    path = tmp_path / "ds"
    torch.manual_seed(0)
    config = config_for(f"train.dataset={path}", "algo.distill_coef=1.0", "algo.dagger_steps=2",
                        "algo.dagger_batch=4")
    learner = Learner(config)
    assert isinstance(learner.labels, DatasetLabels)
    stats = learner.update(batch.clone())
    count = len(compact_decisions(batch))
    assert stats.loss_replay is not None and len(learner.labels) == count
    # a new run (no replay steps even) opens the same dataset and grows it
    fresh = Learner(config_for(f"train.dataset={path}", "algo.distill_coef=1.0"))
    assert len(fresh.labels) == count
    assert fresh.update(batch.clone()).loss_replay is None
    assert len(DecisionDataset(path)) == 2 * count
    assert fresh.labels.state_dict()["decisions"] == 2 * count


LOOPS_ENV = ["scene=street", "slam=model", "planning.actions.max_frontiers=4", "explore.travel_budget=40",
             "graph.features=loops"]


def test_a_loops_copy_of_an_extended_dataset_has_the_envs_loop_length(tmp_path):
    """Real decisions of a ``graph.features=loops`` env, stored as an extended dataset would hold them (the
    first 10 columns): the derived copy's ``loop_length`` equals the env's (float32 storage), the other columns
    are the stored ones; a graph stored at ``max_nodes`` rows is left out and counted."""
    from explore_rl.envs import make_env
    from explore_rl.envs.keys import NEAREST_ACTION
    from explore_rl.trainer.dataset import derive_loops_dataset

    config = load_config(LOOPS_ENV)
    env = make_env(config)
    td, decisions = env.reset(), []
    for _ in range(6):
        decisions += compact_decisions(td.unsqueeze(0))
        td = env.step(td.set("action", td[NEAREST_ACTION]))["next"]
    loop_column = [d["x"][:, 10].clone() for d in decisions]
    assert any(bool((column > 0).any()) for column in loop_column)  # some frontier closes a loop
    for d in decisions:
        d.set("x", d["x"][:, :10].clone())
    extended = list(feature_names("extended"))
    largest = max(d["x"].shape[0] for d in decisions)
    source = DecisionDataset(tmp_path / "ext", DatasetSchema(max_nodes=largest, max_edges=2048, features=extended,
                                                             capacity=20))
    assert source.append(decisions, scene="street") == len(decisions)
    copy, left_out = derive_loops_dataset(source, tmp_path / "loops")
    cut = [d["x"].shape[0] == largest for d in decisions]
    assert left_out == sum(cut) and len(copy) == len(decisions) - sum(cut)
    assert copy.schema.features == list(feature_names("loops")) and copy.schema.scenes == ["street"]
    assert copy.schema.capacity == source.schema.capacity  # a copy a run can grow (train.dataset)
    rows = copy.rows()
    kept = [k for k, was_cut in enumerate(cut) if not was_cut]
    for row, k in enumerate(kept):
        n = decisions[k]["x"].shape[0]
        torch.testing.assert_close(rows["x"][row, :n, :10], decisions[k]["x"].float(), rtol=0, atol=0)
        torch.testing.assert_close(rows["x"][row, :n, 10], loop_column[k].float(), rtol=1e-5, atol=1e-5)
    with pytest.raises(ValueError, match="a loops copy needs graph.features=extended"):
        derive_loops_dataset(copy, tmp_path / "again")
    with pytest.raises(ValueError, match="already holds"):
        derive_loops_dataset(source, tmp_path / "loops")


def test_stored_edges_get_back_the_zero_length_odometry_the_adjacency_dropped():
    """Consecutive keyframes at one place have an odometry edge of length 0, which a padded adjacency cannot
    hold; the missing ``(k, k + 1)`` pairs come back at length 0, and present ones are not repeated."""
    from explore_rl.trainer.dataset import with_zero_length_odometry

    edges = np.array([[0, 1], [2, 3], [1, 3], [3, 5]])  # odometry (1, 2) and (3, 4) missing; (3, 5) joins a frontier
    weights = np.array([1.0, 2.0, 0.5, 1.5])
    got_edges, got_weights = with_zero_length_odometry(edges, weights, n_poses=5)
    assert sorted(map(tuple, got_edges.tolist())) == [(0, 1), (1, 2), (1, 3), (2, 3), (3, 4), (3, 5)]
    added = {tuple(e): w for e, w in zip(got_edges.tolist(), got_weights)}
    assert added[(1, 2)] == 0.0 and added[(3, 4)] == 0.0 and added[(0, 1)] == 1.0
