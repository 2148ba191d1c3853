"""The TorchRL exploration environment: specs, rewards, episodes, failures, worker processes."""

from __future__ import annotations

import multiprocessing
import pickle
from pathlib import Path

import numpy as np
import pytest
import torch
from torchrl.collectors import Collector, MultiSyncCollector
from torchrl.envs.utils import check_env_specs

from explore_rl.config import load_config
from explore_rl.envs import EnvFactory, make_env
from explore_rl.envs.keys import ACTION_REWARDS, EM_ACTION, EXPERT, NEAREST_ACTION
from explore_rl.graph.features import feature_names
from explore_rl.models.actor_critic import make_actor, make_critic, make_random_actor
from explore_rl.planning.em import EMPlanner
from explore_rl.planning.policies import PolicyConfig
from explore_rl.planning.reward import normalize_rewards

LAB = Path(__file__).resolve().parents[2] / "examples" / "scenes" / "lab.yaml"
# a few frontiers per decision keeps EM (the reward) cheap in tests
FAST = ["slam=model", "planning.actions.max_frontiers=3", "explore.progress_bar=false"]


def env_for(*overrides: str):
    return make_env(load_config([*FAST, *overrides]))


def run_episode(env, choose=None, max_steps: int = 400):
    """Step until done with ``choose(td) -> row`` (default: a random valid row); checks
    the action mask on every observation on the way."""
    td = env.reset()
    steps = []
    for _ in range(max_steps):
        mask = td["action_mask"]
        assert mask.any(), "an all-False action mask while the episode runs"
        assert not (mask & ~td["node_mask"]).any()
        td = env.rand_action(td) if choose is None else td.set("action", torch.tensor(choose(td)))
        assert mask[td["action"]]
        out = env.step(td)
        steps.append(out)
        if out["next", "done"].item():
            return steps
        td = out["next"]
    raise AssertionError(f"no episode end in {max_steps} steps")


def test_specs_pass_torchrl_check():
    check_env_specs(env_for("scene=office"), seed=0)


def test_the_expert_labels_ride_nested_where_no_policy_reads_them():
    env = env_for("scene=street")
    rollout = env.rollout(3)
    keys = set(rollout.keys(include_nested=True, leaves_only=True))
    for key in (EM_ACTION, ACTION_REWARDS, NEAREST_ACTION):
        assert key in keys and ("next", *key) in keys
        assert key[1] not in rollout.keys() and key[1] not in rollout["next"].keys()
    assert (rollout[EM_ACTION] >= 0).all()
    assert rollout["action_mask"].gather(-1, rollout[NEAREST_ACTION][:, None]).all()
    config = env.config
    n_features = len(feature_names(config.graph.features))
    actor, critic = make_actor(config.model, n_features, env.action_spec), make_critic(config.model, n_features)
    for module in (actor, critic):
        assert all(key != EXPERT and (isinstance(key, str) or key[0] != EXPERT) for key in module.in_keys)
    blind = rollout[0].exclude(EXPERT)  # the policy acts, and the critic values, without them
    assert blind["action_mask"][int(actor(blind.clone())["action"])]
    assert critic(blind.clone())["state_value"].isfinite().all()


def test_reward_is_algorithm_1_on_an_independent_em_evaluation_of_the_same_state():
    env = env_for("scene=office")
    td = env.reset()
    for _ in range(4):  # a few decisions in, so there is more than one frontier
        td = env.step(td.set("action", td[NEAREST_ACTION]))["next"]
    decision = env.decision
    assert len(decision.actions) > 1
    planner = EMPlanner(PolicyConfig(name="em"), env.config.planning, robot=env.config.robot)
    evaluation = planner.evaluate(decision.state)  # its own action set, context and graph copies
    expected = normalize_rewards(evaluation.raw, evaluation.nearest, env.config.planning.reward)
    np.testing.assert_array_equal(evaluation.indices, [a.candidate for a in decision.actions])
    np.testing.assert_allclose(decision.rewards, expected)
    assert td[EM_ACTION].item() == decision.action_row(evaluation.best)
    rows = [decision.action_row(k) for k in range(len(decision.actions))]
    np.testing.assert_allclose(td[ACTION_REWARDS][rows].numpy(), expected, atol=1e-6)
    assert (td[ACTION_REWARDS][~td["action_mask"]] == 0).all()
    last = len(decision.actions) - 1
    row = decision.action_row(last)
    out = env.step(td.clone().set("action", torch.tensor(row)))
    assert out["next", "reward"].item() == pytest.approx(expected[last], abs=1e-6)


