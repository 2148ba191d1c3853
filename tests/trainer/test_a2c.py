"""The A2C trainer: updates, the NaN guard, real worker processes, exact resume, bad input."""

from __future__ import annotations

import copy
import subprocess
import sys

import pytest
import torch

from explore_rl.config import load_config
from explore_rl.envs import make_env
from explore_rl.envs.keys import ACTION_REWARDS, EM_ACTION, NEAREST_ACTION
from explore_rl.models.actor_critic import Dropout
from explore_rl.models.actor_file import TRAINING_PREFIX
from explore_rl.trainer.a2c import (Learner, TrainingRun, decision_stakes, make_collector, same_observation, train,
                                    write_state_values)
from explore_rl.models.checkpoint import CheckpointError, load_checkpoint, read_checkpoint

# short, cheap episodes: a few frontiers per decision, a small travel budget
FAST = ["scene=street", "slam=model", "planning.actions.max_frontiers=3", "explore.travel_budget=30",
        "train.progress_bar=false", "algo.steps_per_update=5", "model.hidden=32", "model.mlp_hidden=32"]


def config_for(*overrides: str):
    return load_config([*FAST, *overrides])


@pytest.fixture(scope="module")
def batch():
    """One real batch [1, 10] collected by a TorchRL Collector from the env."""
    config = config_for("algo.steps_per_update=10")
    torch.manual_seed(0)
    learner = Learner(config, make_env(config).action_spec)
    collector = make_collector(config, learner.actor)
    data = next(iter(collector)).unsqueeze(0)
    collector.shutdown()
    return data


def test_the_losses_decrease_on_a_fixed_batch(batch):
    """With the value targets fixed (computed once), Adam steps on A2C's critic loss and
    the distillation term (cross-entropy to EM's choice: positive) fit the batch."""
    torch.manual_seed(0)
    config = config_for("algo.distill_coef=1.0", "algo.distill_target=em_choice", "model.dropout=0.0")
    learner = Learner(config, make_env(config).action_spec)
    with torch.no_grad():
        data = learner.loss.value_estimator(batch.clone())
    optimizer = torch.optim.Adam(learner.loss.parameters(), lr=1e-2)
    history = []
    for _ in range(40):
        losses = learner.loss(data)
        critic, distill = losses["loss_critic"], learner.distill_loss(data)
        optimizer.zero_grad()
        (critic + distill).backward()
        optimizer.step()
        history.append((critic.item(), distill.item()))
    assert history[-1][0] < 0.2 * history[0][0]
    assert history[-1][1] < 0.2 * history[0][1]


def test_the_stakes_are_the_best_reward_minus_the_mean_over_the_frontiers():
    rewards = torch.tensor([[1.0, 3.0, 5.0, 9.0], [2.0, 7.0, 0.0, 0.0], [4.0, 0.0, 0.0, 0.0]])
    mask = torch.tensor([[True, True, True, False], [True, True, False, False], [True, False, False, False]])
    expected = [5.0 - (1 + 3 + 5) / 3, 7.0 - 4.5, 0.0]  # the masked 9 is not a frontier; one frontier: 0
    assert decision_stakes(rewards, mask).tolist() == pytest.approx(expected)
    assert decision_stakes(torch.zeros(1, 3), torch.zeros(1, 3, dtype=torch.bool)).tolist() == [0.0]


def test_the_stakes_target_is_the_stakes_weighted_mean_of_the_em_choice_losses(batch):
    """``em_choice_stakes`` on a real batch equals the stakes-weighted mean, computed here one
    decision at a time, of ``em_choice``'s cross-entropy; decisions EM did not label are left out."""
    torch.manual_seed(0)
    config = config_for("algo.distill_coef=1.0", "algo.distill_target=em_choice_stakes", "model.dropout=0.0")
    learner = Learner(config, make_env(config).action_spec)
    plain = Learner(config_for("algo.distill_coef=1.0", "algo.distill_target=em_choice", "model.dropout=0.0"),
                    make_env(config).action_spec)
    plain.actor.load_state_dict(learner.actor.state_dict())
    data = batch.clone()
    data[EM_ACTION][0, 0] = -1  # EM failed here: no label
    weighted, total, every = 0.0, 0.0, []
    for step in range(1, data.shape[1]):
        one = data[:, step:step + 1]
        rewards = one[ACTION_REWARDS][0, 0][one["action_mask"][0, 0]]
        stakes = float(rewards.max() - rewards.mean())
        weighted += stakes * plain.distill_loss(one).item()
        total += stakes
        every.append(stakes)
    assert total > 0 and max(every) > 1.1 * min(every)  # unequal weights: not the plain mean
    assert learner.distill_loss(data).item() == pytest.approx(weighted / total, rel=1e-5)


