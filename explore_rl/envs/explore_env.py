"""The TorchRL environment: one step = one exploration decision (paper Sec. III).

Observation: the exploration graph of the current decision, padded (``x``, ``adj``,
``node_mask``, ``action_mask``; explore_rl/graph/encode.py). Action: a node index; only
frontier nodes are valid (a masked categorical over ``graph.max_nodes``). Reward: the
Algorithm 1 reward of the chosen node, from EM's evaluation of *every* frontier node of
the same decision (min-max normalised, anchored on the nearest frontier), minus
``env.map_error_coef`` times the step's growth of the map error (0 by default: the paper's
reward; the terms add up to the episode's final map error). Then the robot
drives the path with SLAM (``Explorer.act``), the same exploration step the plain runner
uses.

Each decision is evaluated when it is observed, so the observation also carries, under
the ``expert`` sub-tensordict (explore_rl/envs/keys.py, out of every policy's reach), EM's
choice (``("expert", "em_action")``), the Algorithm 1 reward every frontier node would
have earned (``("expert", "action_rewards")``, 0 on other rows and when EM failed) and the
nearest frontier (``("expert", "nearest_action")``) of that state -- the labels a
distillation term needs, aligned with the action taken there.

The action spec's mask follows ``action_mask`` (``Categorical.update_mask`` at every
reset and step), so TorchRL's own random actions (``env.rand_action``, ``env.rollout``
without a policy, ``check_env_specs``) pick frontier nodes only. A final observation
offers no action; a categorical spec cannot sample from an all-False mask, so there the
mask is lifted (stepping a finished episode is an error anyway). TorchRL's
``RandomPolicy`` samples a clone of the spec made when it is built, which never sees a
later mask: a collector's random policy is ``models.actor_critic.make_random_actor()``.

An episode can be restored (:meth:`ExplorationEnv.restore`): the next reset re-runs
episode ``k`` from its seed and replays the recorded actions, which reproduces the state
exactly (everything in it is seeded). The trainer resumes a killed run this way.

Nothing inside a step ends a training run: an EM error gives reward 0 for that step (and
an EM choice of -1); an error while driving or observing ends the episode as truncated
with ``failed = True``. Both are logged and counted in :attr:`ExplorationEnv.failures`.
"""

from __future__ import annotations

import dataclasses
import logging
from collections import Counter
from dataclasses import dataclass

import numpy as np
import torch
from tensordict import TensorDict, TensorDictBase
from torchrl.data import Bounded, Categorical, Composite, Unbounded
from torchrl.envs import EnvBase

from explore_rl.config import Config
from explore_rl.envs.keys import ACTION_REWARDS, EM_ACTION, EXPERT, NEAREST_ACTION
from explore_rl.graph.encode import EncodedGraph, encode
from explore_rl.graph.exploration_graph import ExplorationGraph, graph_from_state
from explore_rl.graph.features import feature_names
from explore_rl.planning.actions import Action
from explore_rl.planning.em import EMPlanner
from explore_rl.planning.policies import PolicyConfig
from explore_rl.runner import DecisionRecord, Explorer, Status
from explore_rl.scene.build import Scene, make_scene
from explore_rl.slam.session import StageTimer
from explore_rl.state import ExplorationState

log = logging.getLogger(__name__)

TERMINATING = (Status.EXPLORED, Status.NO_FRONTIER)  # the task ended; budgets truncate
LAYOUT_STREAM = 7  # keeps the layout draw independent of the start draw of the same episode
RESET_ATTEMPTS = 3  # episodes tried at a reset before giving up (a start with no frontier)
# per-step figures besides the graph: (key, dtype)
INFO_KEYS = (
    ("explored", torch.float32),
    ("map_error", torch.float32),
    ("travel", torch.float32),
    ("loop_closures", torch.int64),
    ("keyframes", torch.int64),
    ("blocked", torch.bool),
    ("contacts", torch.int64),  # motion steps so far whose true footprint touched an obstacle
    ("failed", torch.bool),
    ("episode", torch.int64),
    ("layout", torch.int64),  # the scene seed of the episode (env.train_layouts)
)


