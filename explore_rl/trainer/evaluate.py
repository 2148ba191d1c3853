"""The evaluation protocol: does a policy decide like EM on layouts it never trained on?

Every policy -- ``learned`` (a checkpoint's actor, greedy), ``em``, ``nearest`` and
``random`` (a uniformly random frontier node, seeded per episode) -- plays exactly the
same episodes. An episode is an :class:`EpisodeSpec`: a layout (the scene's seed), a
start (an index into the scene's starts) and a noise seed; everything else comes from
one config, shared by all policies. Every decision is scored by the env's Algorithm 1
reward (EM's evaluation of every frontier node at that state: EM itself earns 0 or 1,
the nearest frontier <= 0) and compared with EM's own choice there.

Figures (:func:`summarize`): per policy the mean reward per decision (each episode
weighs the same) with a 95 % bootstrap interval over episodes, the agreement with EM,
and ``gap_closed = (learned - random) / (EM - random)`` with its own interval. The
bootstrap is *paired*: one resample of episode indices is applied to every policy, so
the interval of a difference reflects the shared episodes. Pooled over layouts and per
layout.

Held out by construction: :func:`check_held_out` refuses to score a policy on a layout
it trained on (its checkpoint says which: ``env.train_layouts`` or, for the paper's
single office, ``scene.seed``).

Results are cached per episode (:class:`EpisodeCache`, a JSON-lines file) under a key of
everything that changes the episode: the config, the spec, the decision cap, the policy
(an actor's file contents) and the source of this package.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import logging
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from multiprocessing import get_context
from pathlib import Path
from typing import Callable, Iterable, Sequence

import numpy as np

from explore_rl.config import Config
from explore_rl.envs.keys import EM_ACTION, NEAREST_ACTION
from explore_rl.intervals import percentile_levels

log = logging.getLogger(__name__)

EVAL_SEED = 1_000_003  # episode noise seeds derive from it; training seeds derive from config.seed
POLICIES = ("learned", "em", "nearest", "random")
BASELINES = ("em", "nearest", "random")
BOOTSTRAP_RESAMPLES = 2000
# the config groups an episode depends on (with the EpisodeSpec and the policy)
EPISODE_GROUPS = ("scene", "robot", "lidar", "slam", "mapping", "planning", "explore", "graph", "env")
PACKAGE_DIR = Path(__file__).resolve().parents[1]

Chooser = Callable[[object], int]  # a TensorDict observation -> an encoded row


# ---------------------------------------------------------------------- episodes


@dataclass(frozen=True)
class EpisodeSpec:
    """One evaluation episode: which layout, which start, which noise."""

    layout: int  # the scene's seed (office: object placement; building: the floor plan)
    start: int  # index into the scene's starts
    seed: int  # the episode's noise seed (motion, sensing, random policy)


def episode_specs(layouts: Sequence[int], starts: int) -> list[EpisodeSpec]:
    """The first ``starts`` starts of each layout, each with a noise seed of its own
    that depends on (layout, start) only -- never on the policy or the order."""
    return [EpisodeSpec(int(layout), start, int(np.random.SeedSequence([EVAL_SEED, int(layout), start])
                                                  .generate_state(1)[0]))
            for layout in layouts for start in range(starts)]


def episode_config(config: Config, spec: EpisodeSpec) -> Config:
    """``config`` set up for ``spec``: its layout, its start, the env on the default start."""
    return dataclasses.replace(
        config, seed=spec.seed, env=dataclasses.replace(config.env, starts="default", train_layouts=None),
        scene=dataclasses.replace(config.scene, seed=spec.layout, start_index=spec.start))


@dataclass
class EpisodeResult:
    """One policy's play of one episode."""

    policy: str
    layout: int
    start: int
    seed: int
    rewards: list[float]  # Algorithm 1 reward of every decision
    agreements: list[bool]  # per decision EM evaluated: the policy chose EM's frontier
    explored: float
    travel: float
    map_error: float

    @property
    def mean_reward(self) -> float:
        return float(np.mean(self.rewards)) if self.rewards else float("nan")

    @property
    def em_agreement(self) -> float:
        return float(np.mean(self.agreements)) if self.agreements else float("nan")