def test_an_update_changes_the_weights_and_reports_finite_figures(batch):
    config = config_for("algo.distill_coef=1.0")
    learner = Learner(config, make_env(config).action_spec)
    before = {k: v.clone() for k, v in learner.actor.state_dict().items()}
    stats = learner.update(batch.clone())
    assert stats.loss_replay is None  # replay is off by default
    assert all(torch.isfinite(torch.tensor(v)) for v in vars(stats).values() if v is not None)
    assert stats.loss_distill != 0 and stats.grad_norm > 0
    assert any(not torch.equal(v, before[k]) for k, v in learner.actor.state_dict().items())


def test_a_nan_loss_skips_the_update_and_counts_it(batch, caplog):
    config = config_for()
    learner = Learner(config, make_env(config).action_spec)
    before = {k: v.clone() for k, v in learner.actor.state_dict().items()}
    poisoned = batch.clone()
    poisoned["next", "reward"][0, 3] = float("nan")
    with caplog.at_level("WARNING"):
        assert learner.update(poisoned) is None
    assert learner.skipped_updates == 1
    assert any("update skipped" in r.getMessage() for r in caplog.records)
    for key, value in learner.actor.state_dict().items():
        assert torch.equal(value, before[key]), key
    assert learner.update(batch.clone()) is not None  # and the next good batch trains


def test_the_sampled_action_is_always_a_frontier(batch):
    assert bool(batch["action_mask"].gather(-1, batch["action"].unsqueeze(-1)).all())


def test_resume_gives_the_same_next_update_as_an_uninterrupted_run(tmp_path):
    uninterrupted, killed = tmp_path / "a", tmp_path / "b"
    common = ["train.checkpoint_every=1", "algo.distill_coef=1.0", "algo.dagger_steps=2",
              "algo.dagger_batch=3"]
    train(config_for(*common, "train.frames=20"), uninterrupted)
    train(config_for(*common, "train.frames=10"), killed)  # stops after 2 updates ...
    state = train(config_for(*common, "train.frames=20", "resume=true"), killed)  # ... and resumes
    assert state.updates == 4 and state.frames == 20
    a = read_checkpoint(uninterrupted / "checkpoints" / "last.pt")
    b = read_checkpoint(killed / "checkpoints" / "last.pt")
    for key in a["actor"]:
        assert torch.equal(a["actor"][key], b["actor"][key]), key
    for key in a["critic"]:
        assert torch.equal(a["critic"][key], b["critic"][key]), key
    rows = (killed / "logs" / "a2c" / "scalars" / "reward.csv").read_text().splitlines()
    assert [int(float(r.split(",")[0])) for r in rows] == [5, 10, 15, 20]


