"""Per-worker episode bookkeeping of a training run.

From the collected batches ``[rows, T]`` (row ``r`` is worker ``r``'s, or, in an async
batch, the worker its ``WORKER`` entry names) it keeps, per worker, the running episode
(its index, the actions taken so far, reward and agreement with EM) and a summary of
every finished one. The running episodes are what a resumed run replays
(``EnvFactory.replay``); the summaries feed the logs and the "best" checkpoint.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np
from tensordict import TensorDictBase

from explore_rl.envs.keys import EM_ACTION, WORKER


def row_workers(batch: TensorDictBase) -> list[int]:
    """The worker of each row of ``batch`` ``[rows, T]``: the one its ``WORKER`` entry names
    (async batches), else the row's index."""
    if WORKER in batch.keys(include_nested=True):
        return [int(worker) for worker in batch[WORKER][:, 0]]
    return list(range(batch.shape[0]))


@dataclass
class EpisodeSummary:
    worker: int
    episode: int
    decisions: int
    mean_reward: float
    em_agreement: float  # fraction of decisions equal to EM's choice (where EM gave one)
    explored: float
    map_error: float
    travel: float
    loop_closures: int
    terminated: bool  # explored / no frontier (else truncated: budget, decision cap, failure)
    failed: bool


@dataclass
class RunningEpisode:
    episode: int
    actions: list[int] = field(default_factory=list)
    reward: float = 0.0
    agree: int = 0
    labelled: int = 0


class EpisodeTracker:
    """See the module docstring."""

    def __init__(self, workers: int):
        self.running: list[RunningEpisode | None] = [None] * workers
        self.next_episode: list[int | None] = [None] * workers  # after an episode ended
        self.finished: list[EpisodeSummary] = []

    def add(self, batch: TensorDictBase) -> list[EpisodeSummary]:
        """Account for a batch ``[rows, T]`` (see the module docstring); the episodes it finished."""
        columns = {key: batch[key].numpy() for key in ("episode", "action", EM_ACTION)}
        nxt = {key: batch["next", key].reshape(batch.shape).numpy()
               for key in ("reward", "done", "terminated", "explored", "map_error", "travel",
                           "loop_closures", "failed")}
        finished = []
        for row, w in enumerate(row_workers(batch)):
            for t in range(batch.shape[1]):
                episode = int(columns["episode"][row, t])
                current = self.running[w]
                if current is None or current.episode != episode:
                    current = self.running[w] = RunningEpisode(episode)
                action, label = int(columns["action"][row, t]), int(columns[EM_ACTION][row, t])
                current.actions.append(action)
                current.reward += float(nxt["reward"][row, t])
                if label >= 0:
                    current.labelled += 1
                    current.agree += action == label
                if nxt["done"][row, t]:
                    finished.append(self.summary(w, current, {k: v[row, t] for k, v in nxt.items()}))
                    self.running[w], self.next_episode[w] = None, episode + 1
        self.finished.extend(finished)
        return finished

    @staticmethod
    def summary(worker: int, episode: RunningEpisode, last: dict) -> EpisodeSummary:
        n = len(episode.actions)
        return EpisodeSummary(
            worker=worker, episode=episode.episode, decisions=n, mean_reward=episode.reward / n,
            em_agreement=episode.agree / episode.labelled if episode.labelled else float("nan"),
            explored=float(last["explored"]), map_error=float(last["map_error"]), travel=float(last["travel"]),
            loop_closures=int(last["loop_closures"]), terminated=bool(last["terminated"]),
            failed=bool(last["failed"]))

    def replays(self) -> list[tuple[int, list[int]] | None]:
        """Per worker, the episode to resume: the running one with its actions, the one
        after a finished one from its start, or None before any data."""
        out = []
        for running, upcoming in zip(self.running, self.next_episode):
            if running is not None:
                out.append((running.episode, list(running.actions)))
            else:
                out.append(None if upcoming is None else (upcoming, []))
        return out

    def abandon_running(self) -> list[tuple[int, list[int]] | None]:
        """After a collector failure: each worker's episode in progress (running, or about
        to start if the failure came at a reset; index -1 if the failure came before any
        batch of that worker arrived) is logged as failed, and every worker starts the
        episode after it afresh."""
        for w, (running, upcoming) in enumerate(zip(self.running, self.next_episode)):
            episode = running if running is not None else RunningEpisode(-1 if upcoming is None else upcoming)
            n = len(episode.actions)
            self.finished.append(EpisodeSummary(
                worker=w, episode=episode.episode, decisions=n,
                mean_reward=episode.reward / n if n else float("nan"), em_agreement=float("nan"),
                explored=float("nan"), map_error=float("nan"), travel=float("nan"), loop_closures=0,
                terminated=False, failed=True))
            self.running[w] = None
            self.next_episode[w] = None if episode.episode < 0 else episode.episode + 1
        return self.replays()

    def recent_mean_reward(self, window: int) -> float | None:
        """Mean reward per decision over the last ``window`` finished episodes (failed
        ones left out)."""
        values = [e.mean_reward for e in self.finished[-window:] if not e.failed]
        return float(np.mean(values)) if values else None

    def state_dict(self) -> dict:
        return {"running": [None if r is None else asdict(r) for r in self.running],
                "next_episode": list(self.next_episode),
                "finished": [asdict(e) for e in self.finished]}

    def load_state_dict(self, state: dict) -> None:
        if not state:
            return
        if len(state["running"]) != len(self.running):
            raise ValueError(f"the checkpoint has {len(state['running'])} workers, the config "
                             f"{len(self.running)}: resume with collector.workers={len(state['running'])}")
        self.running = [None if r is None else RunningEpisode(**r) for r in state["running"]]
        self.next_episode = list(state["next_episode"])
        self.finished = [EpisodeSummary(**e) for e in state["finished"]]