def greedy_actor(config: Config, actor_path: str | Path | None) -> Chooser:
    """The actor of ``actor_path`` (training checkpoint or actor file) choosing greedily."""
    import torch

    from explore_rl.models.actor_critic import greedy_row
    from explore_rl.models.actor_file import load_actor

    actor, _ = load_actor(actor_path)

    def choose(td) -> int:
        with torch.no_grad():
            logits = actor(td["x"], td["adj"], td["node_mask"])
        return greedy_row(logits, td["action_mask"])

    return choose


def check_actor_features(config: Config, actor_path: str | Path | None) -> None:
    """Refuse an actor that reads other node features than the episodes' graphs carry (it
    would fail in its first decision, after the baselines had played)."""
    from explore_rl.models.actor_file import read_actor_file, resolve

    wanted = read_actor_file(resolve(actor_path)).feature_set
    if wanted != config.graph.features:
        raise ValueError(f"{actor_path or 'the shipped policy'} reads graph.features={wanted}, the episodes have "
                         f"graph.features={config.graph.features}: set graph.features={wanted}")


def baseline(name: str, seed: int = 0) -> Chooser:
    """nearest, em or random (seeded) as a chooser of encoded rows."""
    if name == "nearest":
        return lambda td: int(td[NEAREST_ACTION])
    if name == "em":
        return lambda td: int(td[EM_ACTION])
    if name == "random":
        rng = np.random.default_rng(seed)
        return lambda td: int(rng.choice(np.flatnonzero(td["action_mask"].numpy())))
    raise ValueError(f"unknown policy {name!r}: choose one of {', '.join(POLICIES)}")


def play(config: Config, spec: EpisodeSpec, policy: str, choose: Chooser, max_decisions: int) -> EpisodeResult:
    """``policy`` plays episode ``spec`` for at most ``max_decisions`` decisions."""
    import torch

    from explore_rl.envs.factory import make_env

    env = make_env(episode_config(config, spec))
    env.set_seed(spec.seed)
    td = env.reset()
    rewards, agreements = [], []
    for _ in range(max_decisions):
        action = choose(td)
        if int(td[EM_ACTION]) >= 0:
            agreements.append(action == int(td[EM_ACTION]))
        out = env.step(td.set("action", torch.tensor(action)))["next"]
        rewards.append(float(out["reward"]))
        td = out
        if bool(out["done"]):
            break
    return EpisodeResult(policy, spec.layout, spec.start, spec.seed, rewards, agreements,
                         explored=float(td["explored"]), travel=float(td["travel"]), map_error=float(td["map_error"]))


def chooser(policy: str, spec: EpisodeSpec, config: Config, actor_path: str | Path | None) -> Chooser:
    if policy == "learned":
        return greedy_actor(config, actor_path)
    return baseline(policy, seed=spec.seed)


def _play_task(task: tuple) -> EpisodeResult:
    """One (config, spec, policy, actor, cap) task, in whichever process runs it."""
    config, spec, policy, actor_path, max_decisions = task
    import torch

    torch.set_num_threads(1)
    return play(config, spec, policy, chooser(policy, spec, config, actor_path), max_decisions)


# ---------------------------------------------------------------------- the cache


