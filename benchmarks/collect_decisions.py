"""Collect EM-scored decisions into an on-disk dataset (issue 24 item 1).

Parallel spawned workers each play whole episodes (``slam=model`` by default) with a
policy in the loop -- random valid frontiers, or an actor file (greedy or sampled) -- on
layouts drawn from ``env.train_layouts`` of a scene; every decision carries EM's
evaluation of every frontier (Algorithm 1 rewards) and EM's choice. The main process is
the one writer: it appends each finished episode's decisions to the dataset folder
(explore_rl/trainer/dataset.py) and a line to ``PATH/collect.jsonl`` (task, layout,
decisions, seconds). Running the same command again resumes: finished tasks are skipped
(task ``k`` is one episode with its own seed, so a task means the same episode whenever
it runs); ``--tasks`` larger grows the dataset. Each scene has its own tasks, so office and
building episodes can go into one folder (run once per ``--scene``).

    python benchmarks/collect_decisions.py --out /work/data/office_ext --scene office --layouts 0 500 \
        --tasks 400 --max-decisions 20 --workers 2 [--policy random | --actor FILE [--sample]] \
        [--features extended] [--minutes 60] [--set KEY=VALUE ...]

The last line of stdout is one JSON object: ``decisions`` (in the dataset), ``layouts``
(distinct), ``tasks_done``, ``wall_s`` (all sessions), ``decisions_per_s`` (this session),
``decisions_per_s_per_worker``.
"""

from __future__ import annotations

import argparse
import json
import logging
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import emit, machine, spawned_results  # noqa: E402

from explore_rl.config import Config, load_config  # noqa: E402

log = logging.getLogger("collect_decisions")
PROGRESS = "collect.jsonl"
TASK_STREAM = 24  # keeps the task seeds apart from the trainer's worker seeds


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=None, help="dataset folder (created or grown)")
    parser.add_argument("--scene", default="office", help="office | building | ...")
    parser.add_argument("--layouts", type=int, nargs=2, default=[0, 500], metavar=("FIRST", "STOP"),
                        help="env.train_layouts: scene seeds [FIRST, STOP) drawn per episode")
    parser.add_argument("--tasks", type=int, default=100, help="episodes in all (done ones are skipped)")
    parser.add_argument("--max-decisions", type=int, default=20, help="decisions per episode at most")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--actor", default=None, help="actor file in the loop (default: random valid frontiers)")
    parser.add_argument("--sample", action="store_true", help="sample the actor's policy instead of greedy")
    parser.add_argument("--features", default="extended", help="graph.features stored (extended holds paper's)")
    parser.add_argument("--minutes", type=float, default=0.0, help="stop starting episodes after this (0 = none)")
    parser.add_argument("--set", nargs="*", action="extend", default=[], metavar="KEY=VALUE", help="more config overrides")
    parser.add_argument("--smoke", action="store_true", help="2 short episodes, for the test suite")
    args = parser.parse_args(argv)
    if args.smoke:
        args.tasks, args.max_decisions, args.workers = 2, 2, 1
        args.out = args.out or Path("decisions_smoke")
    if args.out is None:
        parser.error("--out DIR is required (a new folder or an existing dataset)")
    for key in ("tasks", "max_decisions", "workers"):
        if getattr(args, key) < 1:
            parser.error(f"--{key.replace('_', '-')} must be >= 1, got {getattr(args, key)}")
    if args.layouts[1] <= args.layouts[0]:
        parser.error(f"--layouts {args.layouts[0]} {args.layouts[1]}: STOP must be > FIRST")
    if args.actor is not None and not Path(args.actor).is_file():
        parser.error(f"--actor {args.actor}: no such file")
    if args.actor is not None:
        problem = actor_reads_stored(args.actor, args.features)
        if problem:
            parser.error(problem)
    return args


def actor_reads_stored(actor_path: str, stored: str) -> str:
    """'' if the actor's node features are columns of ``--features`` (e.g. an extended actor and ``loops``, a
    ``no_covariance`` one and ``extended``), so the actor in the loop reads what is stored; else why not."""
    from explore_rl.graph.features import feature_names
    from explore_rl.models.actor_file import read_actor_file

    actor_file = read_actor_file(actor_path)
    reads = list(actor_file.features)
    try:
        columns = list(feature_names(stored))
    except ValueError as error:
        return f"--features: {error}"
    if any(name not in columns for name in reads):
        return (f"--features {stored}: the actor {actor_path} reads {actor_file.feature_set}, "
                f"whose columns {stored} does not all hold; store a set that holds them")
    return ""


def collection_config(args: argparse.Namespace) -> Config:
    """The env config of the collection (validated before anything runs)."""
    first, stop = args.layouts
    return load_config([f"scene={args.scene}", "slam=model", f"graph.features={args.features}",
                        f"env.train_layouts=[{first},{stop}]", f"train.dataset={args.out}", *args.set])


def task_seed(seed: int, task: int) -> int:
    return int(np.random.SeedSequence([seed, TASK_STREAM, task]).generate_state(1)[0])


