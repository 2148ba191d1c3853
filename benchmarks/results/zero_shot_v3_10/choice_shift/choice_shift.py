"""Does the learned policy lean to the nearest frontier only off its training distribution?

On the same states, the learned policy and EM each choose (the learned policy drives; EM's
choice is only recorded): per decision the path length of each choice, its rank among the
candidates by path length (0 = nearest), and whether they agree. Scenes: office layouts of
training ([0, 1000)) and validation (1000-1002), building seeds of training (0-2) and
validation (1000-1002), the same validation seeds with a big open hall in every plan, parking lots
(the building family's lot plans, validation seeds), the garage (zero-shot). ``slam=model`` (fast), 12 decisions each.

    python benchmarks/results/zero_shot_v3_10/choice_shift/choice_shift.py [--ablate | --phases] [--policy ACTOR] \
        [--only TEXT ...]

``--ablate`` instead prints, per feature column, how often the learned policy takes the nearest
frontier and EM's frontier when that column is made uninformative among the frontiers.
``--policy`` takes another actor file or checkpoint than the default ``policy.checkpoint``.
``--phases`` runs the garage and the large lots for 48 decisions and prints one row per 12
decisions (does the pull to the nearest frontier grow late in an exploration?). ``--only TEXT``
keeps the scene rows whose name contains TEXT (repeatable).
"""

import argparse
import dataclasses

import numpy as np
import torch

from explore_rl.config import load_config
from explore_rl.graph.features import feature_names
from explore_rl.models.graph_unet import INPUT_LEVELS
from explore_rl.planning.learned import actor_logits
from explore_rl.planning.policies import make_policy
from explore_rl.runner import Explorer

SCENES = {
    "office train (layouts 3, 4, 5)": [["scene=office", f"scene.seed={s}"] for s in (3, 4, 5)],
    "office validation (1000-1002)": [["scene=office", f"scene.seed={s}"] for s in (1000, 1001, 1002)],
    "buildings train (0-2)": [["scene=building", f"scene.seed={s}"] for s in (0, 1, 2)],
    "buildings validation (1000-1002)": [["scene=building", f"scene.seed={s}"] for s in (1000, 1001, 1002)],
    "buildings validation (1000-1002), every plan with a 14-16 m hall": [
        ["scene=building", f"scene.seed={s}", "scene.building.hall_probability=1.0",
         "scene.building.hall_min_side=14.0", "scene.building.hall_max_side=16.0"] for s in (1000, 1001, 1002)],
    "parking lots, validation seeds 1000-1002 (scene.building.lot_probability=1)": [
        ["scene=building", f"scene.seed={s}", "scene.building.lot_probability=1.0"] for s in (1000, 1001, 1002)],
    "large parking lots (28-35 m), validation seeds 1000-1002": [
        ["scene=building", f"scene.seed={s}", "scene.building.lot_probability=1.0", "scene.building.size_min=28.0",
         "scene.building.size_max=35.0"] for s in (1000, 1001, 1002)],
    "sparse large lots (28-35 m, lanes 6.5-7 m, pitch 6-6.5 m, half the spaces empty), validation 1000-1002": [
        ["scene=building", f"scene.seed={s}", "scene.building.lot_probability=1.0", "scene.building.size_min=28.0",
         "scene.building.size_max=35.0", "scene.building.lot_lane_width=[6.5,7.0]",
         "scene.building.lot_car_pitch=[6.0,6.5]", "scene.building.lot_gap_probability=0.5"] for s in (1000, 1001, 1002)],
    "buildings with a 25-30 m hall (28-35 m plans), validation 1000-1002": [
        ["scene=building", f"scene.seed={s}", "scene.building.hall_probability=1.0", "scene.building.size_min=28.0",
         "scene.building.size_max=35.0", "scene.building.hall_min_side=25.0", "scene.building.hall_max_side=30.0"]
        for s in (1000, 1001, 1002)],
    "garage (zero-shot)": [["scene=garage", f"seed={s}"] for s in (0, 1, 2)],
}