def source_digest() -> str:
    """A digest of this package's source: results of other code are other results."""
    digest = hashlib.sha256()
    for path in sorted(PACKAGE_DIR.rglob("*.py")):
        digest.update(path.relative_to(PACKAGE_DIR).as_posix().encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()[:16]


def config_digest(config: Config) -> str:
    """A digest of every group of ``config`` that can change an episode (``EPISODE_GROUPS``;
    the learner's, collector's and output settings cannot; the policy is keyed apart)."""
    fields = {group: dataclasses.asdict(getattr(config, group)) for group in EPISODE_GROUPS}
    return hashlib.sha256(json.dumps(fields, sort_keys=True, default=str).encode()).hexdigest()[:16]


def policy_digest(policy: str, actor_path: str | Path | None) -> str:
    if policy != "learned":
        return policy
    from explore_rl.models.actor_file import resolve

    return "learned:" + hashlib.sha256(resolve(actor_path).read_bytes()).hexdigest()[:16]


class EpisodeCache:
    """Episode results kept in a JSON-lines file, keyed on everything that changes them."""

    def __init__(self, path: Path | None):
        self.path = path
        self.results: dict[str, EpisodeResult] = {}
        if path is not None and path.is_file():
            for line in path.read_text().splitlines():
                if line.strip():
                    row = json.loads(line)
                    key = row.pop("key")
                    self.results[key] = EpisodeResult(**row)

    def get(self, key: str) -> EpisodeResult | None:
        return self.results.get(key)

    def put(self, key: str, result: EpisodeResult) -> None:
        self.results[key] = result
        if self.path is not None:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            with open(self.path, "a") as handle:
                handle.write(json.dumps({"key": key, **dataclasses.asdict(result)}) + "\n")


def episode_key(config: Config, spec: EpisodeSpec, policy_id: str, max_decisions: int, source: str) -> str:
    text = json.dumps([config_digest(episode_config(config, spec)), dataclasses.astuple(spec), policy_id,
                       max_decisions, source])
    return hashlib.sha256(text.encode()).hexdigest()[:24]


def run_protocol(config: Config, specs: Sequence[EpisodeSpec], policies: Iterable[str], max_decisions: int,
                 actor_path: str | Path | None = None, workers: int = 1, cache: Path | None = None
                 ) -> dict[str, list[EpisodeResult]]:
    """Every policy on every episode of ``specs`` (``workers`` spawned processes; cached)."""
    policies = list(policies)
    for policy in policies:
        if policy not in POLICIES:
            raise ValueError(f"unknown policy {policy!r}: choose one of {', '.join(POLICIES)}")
    if max_decisions < 1:
        raise ValueError(f"max_decisions must be >= 1, got {max_decisions}")
    if "learned" in policies:
        check_actor_features(config, actor_path)
    store, source = EpisodeCache(cache), source_digest()
    keys = {(policy, spec): episode_key(config, spec, policy_digest(policy, actor_path), max_decisions, source)
            for policy in policies for spec in specs}
    todo = [(config, spec, policy, actor_path, max_decisions) for (policy, spec), key in keys.items()
            if store.get(key) is None]
    log.info("%d episodes to play, %d cached", len(todo), len(keys) - len(todo))
    if workers > 1 and len(todo) > 1:
        with ProcessPoolExecutor(workers, mp_context=get_context("spawn")) as pool:
            for task, result in zip(todo, pool.map(_play_task, todo)):
                store.put(keys[(task[2], task[1])], result)
    else:
        for task in todo:
            store.put(keys[(task[2], task[1])], _play_task(task))
    return {policy: [store.get(keys[(policy, spec)]) for spec in specs] for policy in policies}


# ---------------------------------------------------------------------- statistics


def paired_bootstrap(values: dict[str, np.ndarray], statistic: Callable[[dict[str, np.ndarray]], float],
                     resamples: int = BOOTSTRAP_RESAMPLES, seed: int = 0) -> tuple[float, float]:
    """95 % percentile interval of ``statistic`` over resamples of the episodes, the same
    resampled indices for every policy (the episodes are shared), expanded for few episodes
    (:mod:`explore_rl.intervals`); NaN without two episodes."""
    n = len(next(iter(values.values())))
    if n < 2:  # one episode has no spread
        return float("nan"), float("nan")
    rng = np.random.default_rng(seed)
    draws = []
    for _ in range(resamples):
        index = rng.integers(0, n, n)
        draws.append(statistic({name: column[index] for name, column in values.items()}))
    draws = np.asarray(draws, dtype=float)
    draws = draws[np.isfinite(draws)]
    if len(draws) == 0:
        return float("nan"), float("nan")
    low, high = np.percentile(draws, percentile_levels(n))
    return float(low), float(high)


def gap_closed(means: dict[str, float]) -> float:
    """``(learned - random) / (EM - random)``: 0 is a random frontier, 1 is EM."""
    gap = means["em"] - means["random"]
    return float((means["learned"] - means["random"]) / gap) if gap != 0 else float("nan")


def _mean_of(values: dict[str, np.ndarray]) -> dict[str, float]:
    return {name: float(np.mean(column)) for name, column in values.items()}


def summarize_episodes(results: dict[str, list[EpisodeResult]], resamples: int = BOOTSTRAP_RESAMPLES) -> dict:
    """Per policy mean reward, its 95 % interval, EM agreement and exploration figures;
    ``gap_closed`` and its interval when learned, EM and random all played."""
    values = {name: np.array([e.mean_reward for e in episodes]) for name, episodes in results.items()}
    policies = {}
    for name, episodes in results.items():
        agreements = [a for e in episodes for a in e.agreements]
        policies[name] = {
            "mean_reward": float(np.mean(values[name])),
            "ci95": list(paired_bootstrap({name: values[name]}, lambda v, n=name: float(np.mean(v[n])), resamples)),
            "em_agreement": float(np.mean(agreements)) if agreements else float("nan"),
            "episodes": len(episodes),
            "decisions": int(sum(len(e.rewards) for e in episodes)),
            "explored": float(np.mean([e.explored for e in episodes])),
            "travel_m": float(np.mean([e.travel for e in episodes])),
            "map_error_m": float(np.mean([e.map_error for e in episodes])),
        }
    summary = {"policies": policies}
    if {"learned", "em", "random"} <= set(results):
        summary["gap_closed"] = gap_closed(_mean_of(values))
        summary["gap_closed_ci95"] = list(paired_bootstrap(values, lambda v: gap_closed(_mean_of(v)), resamples))
    return summary


def summarize(results: dict[str, list[EpisodeResult]], resamples: int = BOOTSTRAP_RESAMPLES) -> dict:
    """Pooled over every episode, and per layout (``per_layout``)."""
    summary = summarize_episodes(results, resamples)
    layouts = sorted({e.layout for episodes in results.values() for e in episodes})
    summary["layouts"] = layouts
    summary["per_layout"] = {
        str(layout): summarize_episodes({name: [e for e in episodes if e.layout == layout]
                                         for name, episodes in results.items()}, resamples)
        for layout in layouts}
    return summary


# ---------------------------------------------------------------------- held out


def layout_range(bounds: Sequence[int] | None) -> range | None:
    """``[first, stop)`` as a range (None stays None)."""
    if bounds is None:
        return None
    first, stop = (int(b) for b in bounds)
    return range(first, stop)


def training_layouts(train_config: dict) -> tuple[str | None, range]:
    """The scene and the layouts a policy trained on, from its checkpoint's config (a dict)."""
    scene = train_config.get("scene", {}) or {}
    trained = layout_range((train_config.get("env", {}) or {}).get("train_layouts"))
    if trained is None:
        seed = scene.get("seed", train_config.get("seed", 0))
        if not isinstance(seed, int):  # an unresolved interpolation such as ${seed}
            seed = train_config.get("seed", 0)
        if not isinstance(seed, int):
            raise ValueError("the policy's file names neither its training layouts (meta train_layouts) nor a "
                             "scene seed: write them into it (actor file meta['train_layouts'] = [first, stop]) "
                             "so that the protocol can refuse them")
        trained = range(seed, seed + 1)
    return scene.get("name"), trained


def check_held_out(scene: str, layouts: Sequence[int], trained_scene: str | None, trained: range,
                   what: str = "the policy") -> None:
    """Refuse layouts ``what`` trained on (same scene name, overlapping seeds)."""
    if trained_scene != scene:
        return
    overlap = sorted(set(int(layout) for layout in layouts) & set(trained))
    if overlap:
        raise ValueError(f"layouts {overlap[:5]} of scene {scene} are training layouts of {what} "
                         f"(seeds {trained.start}..{trained.stop - 1}): evaluate on held-out layouts, "
                         "or pass --allow-training-layouts for an in-sample figure")


def actor_training_config(actor_path: str | Path | None) -> dict:
    """The training config stored with an actor (actor file ``meta`` or a training checkpoint)."""
    from explore_rl.models.actor_file import read_actor_file, resolve

    actor_file = read_actor_file(resolve(actor_path))
    meta = actor_file.meta
    if "train_config" in meta:
        return meta["train_config"]
    scene_seed = meta.get("scene_seed", meta.get("seed"))
    return {"scene": {"name": meta.get("scene"), "seed": scene_seed}, "seed": meta.get("seed"),
            "env": {"train_layouts": meta.get("train_layouts")}}