def make_chooser(actor_path: str | None, sample: bool, seed: int, stored: str | None = None):
    """Random valid frontiers (seeded), or the actor's greedy or sampled choice; ``stored``: the
    ``graph.features`` of the env's ``x``, of which the actor reads its own columns by name (default: its
    features are the leading columns)."""
    import torch

    if actor_path is None:
        rng = np.random.default_rng(seed)
        return lambda td: int(rng.choice(np.flatnonzero(td["action_mask"].numpy())))
    from explore_rl.models.actor_file import load_actor
    from explore_rl.models.actor_critic import greedy_row

    from explore_rl.graph.features import feature_names

    actor, actor_file = load_actor(actor_path)
    names = list(feature_names(stored)) if stored is not None else actor_file.features
    reads = [names.index(name) for name in actor_file.features]  # actor_reads_stored checked they are there
    generator = torch.Generator().manual_seed(seed)

    def choose(td) -> int:
        with torch.no_grad():
            logits = actor(td["x"][..., reads], td["adj"], td["node_mask"])
        if not sample:
            return greedy_row(logits, td["action_mask"])
        probs = torch.softmax(logits.masked_fill(~td["action_mask"], -torch.inf), -1)
        return int(torch.multinomial(probs, 1, generator=generator))

    return choose


def play_task(task: tuple) -> tuple[int, list, dict]:
    """One episode (task ``k``) with the policy in the loop: its compact labelled decisions."""
    config, k, max_decisions, actor_path, sample = task
    import torch

    from explore_rl.envs.factory import make_env
    from explore_rl.trainer.imitation import compact_decisions

    torch.set_num_threads(1)
    start = time.perf_counter()
    seed = task_seed(config.seed, k)
    env = make_env(config)
    env.set_seed(seed)
    choose = make_chooser(actor_path, sample, seed, config.graph.features)
    td, decisions, steps = env.reset(), [], 0
    layout = int(td["layout"])
    for _ in range(max_decisions):
        action = choose(td)
        for decision in compact_decisions(td.unsqueeze(0)):
            decision["episode"] = torch.tensor(k)
            decisions.append(decision)
        td = env.step(td.set("action", torch.tensor(action)))["next"]
        steps += 1
        if bool(td["done"]):
            break
    info = {"task": k, "layout": layout, "decisions": len(decisions), "steps": steps,
            "explored": round(float(td["explored"]), 4), "seconds": round(time.perf_counter() - start, 2)}
    return k, decisions, info


def read_progress(path: Path) -> list[dict]:
    file = path / PROGRESS
    if not file.is_file():
        return []
    return [json.loads(line) for line in file.read_text().splitlines() if line.strip()]


def append_progress(path: Path, row: dict) -> None:
    with open(path / PROGRESS, "a") as handle:
        handle.write(json.dumps(row) + "\n")


def tasks_done_for(rows: list[dict], scene: str) -> set[int]:
    """The tasks of ``scene`` already in the dataset: one folder can hold several scenes'
    episodes (office and building), each scene with its own task numbers. Rows written
    before the scene was recorded count as office."""
    return {row["task"] for row in rows if "task" in row and row.get("scene", "office") == scene}


def open_dataset(config: Config):
    from explore_rl.graph.features import feature_names
    from explore_rl.trainer.dataset import DatasetSchema, DecisionDataset

    train = config.train
    schema = DatasetSchema(max_nodes=config.graph.max_nodes, max_edges=train.dataset_max_edges,
                           features=list(feature_names(config.graph.features)), capacity=train.dataset_capacity)
    return DecisionDataset(train.dataset, schema)


def collect(args: argparse.Namespace) -> dict:
    """Play the tasks not yet done, append their decisions; the summary."""
    config = collection_config(args)
    dataset = open_dataset(config)
    done = tasks_done_for(read_progress(dataset.path), args.scene)
    todo = [k for k in range(args.tasks) if k not in done]
    log.info("%s: %d decisions, %d tasks done, %d to play", dataset.path, len(dataset), len(done), len(todo))
    started, stored = time.perf_counter(), 0
    deadline = started + 60 * args.minutes if args.minutes > 0 else float("inf")
    tasks = [(config, k, args.max_decisions, args.actor, args.sample) for k in todo]
    for k, decisions, info in spawned_results(play_task, tasks, args.workers, deadline, lambda: dataset.full):
        info["scene"] = args.scene
        info["stored"] = dataset.append(decisions, args.scene)
        stored += info["stored"]
        info["wall_s"] = round(time.perf_counter() - started, 1)
        append_progress(dataset.path, info)
        log.info("task %d (layout %d): %d decisions in %.0f s; dataset %d", k, info["layout"],
                 info["decisions"], info["seconds"], len(dataset))
    seconds = time.perf_counter() - started
    append_progress(dataset.path, {"session_s": round(seconds, 1), "stored": stored, "workers": args.workers,
                                   "load_average_1min": round(__import__("os").getloadavg()[0], 2)})
    rows = read_progress(dataset.path)
    tasks_done = [row for row in rows if "task" in row]
    return {
        "dataset": str(dataset.path), "decisions": len(dataset), "stored_this_session": stored,
        "layouts": len({row["layout"] for row in tasks_done}), "tasks_done": len(tasks_done),
        "wall_s": round(sum(row.get("session_s", 0.0) for row in rows), 1), "session_s": round(seconds, 1),
        "decisions_per_s": round(stored / seconds, 3) if seconds > 0 else None,
        "decisions_per_s_per_worker": round(stored / seconds / args.workers, 3) if seconds > 0 else None,
        "scene": args.scene, "features": args.features, "policy": args.actor or "random",
        "workers": args.workers, "machine": machine(), "smoke": args.smoke,
    }


def main(argv: list[str] | None = None) -> None:
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(name)s %(message)s")
    args = parse_args(argv)
    try:
        result = collect(args)
    except ValueError as error:
        print(f"error: {error}", file=sys.stderr)
        raise SystemExit(2) from None
    emit(result)


if __name__ == "__main__":
    main()
