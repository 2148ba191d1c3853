"""Issue 24's zero-shot targets on finished ``explore-rl-eval`` reports, with 95 % intervals.

For each report folder (an ``explore-rl-eval`` run, or a sweep's parent with one sub-folder
per scene), reads every ``trials.jsonl`` and checks the learned policy against EM
(explore_rl/zero_shot.py): travel to the common coverage, map error there and at equal
travel, decision time; ratios of means with bootstrap intervals, a target met only when its
whole interval is within it. New reports carry the same table in their ``summary.md``; this
script re-reads reports written before it existed. Writes ``targets.md`` and
``targets.json`` into the folder (or into ``--out``), prints one JSON line last.

Candidates are often run alone, against one EM run of the same scenes and seeds (EM is
seeded and deterministic on the same code): ``--reference`` takes EM's trials from those
runs, one folder per report. ``--pool NAME`` also checks every report's scenes as one set
(scenes named ``report/scene``: two sweeps over the same seeds with other scene options
stay apart), written to ``NAME/`` under ``--out`` or beside the first report. With
``--reference-policy learned`` the reference runs are another learned policy's (named
``learned_reference`` in the tables): two candidates compared directly, scene by scene;
``--policy em --reference-policy em`` compares two EM runs of other seeds (the noise floor).

    python benchmarks/study_zero_shot.py benchmarks/results/zero_shot_v3_10 \
        benchmarks/results/zero_shot_buildings_v3
    python benchmarks/study_zero_shot.py runs/buildings_wide runs/sparse_wide \
        --reference runs/buildings_em runs/sparse_em --pool validation_wide
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import emit, machine  # noqa: E402

from explore_rl import comparison, zero_shot  # noqa: E402


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("reports", nargs="+", help="explore-rl-eval output folders")
    parser.add_argument("--out", default=None, help="write targets.{md,json} here (one sub-folder per report) "
                                                    "instead of into each report")
    parser.add_argument("--reference", nargs="+", default=None, metavar="FOLDER",
                        help="take the reference policy's (EM's) trials from these runs, one per report in order "
                             "(the same scenes and seeds); default: each report's own")
    parser.add_argument("--policy", default="learned", metavar="NAME",
                        help="the policy checked (default learned)")
    parser.add_argument("--reference-policy", default="em", metavar="NAME",
                        help="the policy of the --reference runs to compare with (default em; learned: another "
                             "candidate's runs, a direct comparison)")
    parser.add_argument("--pool", default=None, metavar="NAME",
                        help="also check all reports' scenes as one pooled set, written to NAME/")
    parser.add_argument("--plots", action="store_true",
                        help="also draw each report's map error and 3D volume against travel per scene, the policy "
                             "and the reference together (SCENE_map_error.png, SCENE_volume.png beside targets.md)")
    parser.add_argument("--resamples", type=int, default=zero_shot.RESAMPLES, help="bootstrap resamples")
    parser.add_argument("--smoke", action="store_true", help="for the test suite: 50 resamples")
    return parser.parse_args(argv)


def read_report(folder: Path, argument: str = "") -> list[dict]:
    """Every trial of a report: its own ``trials.jsonl`` or its sub-folders' (a sweep);
    ``argument`` names the flag it came from in the error."""
    paths = [folder / "trials.jsonl"] if (folder / "trials.jsonl").exists() else sorted(folder.glob("*/trials.jsonl"))
    if not paths:
        raise SystemExit(f"{argument}{folder}: no trials.jsonl in it or its sub-folders; pass an explore-rl-eval "
                         "output folder")
    return [run for path in paths for run in comparison.read_trials(path)]


def reference_label(reference_policy: str, policy: str = "learned") -> str:
    """The reference's name in the tables: its own, or ``<policy>_reference`` when it is
    another run of the checked policy."""
    return f"{policy}_reference" if reference_policy == policy else reference_policy


def with_reference(runs: list[dict], folder: Path, reference_folder: Path, reference_policy: str = "em",
                   policy: str = "learned") -> list[dict]:
    """``runs`` (a report's trials) with the ``reference_policy``'s trials of ``reference_folder``
    added (under :func:`reference_label`); every scene of the report must have them there."""
    label = reference_label(reference_policy, policy)
    if any(r["policy"] == label for r in runs):
        raise SystemExit(f"{folder}: it has {label} trials of its own; drop --reference or pass a report "
                         f"without {label}")
    theirs = [{**r, "policy": label} for r in read_report(reference_folder, "--reference ")
              if r["policy"] == reference_policy]
    missing = sorted({r["scene"] for r in runs if r["policy"] == policy} - {r["scene"] for r in theirs})
    if missing:
        raise SystemExit(f"--reference {reference_folder}: no {reference_policy} trial of scene(s) "
                         f"{', '.join(missing)} of {folder}; pass the {reference_policy} run of the same scenes")
    return runs + theirs


def pooled(reports: dict[str, list[dict]]) -> list[dict]:
    """Every report's trials as one set, scenes renamed ``report/scene``."""
    return [{**run, "scene": f"{name}/{run['scene']}"} for name, runs in reports.items() for run in runs]


def check(name: str, runs: list[dict], out: Path, resamples: int, policy: str = "learned", reference: str = "em"
          ) -> dict:
    """The targets of one set of trials, ``policy`` against ``reference``, written to
    ``out/targets.{md,json}``; the JSON summary."""
    entries = zero_shot.check_targets(runs, policy=policy, reference=reference, resamples=resamples)
    out.mkdir(parents=True, exist_ok=True)
    (out / "targets.md").write_text(zero_shot.targets_markdown(entries))
    (out / "targets.json").write_text(json.dumps(zero_shot.targets_json(entries), indent=1))
    print(f"{name}:\n{zero_shot.targets_markdown(entries)}")
    keys = [*(k for ratio in zero_shot.KEYS for k in (ratio, f"{ratio}_ci95")), "travel_met", "error_met",
            "speed_met", "trials_to_resolve"]
    return {e["scene"]: {key: e[key] for key in keys} for e in entries}


def plot(runs: list[dict], out: Path, policy: str, reference: str) -> list[Path]:
    """The paper's two plots of every scene of ``runs``, ``policy`` and ``reference`` only (a
    reference run that was paired in from another folder is drawn beside the policy's)."""
    shown = [run for run in runs if run["policy"] in (policy, reference)]
    return [path for scene in sorted({run["scene"] for run in shown})
            for path in comparison.plot_scene(shown, scene, out)]


def main(argv: list[str] | None = None) -> None:
    args = parse_args(argv)
    folders = [Path(name) for name in args.reports]
    if args.reference is not None and len(args.reference) != len(folders):
        raise SystemExit(f"--reference: {len(args.reference)} folder(s) for {len(folders)} report(s); "
                         "pass one reference run per report, in the same order")
    if args.reference is None and args.reference_policy != "em":
        raise SystemExit(f"--reference-policy {args.reference_policy}: it names the policy of the --reference "
                         "runs; pass --reference FOLDER ... too")
    if args.reference is None and args.reference_policy == args.policy:
        raise SystemExit(f"--policy {args.policy}: the same as the reference policy; pass --reference FOLDER ... "
                         "(another run of it) to compare it with itself")
    if args.plots and args.out is None:
        raise SystemExit("--plots: pass --out DIR too (in the reports' own folders the plots would replace "
                         "explore-rl-eval's, which show every policy)")
    reports = {folder.name: read_report(folder) for folder in folders}
    if len(reports) != len(folders):
        raise SystemExit("reports: two folders share a name; pass folders with distinct names")
    if args.reference is not None:
        reports = {folder.name: with_reference(reports[folder.name], folder, Path(reference), args.reference_policy,
                                                args.policy)
                   for folder, reference in zip(folders, args.reference)}
    reference = reference_label(args.reference_policy, args.policy) if args.reference is not None else "em"
    result = {"machine": machine(), "smoke": args.smoke, "reports": {}}
    resamples = 50 if args.smoke else args.resamples
    for folder in folders:
        out = folder if args.out is None else Path(args.out) / folder.name
        result["reports"][folder.name] = check(folder.name, reports[folder.name], out, resamples, args.policy, reference)
        if args.plots:
            plot(reports[folder.name], out, args.policy, reference)
    if args.pool is not None:
        out = (folders[0].parent if args.out is None else Path(args.out)) / args.pool
        pool = check(args.pool, pooled(reports), out, resamples, args.policy, reference)
        result["pool"] = {scene: entry for scene, entry in pool.items() if scene.startswith("all ")}  # the rest: above
    emit(result)


if __name__ == "__main__":
    main()