def test_the_map_error_term_charges_each_steps_growth_and_sums_to_the_final_map_error():
    """``env.map_error_coef=c``: each step's reward is the chosen frontier's Algorithm 1 reward
    minus c times the growth of the map error the step reports; over an episode the terms add
    up to c times (final - initial) map error. A negative coefficient is refused in one line."""
    coef = 40.0
    env = env_for("scene=office", "seed=1", "explore.max_decisions=8", f"env.map_error_coef={coef}")
    td = env.reset()
    start = before = td["map_error"].item()
    charged = 0.0
    for _ in range(8):
        td = td.set("action", td[NEAREST_ACTION])
        algorithm_1 = td[ACTION_REWARDS][td["action"]].item()
        out = env.step(td)
        after, reward = out["next", "map_error"].item(), out["next", "reward"].item()
        assert reward == pytest.approx(algorithm_1 - coef * (after - before), abs=1e-5)
        charged += algorithm_1 - reward
        before, td = after, out["next"]
        if out["next", "done"].item():
            break
    assert before != start  # the map error moved, so the term was exercised
    assert charged == pytest.approx(coef * (before - start), abs=1e-4)
    with pytest.raises(ValueError, match="env.map_error_coef") as error:
        load_config(["env.map_error_coef=-1"])
    assert "\n" not in str(error.value)


def test_a_whole_office_episode_with_random_valid_actions_ends_done():
    env = env_for("scene=office", "seed=3")
    steps = run_episode(env)
    last = steps[-1]["next"]
    assert last["terminated"].item() or last["truncated"].item()
    assert not last["action_mask"].any()  # the final observation offers nothing
    assert env.explorer.result.status.value in ("explored", "no_reachable_frontier", "travel_budget",
                                                "max_decisions")
    if last["terminated"].item():
        assert last["explored"].item() >= 0.85 or env.explorer.result.status.value == "no_reachable_frontier"
    rewards = torch.stack([s["next", "reward"] for s in steps])
    assert rewards.min() >= -1 and rewards.max() <= 1
    travel = torch.stack([s["next", "travel"] for s in steps])
    assert torch.all(travel[1:] >= travel[:-1])
    assert env.max_nodes_seen > 0 and not env.failures


@pytest.mark.parametrize("scene", ["office", "street", "garage"])
def test_the_action_mask_is_never_empty_before_the_end_in_every_procedural_scene(scene):
    env = env_for(f"scene={scene}", "explore.travel_budget=40")
    steps = run_episode(env)
    assert steps[-1]["next", "done"].item()


def assert_valid_actions(data) -> None:
    """Every action of a rollout or batch is a frontier row of its own observation."""
    data = data.reshape(-1)
    assert data["action_mask"].any(-1).all()
    assert data["action_mask"].gather(-1, data["action"][:, None]).all()


def test_random_rollouts_take_frontier_actions_through_the_action_spec_mask():
    """No ``rand_action`` override: the spec's mask follows each observation, so TorchRL's
    own random rollout (across an episode end and the reset after it) stays valid."""
    env = env_for("scene=street", "explore.max_decisions=3")
    env.set_seed(0)
    rollout = env.rollout(7, break_when_any_done=False)
    assert_valid_actions(rollout)
    assert rollout["next", "done"].sum() >= 2  # two episodes ended inside the rollout
    assert not rollout["next", "action_mask"][rollout["next", "done"].squeeze(-1)].any()
    assert torch.equal(env.action_spec.mask, rollout[-1]["next", "action_mask"]) or rollout[-1]["next", "done"]