@dataclass
class Decision:
    """One observed decision: the state, its action set, graph, encoding and rewards."""

    state: ExplorationState
    actions: list[Action]  # nearest first; actions[k] is graph.frontier_nodes[k]
    graph: ExplorationGraph
    encoded: EncodedGraph
    rewards: np.ndarray | None  # (F,) Algorithm 1 reward of each action; None if EM failed
    em_choice: int  # position in actions of EM's choice, -1 if EM failed

    def action_row(self, k: int) -> int:
        """Row of the encoded graph holding action ``k``."""
        return self.encoded.row_of(int(self.graph.frontier_nodes[k]))

    def action_of_row(self, row: int) -> int:
        """Position in ``actions`` of the frontier at encoded row ``row``."""
        node = int(self.encoded.nodes[row])
        return int(np.flatnonzero(self.graph.frontier_nodes == node)[0])


class ExplorationEnv(EnvBase):
    """Exploration decisions as a TorchRL environment (see the module docstring)."""

    def __init__(self, config: Config, device: str | torch.device = "cpu"):
        super().__init__(device=device)
        self.config = config
        self.max_nodes = int(config.graph.max_nodes)
        self.em = EMPlanner(PolicyConfig(name="em"), config.planning, robot=config.robot)
        self.timer = StageTimer()  # seconds in graph / reward / drive, summed over steps
        self.failures: Counter[str] = Counter()
        self.explorer: Explorer | None = None
        self.decision: Decision | None = None
        self.episode = 0
        self.map_error_before = 0.0  # the map error when the current step began (env.map_error_coef)
        self.max_nodes_seen = 0
        self._scenes: dict[tuple[int, int], Scene] = {}  # (layout, start) -> scene, in order of use
        self.layout_of_episode = int(config.scene.seed)
        self._pending_replay: tuple[int, list[int]] | None = None
        self._set_seed(config.seed)
        self._make_specs()

    # ------------------------------------------------------------------ specs

    def _make_specs(self) -> None:
        n, device = self.max_nodes, self.device
        flag = dict(n=2, dtype=torch.bool, device=device)
        self.observation_spec = Composite(
            x=Unbounded((n, len(feature_names(self.config.graph.features))), dtype=torch.float32, device=device),
            adj=Unbounded((n, n), dtype=torch.float32, device=device),
            node_mask=Categorical(shape=(n,), **flag),
            action_mask=Categorical(shape=(n,), **flag),
            **{EXPERT: Composite({
                EM_ACTION[1]: Bounded(-1, n - 1, shape=(), dtype=torch.int64, device=device),
                ACTION_REWARDS[1]: Bounded(-1.0, 1.0, shape=(n,), dtype=torch.float32, device=device),
                NEAREST_ACTION[1]: Bounded(0, n - 1, shape=(), dtype=torch.int64, device=device),
            }, device=device)},
            **{key: Unbounded((), dtype=dtype, device=device) for key, dtype in INFO_KEYS},
            device=device,
        )
        self.action_spec = Categorical(n=n, shape=(), dtype=torch.int64, device=device)
        self.reward_spec = Unbounded((1,), dtype=torch.float32, device=device)
        self.full_done_spec = Composite(
            done=Categorical(shape=(1,), **flag),
            terminated=Categorical(shape=(1,), **flag),
            truncated=Categorical(shape=(1,), **flag),
            device=device,
        )

    # ------------------------------------------------------------------ seeding & episodes

    def _set_seed(self, seed: int | None) -> None:
        """Episode seeds and starts derive from ``seed`` (and the episode count)."""
        self.seed = int(self.config.seed if seed is None else seed)
        self.episode = 0

    def episode_seed(self) -> int:
        return int(np.random.SeedSequence([self.seed, self.episode]).generate_state(1)[0])

    def layout(self) -> int:
        """The layout (scene seed) of the next episode: drawn from ``env.train_layouts``
        (a function of (seed, episode), so a replayed episode gets the same one), else
        ``scene.seed``."""
        bounds = self.config.env.train_layouts
        if bounds is None:
            return int(self.config.scene.seed)
        rng = np.random.default_rng([self.seed, self.episode, LAYOUT_STREAM])
        return int(rng.integers(bounds[0], bounds[1]))

    def start_index(self, n_starts: int) -> int:
        """The start of the next episode (``env.starts``)."""
        mode = self.config.env.starts
        if mode == "auto":
            mode = {"office": "cycle", "building": "sample"}.get(self.config.scene.name, "default")
        if mode == "cycle":
            return (self.seed + self.episode) % n_starts
        if mode == "sample":  # a function of (seed, episode), so a replayed episode starts alike
            return int(np.random.default_rng([self.seed, self.episode]).integers(n_starts))
        if mode == "default":
            return int(self.config.scene.start_index)
        raise ValueError(f"env.starts={mode!r}: choose auto, cycle, sample or default")

    def scene(self, layout: int, start_index: int) -> Scene:
        """The scene of ``layout`` built for ``start_index`` (kept for reuse; the least
        recently used goes beyond ``env.scene_cache``)."""
        key = (layout, start_index)
        if key in self._scenes:
            self._scenes[key] = self._scenes.pop(key)  # most recently used last
        else:
            scene_config = dataclasses.replace(self.config.scene, seed=layout, start_index=start_index)
            self._scenes[key] = make_scene(scene_config, self.config.robot, self.config.lidar)
            while len(self._scenes) > self.config.env.scene_cache:
                self._scenes.pop(next(iter(self._scenes)))
        return self._scenes[key]

    def new_explorer(self) -> Explorer:
        layout = self.layout()
        n_starts = len(self.scene(layout, self.config.scene.start_index).layout.starts)
        start = self.start_index(n_starts)
        config = dataclasses.replace(self.config, seed=self.episode_seed(),
                                     scene=dataclasses.replace(self.config.scene, seed=layout, start_index=start))
        log.debug("episode %d: layout %d, start %d, seed %d", self.episode, layout, start, config.seed)
        self.episode += 1
        self.layout_of_episode = layout
        return Explorer(config, policy=self.em, scene=self.scene(layout, start))

    # ------------------------------------------------------------------ EnvBase

    def restore(self, episode: int, actions: list[int]) -> None:
        """Make the next reset re-run ``episode`` and replay ``actions`` (encoded rows)."""
        self._pending_replay = (int(episode), [int(a) for a in actions])

    def _reset(self, tensordict: TensorDictBase | None = None, **kwargs) -> TensorDictBase:
        if self._pending_replay is not None:
            return self.replay(*self._pending_replay)
        for _ in range(RESET_ATTEMPTS):
            self.explorer = self.new_explorer()
            self.decision = self.observe()
            if self.decision is not None:
                break
            log.warning("episode %d had no reachable frontier at its start; trying the next",
                        self.episode - 1)
        if self.decision is None:
            raise RuntimeError(f"{RESET_ATTEMPTS} episodes in a row had no reachable frontier at the "
                               "start: check the scene's starts")
        info = self.explorer_info(None, failed=False)
        self.map_error_before = info["map_error"]  # the episode's first map error (env.map_error_coef)
        out = self.observation(self.decision, info)
        return out.update(self.full_done_spec.zero())

    def replay(self, episode: int, actions: list[int]) -> TensorDictBase:
        """Episode ``episode`` after ``actions``: the observation an uninterrupted run had."""
        self._pending_replay = None
        self.episode = episode
        self.explorer = self.new_explorer()
        self.decision = self.observe()
        self.map_error_before = self.explorer.session.metrics().map_error_m
        record = None
        for row in actions:
            if self.decision is None:
                raise RuntimeError(f"replaying episode {episode}: it ended before action {row}")
            _, record, failed = self.decide(self.validate_action(row, self.decision))
            if failed:
                raise RuntimeError(f"replaying episode {episode}: a step failed")
        if self.decision is None:
            raise RuntimeError(f"replaying episode {episode}: it ended with the last action")
        log.info("episode %d restored after %d decisions", episode, len(actions))
        out = self.observation(self.decision, self.explorer_info(record, failed=False))
        return out.update(self.full_done_spec.zero())

    def _step(self, tensordict: TensorDictBase) -> TensorDictBase:
        decision = self.decision
        if decision is None:
            raise RuntimeError("step() called before reset() or after the episode ended: reset the env")
        reward, record, failed = self.decide(self.validate_action(int(tensordict.get("action")), decision))
        terminated = truncated = False
        following = self.decision
        if following is None:  # the episode ended with this step
            terminated = not failed and self.explorer.result.status in TERMINATING
            following = None if terminated else self.bootstrap_decision()
            terminated = following is None  # nothing to bootstrap from: the value there is 0
            truncated = not terminated
        out = self.observation(following or decision, self.explorer_info(record, failed),
                               no_actions=self.decision is None)
        out.set("reward", torch.tensor([reward], dtype=torch.float32))
        out.set("terminated", torch.tensor([terminated]))
        out.set("truncated", torch.tensor([truncated]))
        out.set("done", torch.tensor([terminated or truncated]))
        return out

    def decide(self, k: int) -> tuple[float, DecisionRecord | None, bool]:
        """Take action ``k`` of the current decision: its reward, drive, observe the next.
        Returns ``(reward, record, failed)``; ``self.decision`` is None once the episode ends."""
        decision = self.decision
        reward = 0.0 if decision.rewards is None else float(decision.rewards[k])
        record, failed = None, False
        try:
            with self.timer("drive"):
                record = self.explorer.act(decision.state, decision.actions[k].candidate)
            reward -= self.map_error_penalty(record.map_error_m)
            self.decision = self.observe()
        except Exception:  # noqa: BLE001 -- one bad step must not end a training run
            log.exception("episode %d: driving or observing failed; the episode ends truncated", self.episode - 1)
            self.failures["step"] += 1
            self.decision, failed = None, True
        return reward, record, failed

    def map_error_penalty(self, map_error: float) -> float:
        """``env.map_error_coef`` times the map error's growth over this step (the steps' sum
        is the episode's map error at its end: whole-exploration credit for A2C); 0 when
        the coefficient is 0 or the map error is not finite (logged)."""
        coef, before = self.config.env.map_error_coef, self.map_error_before
        if not np.isfinite(map_error):
            log.warning("episode %d: map error %s; no map-error term this step", self.episode - 1, map_error)
            return 0.0
        self.map_error_before = map_error
        return coef * (map_error - before) if coef > 0 else 0.0

    def validate_action(self, action: int, decision: Decision) -> int:
        """Position in the action set of the frontier at row ``action``; a clear error otherwise."""
        mask = decision.encoded.action_mask
        if not 0 <= action < self.max_nodes or not mask[action]:
            raise ValueError(f"action {action} is not a frontier node: action_mask allows rows "
                             f"{np.flatnonzero(mask).tolist()}")
        return decision.action_of_row(action)

    # ------------------------------------------------------------------ decisions

    def observe(self) -> Decision | None:
        """The next decision (graph + Algorithm 1 rewards), or None when the episode is over."""
        with self.timer("observe"):  # escape, frontiers, one Dijkstra: as the runner does
            state = self.explorer.next_state()
        if state is None:
            return None
        with self.timer("context"):  # action set, marginals, virtual map: shared with EM
            actions = self.em.actions(state)
            context = self.em.decision_context(state)
        with self.timer("graph"):
            graph = self.graph(state, context, actions)
            encoded = encode(graph, self.max_nodes)
        self.max_nodes_seen = max(self.max_nodes_seen, graph.num_nodes)
        rewards, em_choice = None, -1
        with self.timer("reward"):
            try:
                evaluation = self.em.evaluate(state, actions, context)
                rewards, em_choice = evaluation.rewards(self.config.planning), evaluation.best
            except Exception:  # noqa: BLE001 -- reward 0 for this step, the run goes on
                log.exception("EM evaluation failed at decision %d; reward 0", len(self.explorer.result.records))
                self.failures["em"] += 1
        return Decision(state, actions, graph, encoded, rewards, em_choice)

    def graph(self, state: ExplorationState, context, actions: list[Action]) -> ExplorationGraph:
        """The exploration graph with the node features of ``graph.features``."""
        return graph_from_state(state, context, actions, self.config.graph.features,
                                self.config.planning.virtual_map.sensor_range)

    def bootstrap_decision(self) -> Decision | None:
        """At a truncation (travel budget, decision cap, a failed step): the graph of the
        state the robot is in *after* the last action, with no EM evaluation, so the value
        target bootstraps from V(s_T) and not from the previous decision's graph. None if
        there is no frontier left (then the episode is as good as terminated) or the
        state cannot be observed (logged)."""
        try:
            with self.timer("observe"):
                state = self.explorer.observe()
            if state is None:
                return None
            with self.timer("context"):
                actions = self.em.actions(state)
                context = self.em.decision_context(state)
            with self.timer("graph"):
                graph = self.graph(state, context, actions)
                encoded = encode(graph, self.max_nodes)
        except Exception:  # noqa: BLE001 -- the episode is over anyway
            log.exception("episode %d: the final state could not be observed; it ends terminated",
                          self.episode - 1)
            self.failures["final_state"] += 1
            return None
        return Decision(state, actions, graph, encoded, rewards=None, em_choice=-1)

    def explorer_info(self, record: DecisionRecord | None, failed: bool) -> dict:
        """Per-step figures: from the decision's record, or the session at a reset/failure."""
        if record is not None:
            explored, map_error, loops, keyframes = (record.explored, record.map_error_m,
                                                     record.loop_closures, record.keyframes)
            blocked, contacts = record.path_status == "blocked", record.contacts
        else:
            metrics = self.explorer.session.metrics()
            explored, map_error, loops, keyframes = (metrics.explored, metrics.map_error_m,
                                                     metrics.loop_closures, metrics.keyframes)
            blocked, contacts = False, self.explorer.robot.contacts
        return dict(explored=explored, map_error=map_error, travel=self.explorer.robot.travelled,
                    loop_closures=loops, keyframes=keyframes, blocked=blocked, contacts=contacts, failed=failed,
                    episode=self.episode - 1, layout=self.layout_of_episode)

    def observation(self, decision: Decision, info: dict, no_actions: bool = False) -> TensorDict:
        """The observation keys of ``decision``, and the action spec's mask set to its
        ``action_mask``. ``no_actions``: a final observation (every action masked; nothing
        acts on it; at a truncation the critic reads its graph)."""
        encoded = decision.encoded
        action_mask = torch.from_numpy(np.zeros_like(encoded.action_mask) if no_actions else encoded.action_mask)
        self.mask_actions(action_mask)
        em_action = -1 if decision.em_choice < 0 else decision.action_row(decision.em_choice)
        values = {
            "x": torch.from_numpy(encoded.x),
            "adj": torch.from_numpy(encoded.adj),
            "node_mask": torch.from_numpy(encoded.node_mask),
            "action_mask": action_mask,
            EXPERT: {
                EM_ACTION[1]: torch.tensor(em_action, dtype=torch.int64),
                ACTION_REWARDS[1]: torch.from_numpy(self.action_rewards(decision)),
                NEAREST_ACTION[1]: torch.tensor(decision.action_row(0), dtype=torch.int64),
            },
        }
        values.update({key: torch.tensor(info[key], dtype=dtype) for key, dtype in INFO_KEYS})
        return TensorDict(values, batch_size=())

    def mask_actions(self, action_mask: torch.Tensor) -> None:
        """Random actions drawn from the action spec pick ``action_mask`` rows. An all-False
        mask (a final observation) cannot be sampled from (``torch.multinomial`` raises), so
        it lifts the mask instead: nothing may act there, and ``step`` would refuse."""
        self.action_spec.update_mask(action_mask.to(self.device, copy=True) if bool(action_mask.any()) else None)

    def action_rewards(self, decision: Decision) -> np.ndarray:
        """``(N,)``: each frontier row's Algorithm 1 reward; 0 elsewhere or if EM failed."""
        rewards = np.zeros(self.max_nodes, dtype=np.float32)
        if decision.rewards is not None:
            for k, reward in enumerate(decision.rewards):
                rewards[decision.action_row(k)] = reward
        return rewards

    def timings_ms(self) -> dict[str, float]:
        """Milliseconds per stage summed over all steps so far."""
        return {stage: 1e3 * seconds for stage, seconds in self.timer.seconds.items()}