def test_two_real_worker_processes_through_the_cli(tmp_path):
    out = tmp_path / "run"
    command = [sys.executable, "-c", "from explore_rl.cli import train; train()", *FAST,
               "collector.workers=2", "algo.steps_per_update=2", "train.frames=8", f"out={out}"]
    done = subprocess.run(command, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    assert "2 updates, 8 decisions" in done.stdout
    checkpoint = read_checkpoint(out / "checkpoints" / "last.pt")
    assert checkpoint["state"]["frames"] == 8 and len(checkpoint["state"]["episodes"]["running"]) == 2
    again = subprocess.run(command, capture_output=True, text=True, timeout=120)
    assert again.returncode == 2 and "add resume=true" in again.stderr


def collect_two_workers(seed: int, start_frame: int = 0, batches: int = 2):
    """``batches`` batches ``[2, 3]`` of two spawned workers, acting with the same initial weights."""
    config = config_for("collector.workers=2", "algo.steps_per_update=3", f"seed={seed}")
    torch.manual_seed(0)
    learner = Learner(config, make_env(config).action_spec)
    collector = make_collector(config, learner.actor, start_frame=start_frame)
    try:
        return torch.stack([batch for _, batch in zip(range(batches), collector)])
    finally:
        collector.shutdown()


@pytest.mark.slow  # four collectors of two spawned workers: ~1-2 min on 2 cores
def test_a_two_worker_collection_is_reproduced_by_its_seed():
    """The workers' action sampling is seeded per worker from (seed, worker, start frame):
    the same seed gives the same actions and episodes, another seed or start other ones."""
    first, again = collect_two_workers(0), collect_two_workers(0)
    assert torch.equal(first["action"], again["action"]) and torch.equal(first["episode"], again["episode"])
    torch.testing.assert_close(first["action_log_prob"], again["action_log_prob"])
    torch.testing.assert_close(first["next", "reward"], again["next", "reward"])
    assert not torch.equal(first["action"][:, 0], first["action"][:, 1])  # two workers, two streams
    other_seed, other_start = collect_two_workers(1), collect_two_workers(0, start_frame=6)
    assert not torch.equal(first["action"], other_seed["action"])
    assert not torch.equal(first["action"], other_start["action"])  # same envs, other samples


def test_bad_checkpoints_fail_with_one_line_naming_the_file(tmp_path):
    config = config_for("train.frames=5")
    train(config, tmp_path / "run")
    path = tmp_path / "run" / "checkpoints" / "last.pt"
    with pytest.raises(CheckpointError, match=r"last\.pt: model\.hidden is 32 in the checkpoint but 64"):
        load_checkpoint(path, config_for("model.hidden=64"))
    with pytest.raises(CheckpointError, match="no checkpoint there"):
        load_checkpoint(tmp_path / "missing.pt", config)
    corrupt = tmp_path / "corrupt.pt"
    corrupt.write_bytes(b"not a checkpoint")
    with pytest.raises(CheckpointError, match="corrupt.pt: not a readable checkpoint"):
        load_checkpoint(corrupt, config)
    # a different feature count: the first layer's weight no longer fits
    payload = torch.load(path, weights_only=True)
    first = next(k for k in payload["actor"] if k.endswith("weight"))
    payload["actor"][first] = torch.zeros(*payload["actor"][first].shape[:-1], 7)
    torch.save(payload, tmp_path / "features.pt")
    (tmp_path / "resume" / "checkpoints").mkdir(parents=True)
    (tmp_path / "features.pt").rename(tmp_path / "resume" / "checkpoints" / "last.pt")
    with pytest.raises(CheckpointError, match="has shape .*a different feature count"):
        TrainingRun(config_for("resume=true"), tmp_path / "resume")


@pytest.mark.parametrize("override, message", [
    ("algo.lr=-1", "algo.lr must be positive"),
    ("algo.estimator=mc", "algo.estimator='mc'"),
    ("collector.workers=0", "collector.workers must be >= 1"),
    ("algo.dagger_steps=2", "needs algo.distill_coef > 0"),
    ("collector.backend=slurm", "collector.backend='slurm'"),
    ("model.hidden=0", "model.hidden must be a positive int"),
])
def test_bad_training_configs_fail_at_start(override, message):
    with pytest.raises(ValueError, match=message):
        config_for(override)


def test_a_sweep_puts_each_run_in_its_own_folder(tmp_path):
    command = [sys.executable, "-c", "from explore_rl.cli import train; train()", "-m", "seed=0,1", *FAST,
               "algo.steps_per_update=2", "train.frames=2", f"out={tmp_path}"]
    done = subprocess.run(command, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    folders = sorted(p.name for p in tmp_path.iterdir())
    assert len(folders) == 2 and "seed=0" in folders[0].split(",") and "seed=1" in folders[1].split(",")
    for folder in folders:
        assert (tmp_path / folder / "checkpoints" / "last.pt").is_file()
        assert (tmp_path / folder / "config.yaml").is_file()


def test_a_worker_whose_env_raises_is_restarted_and_its_episode_logged_as_failed(tmp_path, monkeypatch):
    from explore_rl.envs.explore_env import ExplorationEnv

    original, calls = ExplorationEnv.new_explorer, {"n": 0}

    def flaky(self):
        calls["n"] += 1
        if calls["n"] == 2:  # the second episode's start (an auto-reset inside the collector)
            raise RuntimeError("scene server unavailable")
        return original(self)

    monkeypatch.setattr(ExplorationEnv, "new_explorer", flaky)
    run = TrainingRun(config_for("train.frames=30", "explore.travel_budget=10"), tmp_path)
    state = run.run()
    assert state.frames >= 30 and run.failed_collections == 1
    assert calls["n"] > 2
    assert any(e.failed for e in run.episodes.finished)


def record_dropout_modes(learner) -> list[bool]:
    """The ``training`` flag of the actor's dropout layers at every forward pass."""
    modes: list[bool] = []
    dropouts = [m for m in learner.actor.modules() if isinstance(m, Dropout)]
    assert dropouts
    dropouts[0].register_forward_pre_hook(lambda module, args: modes.append(module.training))
    return modes


def test_the_a2c_terms_see_the_policy_that_acted_dropout_off(batch):
    """With dropout 0.5, the A2C objective of an update equals -(log pi(a|s) * A) computed
    with the network in its acting mode (eval: dropout off). With dropout on in the loss
    the policy being differentiated would not be the one that sampled the actions."""
    config = config_for("model.dropout=0.5", "algo.entropy_coef=0.0")
    torch.manual_seed(1)
    learner = Learner(config, make_env(config).action_spec)
    modes = record_dropout_modes(learner)
    data = batch.clone()
    with torch.no_grad():
        learner.actor.eval()
        learner.critic.eval()
        expected_data = learner.loss.value_estimator(data.clone())
        log_prob = learner.actor.get_dist(expected_data).log_prob(expected_data["action"])
        expected = -(log_prob * expected_data["advantage"].squeeze(-1)).mean()
    modes.clear()
    stats = learner.update(data)
    assert modes and not any(modes)
    assert stats.loss_objective == pytest.approx(expected.item(), rel=1e-5, abs=1e-7)


def test_dagger_steps_use_dropout_and_leave_it_off_afterwards(batch):
    config = config_for("model.dropout=0.5", "algo.distill_coef=1.0", "algo.dagger_steps=2", "algo.dagger_batch=3")
    learner = Learner(config, make_env(config).action_spec)
    modes = record_dropout_modes(learner)
    learner.update(batch.clone())
    assert True in modes and False in modes  # A2C + distillation in eval mode, replay in train mode
    assert not learner.actor.training and not learner.critic.training


def _episode_batch(config) -> "torch.Tensor":
    """One whole episode of the env (actions: the nearest frontier) as a [1, T] batch."""
    from tensordict import TensorDict

    env = make_env(config)
    td = env.reset()
    steps = []
    while True:
        td = td.set("action", td[NEAREST_ACTION].clone())
        td = env.step(td)
        steps.append(td.clone())
        if bool(td["next", "done"]):
            break
        td = td["next"].clone()
    return TensorDict.maybe_dense_stack(steps, 0).unsqueeze(0)


@pytest.mark.parametrize("end", ["truncated", "terminated"])
def test_value_targets_bootstrap_at_a_truncation_and_not_at_a_termination(end):
    """TD(0) target of the last step: r + gamma V(s_T) when the episode was cut (decision
    cap) -- with s_T the graph *after* the last action, not the one before it -- and r
    alone when the task ended (here: a 13 % explored target, reached after 2 decisions)."""
    overrides = ["algo.estimator=td0", "algo.gamma=0.9", "model.dropout=0.0"]
    overrides += ["explore.max_decisions=2"] if end == "truncated" else ["explore.target_explored=0.13"]
    config = config_for(*overrides)
    torch.manual_seed(0)
    learner = Learner(config, make_env(config).action_spec)
    data = _episode_batch(config)
    last = data[0, -1]
    assert bool(last["next", end]) and bool(last["next", "done"])
    assert not bool(last["next", "action_mask"].any())
    if end == "truncated":  # the post-action graph: more keyframes than the decision before it
        assert int(last["next", "node_mask"].sum()) > int(last["node_mask"].sum())
    with torch.no_grad():
        targets = learner.loss.value_estimator(data.clone())["value_target"][0, -1]
        next_value = learner.critic(last["next"].clone())["state_value"]
    reward = last["next", "reward"]
    expected = reward + 0.9 * next_value if end == "truncated" else reward
    torch.testing.assert_close(targets, expected, rtol=1e-5, atol=1e-6)


def test_the_learners_value_targets_equal_the_estimators_own_critic_calls():
    """Episodes of 2 decisions in batches of 5: resets inside the row (the next observation
    is not the following root one) and truncations (bootstrapped). The learner's targets,
    with root values reused for the next observations that equal them, are the estimator's
    own (a critic call on each half of the batch) within float noise, and its critic ran
    on the roots and on just the next observations that differ from the following root."""
    config = config_for("explore.max_decisions=2", "model.dropout=0.0")
    torch.manual_seed(0)
    learner = Learner(config, make_env(config).action_spec)
    collector = make_collector(config, learner.actor)
    data = next(iter(collector)).unsqueeze(0)
    collector.shutdown()
    assert data["next", "truncated"].sum() >= 2 and not data["next", "done"][0, -1]
    expected = learner.value_targets_reference(data.clone())
    graphs_seen = []
    learner.critic.module.register_forward_pre_hook(lambda module, args: graphs_seen.append(args[0].shape[:-2].numel()))
    got = learner.value_targets(data.clone())
    for key in ["advantage", "value_target", "state_value", ("next", "state_value")]:
        torch.testing.assert_close(got[key], expected[key], rtol=1e-5, atol=1e-6)
    resets = int(data["next", "done"][0, :-1].sum())
    assert graphs_seen == [5, resets + 1]  # the roots, then the reset steps' and the row end's next graphs


def test_same_observation_compares_every_key_the_critic_reads():
    data = batch_of_observations()
    assert same_observation(data, data.clone()).all()
    for key in ["x", "adj", "node_mask"]:
        changed = data.clone()
        changed[key][0, 1].view(-1)[0] = ~changed[key][0, 1].view(-1)[0] if key == "node_mask" else 7.0
        assert same_observation(data, changed).tolist() == [[True, False, True]]


def test_write_state_values_reuses_a_root_value_only_where_the_observation_is_the_same():
    """A next observation equal to the following root takes its value; one that differs
    (here: the last step's, and one altered in the middle) gets the critic's own."""
    data = batch_of_observations()
    data["next"] = data.exclude("next").clone()
    data["next"][:, :-1] = data[:, 1:].exclude("next").clone()
    data["next", "x"][0, 0] += 1.0  # step 0's next graph is not step 1's root
    critic = lambda td: td.set("state_value", td["x"].sum((-1, -2)).unsqueeze(-1))  # noqa: E731
    write_state_values(critic, data)
    torch.testing.assert_close(data["next", "state_value"], critic(data["next"].clone())["state_value"])
    torch.testing.assert_close(data["state_value"], critic(data.clone())["state_value"])


def batch_of_observations():
    """A [1, 3] batch of random graph observations (4 nodes)."""
    from tensordict import TensorDict

    torch.manual_seed(0)
    return TensorDict({"x": torch.randn(1, 3, 4, 2), "adj": torch.rand(1, 3, 4, 4),
                       "node_mask": torch.rand(1, 3, 4) > 0.3}, batch_size=[1, 3])


def test_a_wall_clock_budget_ends_the_run_after_the_update_that_crosses_it(tmp_path):
    state = train(config_for("train.frames=1000", "train.max_minutes=0.0001"), tmp_path / "run")
    assert state.updates == 1 and state.frames == 5 and state.wall_s >= 0.006
    assert (tmp_path / "run" / "checkpoints" / "last.pt").is_file()
    with pytest.raises(ValueError, match="train.max_minutes must be >= 0"):
        config_for("train.max_minutes=-1")


def test_train_device_cpu_explicitly_and_a_missing_gpu_is_one_line(tmp_path):
    state = train(config_for("train.frames=5", "train.device=cpu"), tmp_path / "run")
    assert state.updates == 1
    checkpoint = read_checkpoint(tmp_path / "run" / "checkpoints" / "last.pt")
    assert all(value.device.type == "cpu" for value in checkpoint["actor"].values())
    with pytest.raises(ValueError, match=r"train.device='tpu': choose auto, cpu or cuda"):
        config_for("train.device=tpu")
    if not torch.cuda.is_available():
        from explore_rl.trainer.a2c import resolve_device

        assert resolve_device("auto").type == "cpu"
        with pytest.raises(ValueError, match="train.device=cuda: no CUDA device here"):
            resolve_device("cuda")
        command = [sys.executable, "-c", "from explore_rl.cli import train; train()", *FAST,
                   "train.device=cuda", f"out={tmp_path / 'gpu'}"]
        done = subprocess.run(command, capture_output=True, text=True, timeout=120)
        assert done.returncode == 2 and "no CUDA device here" in done.stderr
        assert len(done.stderr.strip().splitlines()) == 1 and not (tmp_path / "gpu").exists()


def test_a_learner_on_another_device_acts_with_a_cpu_copy_of_its_weights(batch):
    """What a GPU learner does, on the CPU: the collectors' actor is a separate CPU module
    that receives the learner's weights after every step."""
    from explore_rl.trainer.a2c import cpu_state

    config = config_for("algo.distill_coef=1.0")
    learner = Learner(config, make_env(config).action_spec)
    learner.acting_actor = copy.deepcopy(learner.actor)  # as a non-CPU learner builds it
    learner.update(batch.clone())
    for key, value in cpu_state(learner.actor).items():
        assert torch.equal(learner.acting_actor.state_dict()[key], value), key


def test_a_new_run_starts_from_the_initial_actor_and_a_mismatch_is_one_line(tmp_path):
    """train.init_actor: the actor of a finished run's checkpoint starts a new run (the
    distillation-then-A2C recipe); another feature set or model size is refused."""
    first = tmp_path / "first"
    train(config_for("train.frames=5", "algo.distill_coef=1.0", "algo.a2c_coef=0.0"), first)
    source = read_checkpoint(first / "checkpoints" / "last.pt")["actor"]
    config = config_for("train.frames=5", f"train.init_actor={first / 'checkpoints' / 'last.pt'}")
    torch.manual_seed(123)  # other random initial weights than the first run's
    run = TrainingRun(config, tmp_path / "second")
    started = run.learner.actor.state_dict()
    assert started.keys() == source.keys()
    for key, value in source.items():
        assert torch.equal(started[key], value), key
    fresh = Learner(config_for(), make_env(config).action_spec).actor.state_dict()
    assert any(not torch.equal(fresh[key], source[key]) for key in source)  # a real change
    extended = tmp_path / "extended"  # a wider actor cannot start a narrower run
    train(config_for("train.frames=5", "graph.features=extended"), extended)
    with pytest.raises(CheckpointError, match="graph.features=extended, this run paper"):
        TrainingRun(config_for(f"train.init_actor={extended / 'checkpoints' / 'last.pt'}"), tmp_path / "third")
    with pytest.raises(CheckpointError, match="hidden"):
        TrainingRun(config_for(f"train.init_actor={first / 'checkpoints' / 'last.pt'}", "model.hidden=16"),
                    tmp_path / "fourth")
    with pytest.raises(ValueError, match="train.init_actor=.*no such file"):
        config_for(f"train.init_actor={tmp_path / 'missing.pt'}")


def test_an_actor_of_fewer_node_features_starts_a_wider_run_deciding_as_before(tmp_path, batch):
    """train.init_actor of a paper-feature actor in an ``extended`` run: the new columns' input weights start at
    0, so on any graph (the extra columns filled with arbitrary values) the logits are the narrow actor's on its
    own columns; the feature scales of the shared columns are the file's."""
    first = tmp_path / "first"
    train(config_for("train.frames=5", "algo.distill_coef=1.0", "algo.a2c_coef=0.0"), first)
    checkpoint = first / "checkpoints" / "last.pt"
    narrow = Learner(config_for(f"train.init_actor={checkpoint}"))
    narrow.load_initial_actor(checkpoint)
    wide = Learner(config_for("graph.features=extended"))
    wide.load_initial_actor(checkpoint)
    flat = batch.reshape(-1)[:4]
    extra = torch.rand(*flat["x"].shape[:-1], 6) * 5.0
    widened = flat.clone().set("x", torch.cat([flat["x"], extra], dim=-1))
    with torch.no_grad():
        expected = narrow.actor.get_dist(flat).logits
        got = wide.actor.get_dist(widened).logits
    torch.testing.assert_close(got, expected, rtol=1e-5, atol=1e-5)
    scale = wide.actor.state_dict()[TRAINING_PREFIX + "scale.scale"]
    assert torch.equal(scale[:4], narrow.actor.state_dict()[TRAINING_PREFIX + "scale.scale"]) and len(scale) == 10
