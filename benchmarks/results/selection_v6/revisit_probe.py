"""Do the learned policies pick frontiers whose paths revisit fewer keyframes than EM's best?
On the default's DAgger dataset (EM's Algorithm 1 reward of every frontier of 19,260 decisions, all
training data of these actors: in-sample), per actor: the mean ``revisits`` (keyframes the path
revisits: predicted loop closures) and ``path_length`` of its greedy choice and of EM's best, and how
often each picks a frontier with any revisit. No simulation.

    python benchmarks/results/selection_v6/revisit_probe.py
"""

from __future__ import annotations

import json

import torch

from explore_rl.config import load_config
from explore_rl.envs.keys import ACTION_REWARDS
from explore_rl.graph.features import feature_names
from explore_rl.trainer.a2c import Learner
from explore_rl.trainer.dataset import DecisionDataset, padded_batch
from explore_rl.trainer.offline import offline_config

DATASET = "/work/runs/data_dagger_sparse"
ACTORS = {"default": ("/work/main/policies/buildings_sparse_distill/actor.pt", 128),
          "wide": ("/work/main/benchmarks/results/selection_v5/candidate_wide_actor.pt", 256),
          "dagger_wide": ("/work/runs/dagger_wide/checkpoints/last.pt", 256)}


def choices(path: str, hidden: int, dataset: DecisionDataset) -> dict[str, float]:
    config = offline_config(load_config(["scene=building", "slam=model", "graph.features=extended",
                                         f"model.hidden={hidden}"]))
    learner = Learner(config)
    learner.load_initial_actor(path)
    learner.set_training(False)
    names = list(feature_names("extended"))
    columns = dataset.columns_for(names)
    revisits, length = names.index("revisits"), names.index("path_length")
    sums = {"policy_revisits": 0.0, "em_revisits": 0.0, "policy_path_m": 0.0, "em_path_m": 0.0,
            "policy_any_revisit": 0.0, "em_any_revisit": 0.0, "same_choice": 0.0}
    count = 0
    with torch.no_grad():
        for chunk in torch.arange(len(dataset)).split(128):
            batch = padded_batch(dataset.rows(chunk), columns)
            mask, rewards = batch["action_mask"], batch[ACTION_REWARDS]
            mine = learner.actor.get_dist(batch).probs.masked_fill(~mask, -1.0).argmax(-1)
            best = rewards.masked_fill(~mask, -torch.inf).argmax(-1)
            rows = torch.arange(len(chunk))
            x = batch["x"]
            for who, pick in (("policy", mine), ("em", best)):
                sums[f"{who}_revisits"] += float(x[rows, pick, revisits].sum())
                sums[f"{who}_path_m"] += float(x[rows, pick, length].sum())
                sums[f"{who}_any_revisit"] += float((x[rows, pick, revisits] > 0).sum())
            sums["same_choice"] += float((mine == best).sum())
            count += len(chunk)
    return {key: round(value / count, 3) for key, value in sums.items()} | {"decisions": count}


def main() -> None:
    dataset = DecisionDataset(DATASET)
    result = {name: choices(path, hidden, dataset) for name, (path, hidden) in ACTORS.items()}
    for name, row in result.items():
        print(name, row)
    print(json.dumps(result))


if __name__ == "__main__":
    main()