class Both:
    """The learned policy decides; EM's choice on the same state is recorded."""

    name = "learned"

    def __init__(self, learned, em):
        self.learned, self.em, self.records, self.ablations = learned, em, [], []

    def choose(self, state) -> int:
        mine, theirs = self.learned.choose(state), self.em.choose(state)
        lengths = np.array([c.length for c in state.candidates])
        rank = np.argsort(np.argsort(lengths, kind="stable"), kind="stable")
        self.records.append((lengths[mine], lengths[theirs], rank[mine], rank[theirs], len(lengths), mine == theirs,
                             len(self.records)))
        self.ablations.append([(rank[c], c == theirs) for c in self.ablated_choices()])
        return mine

    ablations: list

    def ablated_choices(self) -> list[int]:
        """The learned choice with each feature column made uninformative among the frontier
        rows (every frontier row given the column's mean over them), one column at a time."""
        encoded, graph = self.learned.last_encoded, self.learned.last_graph
        rows = np.flatnonzero(encoded.action_mask)
        choices = []
        for column in range(encoded.x.shape[1]):
            x = encoded.x.copy()
            x[rows, column] = x[rows, column].mean()
            INPUT_LEVELS.clear()
            logits = actor_logits(self.learned.actor, dataclasses.replace(encoded, x=x))
            masked = torch.where(torch.from_numpy(encoded.action_mask), logits, torch.tensor(-torch.inf))
            choices.append(int(graph.candidate[encoded.nodes[int(torch.argmax(masked))]]))
        return choices


parser = argparse.ArgumentParser(description="Does the learned policy lean to the nearest frontier?")
mode = parser.add_mutually_exclusive_group()
mode.add_argument("--ablate", action="store_true", help="one feature column made uninformative at a time")
mode.add_argument("--phases", action="store_true", help="garage and large lots, 48 decisions, rows per 12")
parser.add_argument("--policy", help="an actor file or checkpoint instead of the default policy.checkpoint")
parser.add_argument("--only", action="append", default=[], metavar="TEXT", help="keep scene rows containing TEXT")
args = parser.parse_args()
ABLATE, PHASES = args.ablate, args.phases
POLICY = [f"policy.checkpoint={args.policy}"] if args.policy else []
DECISIONS, PHASE = (48, 12) if PHASES else (12, 12)
if PHASES:
    SCENES = {name: SCENES[name] for name in ("large parking lots (28-35 m), validation seeds 1000-1002",
                                               "garage (zero-shot)")}
if args.only:
    SCENES = {name: scenes for name, scenes in SCENES.items() if any(text in name for text in args.only)}
names = feature_names("extended")
if ABLATE:
    print("| scenes | " + " | ".join(names) + " |  (per column made uninformative: nearest chosen / same as EM)")
for name, overrides_list in SCENES.items():
    records, ablations = [], []
    for overrides in overrides_list:
        config = load_config([*overrides, "slam=model", "policy=learned", *POLICY, f"explore.max_decisions={DECISIONS}",
                              "explore.progress_bar=false", "graph.max_nodes=1024"])
        rng = np.random.default_rng(0)
        learned = make_policy(config.policy, rng, planning=config.planning, robot=config.robot, graph=config.graph)
        em = make_policy(dataclasses.replace(config.policy, name="em"), rng, planning=config.planning,
                         robot=config.robot, graph=config.graph)
        both = Both(learned, em)
        Explorer(config, policy=both).run()
        records += both.records
        ablations += both.ablations
    if ABLATE:
        a = np.array(ablations, dtype=float)  # (decisions, columns, [rank, same as EM])
        print(f"| {name} | " + " | ".join(f"{np.mean(a[:, c, 0] == 0):.2f} / {a[:, c, 1].mean():.2f}"
                                          for c in range(a.shape[1])) + " |", flush=True)
        continue
    rows = np.array(records, dtype=float)
    for phase in range(0, DECISIONS, PHASE):
        r = rows[(rows[:, 6] >= phase) & (rows[:, 6] < phase + PHASE)]
        if len(r) == 0:
            continue
        label = f"{name}, decisions {phase}-{phase + PHASE - 1}" if PHASES else name
        print(f"| {label} | {len(r)} | {r[:, 4].mean():.1f} | {np.median(r[:, 0]):.1f} / {np.median(r[:, 1]):.1f} | "
              f"{r[:, 2].mean():.2f} / {r[:, 3].mean():.2f} | {np.mean(r[:, 2] == 0):.2f} / {np.mean(r[:, 3] == 0):.2f} | "
              f"{r[:, 5].mean():.2f} |", flush=True)