def test_the_final_observations_empty_mask_leaves_random_actions_possible():
    """A final observation masks every action; a categorical spec cannot sample from that
    (torch.multinomial raises), so the mask is lifted there and stepping is what refuses."""
    env = env_for("scene=street", "explore.max_decisions=1")
    td = env.reset()
    assert torch.equal(env.action_spec.mask, td["action_mask"])
    out = env.step(env.rand_action(td))["next"]
    assert out["done"].item() and not out["action_mask"].any()
    assert env.action_spec.mask is None
    with pytest.raises(RuntimeError, match="after the episode ended"):
        env.step(env.rand_action(out.clone()))
    td = env.reset()
    assert torch.equal(env.action_spec.mask, td["action_mask"])


def test_a_random_actor_in_a_collector_and_in_spawned_workers_takes_frontier_actions():
    """``make_random_actor`` reads each observation's mask (TorchRL's ``RandomPolicy`` holds a
    clone of the spec and cannot); batches cross episode ends, so the final observations'
    empty masks and the resets after them are on the way."""
    factory = EnvFactory(load_config([*FAST, "scene=street", "explore.max_decisions=3"]))
    torch.manual_seed(0)
    plain = dict(auto_register_policy_transforms=False)  # as the trainer: the env needs no policy transforms
    collector = Collector(factory, make_random_actor(), frames_per_batch=7, total_frames=7, **plain)
    batch = next(iter(collector))
    collector.shutdown()
    assert_valid_actions(batch)
    assert batch["next", "done"].sum() >= 2
    assert {EM_ACTION, ("next", *EM_ACTION)} <= set(batch.keys(include_nested=True))  # nested keys kept
    workers = MultiSyncCollector([factory, EnvFactory(factory.config, worker=1)], make_random_actor(),
                                 frames_per_batch=8, total_frames=8, **plain)
    try:
        batch = next(iter(workers))
    finally:
        workers.shutdown()
    assert_valid_actions(batch)
    assert batch["next", "done"].sum() >= 2


def test_a_scene_file_episode():
    env = env_for("scene=file", f"scene.path={LAB}", "explore.travel_budget=30")
    steps = run_episode(env, choose=lambda td: td[EM_ACTION].item())
    assert steps[-1]["next", "done"].item()
    assert all(s[EM_ACTION].item() >= 0 for s in steps)


def test_the_icp_front_end_drives_a_decision():
    env = make_env(load_config(["slam=icp", "scene=street", "planning.actions.max_frontiers=2"]))
    td = env.reset()
    out = env.step(td.set("action", td[NEAREST_ACTION]))
    assert out["next", "keyframes"].item() > td["keyframes"].item()
    assert out["next", "travel"].item() > 0


def test_office_resets_cycle_through_the_starts():
    env = env_for("scene=office")
    env.set_seed(5)
    starts = []
    for _ in range(3):
        env.reset()
        starts.append(env.explorer.scene.config.start_index)
    n = len(env.explorer.scene.layout.starts)
    assert n == 9 and starts == [(5 + k) % n for k in range(3)]


def test_an_invalid_action_names_the_mask():
    env = env_for("scene=street")
    td = env.reset()
    invalid = int(torch.nonzero(~td["action_mask"])[0, 0])
    with pytest.raises(ValueError, match="not a frontier node: action_mask allows rows"):
        env.step(td.set("action", torch.tensor(invalid)))


def test_an_em_failure_gives_reward_zero_and_the_run_goes_on(monkeypatch):
    env = env_for("scene=street")
    td = env.reset()

    def broken(*args, **kwargs):
        raise np.linalg.LinAlgError("singular")

    monkeypatch.setattr(env.em, "evaluate", broken)
    out = env.step(td.set("action", td[NEAREST_ACTION]))["next"]
    assert out[EM_ACTION].item() == -1 and not out["done"].item()
    assert (out[ACTION_REWARDS] == 0).all()
    out = env.step(out.set("action", out[NEAREST_ACTION]))
    assert out["next", "reward"].item() == 0.0
    assert env.failures["em"] == 2


def test_a_failure_while_driving_ends_the_episode_truncated(monkeypatch):
    env = env_for("scene=street")
    td = env.reset()

    def broken(*args, **kwargs):
        raise RuntimeError("iSAM2 exploded")

    monkeypatch.setattr(env.explorer, "act", broken)
    out = env.step(td.set("action", td[NEAREST_ACTION]))["next"]
    assert out["done"].item() and out["truncated"].item() and not out["terminated"].item()
    assert out["failed"].item() and env.failures["step"] == 1
    td = env.reset()  # and the next episode starts normally
    assert td["action_mask"].any()


def _reset_in_child(factory_bytes: bytes, queue) -> None:
    factory = pickle.loads(factory_bytes)
    env = factory()
    env.set_seed(7)
    td = env.reset()
    queue.put((td["x"].numpy(), td["action_mask"].numpy()))


def test_the_env_factory_works_in_a_spawned_process():
    factory = EnvFactory(load_config([*FAST, "scene=street"]))
    context = multiprocessing.get_context("spawn")
    queue = context.Queue()
    child = context.Process(target=_reset_in_child, args=(pickle.dumps(factory), queue))
    child.start()
    x, mask = queue.get(timeout=120)
    child.join(timeout=60)
    assert child.exitcode == 0
    env = factory()
    env.set_seed(7)
    td = env.reset()
    # another process may take other SIMD paths in libm/BLAS: features to 1e-9, far
    # below any change of the episode; the action set is discrete and must be identical
    np.testing.assert_allclose(td["x"].numpy(), x, rtol=0, atol=1e-9)
    np.testing.assert_array_equal(td["action_mask"].numpy(), mask)


def test_a_restored_episode_reproduces_the_observation_exactly():
    config = load_config([*FAST, "scene=street", "seed=2"])
    env = make_env(config)
    env.reset()
    env.reset()  # the second episode, so the episode index matters
    td, actions = env.reset(), []
    for _ in range(4):
        td = env.rand_action(td)
        actions.append(int(td["action"]))
        td = env.step(td)["next"]
    assert not td["done"].item()
    episode = int(td["episode"])
    assert episode == 2

    restored = make_env(config)
    restored.restore(episode, actions)
    out = restored.reset()
    for key in ("x", "adj", "node_mask", "action_mask", EM_ACTION, NEAREST_ACTION, "travel",
                "explored", "map_error", "keyframes", "loop_closures", "episode"):
        np.testing.assert_array_equal(out[key].numpy(), td[key].numpy(), err_msg=str(key))
    # and the two go on alike
    step = td.clone().set("action", td[NEAREST_ACTION])
    a, b = env.step(step)["next"], restored.step(step.clone())["next"]
    np.testing.assert_array_equal(a["x"].numpy(), b["x"].numpy())
    assert a["reward"].item() == b["reward"].item()


def test_train_layouts_draw_each_episodes_layout_from_the_range_reproducibly():
    config = load_config([*FAST, "scene=office", "env.train_layouts=[40,50]", "explore.max_decisions=1"])
    env = make_env(config)
    layouts = [int(env.reset()["layout"]) for _ in range(6)]
    assert all(40 <= layout < 50 for layout in layouts) and len(set(layouts)) > 1
    again = make_env(config)
    assert [int(again.reset()["layout"]) for _ in range(6)] == layouts
    assert len(env._scenes) <= config.env.scene_cache


def test_without_train_layouts_every_episode_is_the_scene_seed():
    env = make_env(load_config([*FAST, "scene=street", "seed=3", "explore.max_decisions=1"]))
    assert [int(env.reset()["layout"]) for _ in range(2)] == [3, 3]


@pytest.mark.parametrize("overrides,message", [
    (["env.train_layouts=[0,2000]"], "overlaps env.validation_layouts"),
    (["env.train_layouts=[5,5]"], "env.train_layouts"),
    (["env.validation_layouts=[3]"], "env.validation_layouts"),
])
def test_bad_layout_ranges_are_refused_in_one_line(overrides, message):
    with pytest.raises(ValueError, match=message):
        load_config(overrides)
