"""Hydra entry points: ``explore-rl-view``, ``-tour``, ``-explore``, ``-compare``, ``-train``, ``-eval``.

The config directory is the package's ``conf/`` (the repository's in a source tree or an
editable install, the wheel's copy otherwise; explore_rl/resources.py); ``--config-path``
still overrides it. ``hydra.job.chdir`` stays false so relative paths mean what the user
typed. A ``ValueError`` anywhere in a command -- a bad value, file or situation the code
names -- reaches the user as one ``error:`` line with exit status 2, not a traceback.
"""

from __future__ import annotations

import functools
import importlib.util
import logging
import sys
from pathlib import Path
from typing import Callable, TypeVar

import hydra
import numpy as np
from omegaconf import DictConfig, OmegaConf

from explore_rl.config import CONF_DIR, Config, register_configs, validate

T = TypeVar("T")
log = logging.getLogger("explore_rl")

register_configs()


def to_config(cfg: DictConfig) -> Config:
    """The typed, validated config object of a Hydra job."""
    config: Config = OmegaConf.to_object(cfg)  # type: ignore[assignment]
    validate(config)
    return config


def fail(message: str) -> None:
    """Print one clear error line and exit with status 2 (no traceback)."""
    print(f"error: {message}", file=sys.stderr)
    sys.exit(2)


def build_or_fail(cfg: DictConfig, build: Callable[[Config], T]) -> tuple[Config, T]:
    """Validate the config and build the job's object; a bad input exits with one clear line."""
    try:
        config = to_config(cfg)
        return config, build(config)
    except ValueError as error:
        fail(str(error))
        raise  # unreachable: fail() exits


def entry_point(config_name: str = "config") -> Callable[[Callable[[DictConfig], None]], Callable[[], None]]:
    """``hydra.main`` over ``conf/`` for a command whose ``ValueError`` (raised while it
    runs, not only by validation) ends it with one ``error:`` line instead of a traceback."""

    def decorate(task: Callable[[DictConfig], None]) -> Callable[[], None]:
        @functools.wraps(task)
        def run(cfg: DictConfig) -> None:
            try:
                task(cfg)
            except ValueError as error:
                log.debug("the command ended with a ValueError", exc_info=True)  # hydra.verbose=explore_rl
                fail(str(error).strip().splitlines()[0] if str(error).strip() else type(error).__name__)

        return hydra.main(config_path=CONF_DIR, config_name=config_name, version_base="1.3")(run)

    return decorate


# optional dependencies of settings: (config key, value) -> (module, the install command)
OPTIONAL_DEPENDENCIES = {
    ("collector.backend", "ray"): ("ray", 'pip install "explore_rl[ray]"  (or: pip install "ray[default]>=2.9")'),
    ("logger.kind", "tensorboard"): ("tensorboard", "pip install tensorboard"),
}


def check_optional_dependencies(config: Config) -> None:
    """Fail in one line, with the install command, if a setting needs a package that is
    not installed (before any run folder or file is written)."""
    settings = {"collector.backend": config.collector.backend, "logger.kind": config.logger.kind}
    for (key, value), (module, install) in OPTIONAL_DEPENDENCIES.items():
        if settings[key] != value:
            continue
        if importlib.util.find_spec(module) is None:  # as TorchRL itself detects them
            raise ValueError(f"{key}={value} needs the package {module!r}, which is not installed: {install}")


@entry_point()
def view(cfg: DictConfig) -> None:
    """Render a scene top-down: obstacles, true free space, the robot and one LiDAR scan."""
    from explore_rl import viz
    from explore_rl.scene.build import make_scene
    from explore_rl.sensors.lidar import Lidar

    config, scene = build_or_fail(cfg, lambda c: make_scene(c.scene, c.robot, c.lidar))
    lidar = Lidar(scene, config.lidar, np.random.default_rng(config.seed))
    pose = scene.start_pose
    scan = lidar.scan(pose)
    fig, ax = viz.new_figure(scene.layout)
    viz.draw_mask(ax, scene.grid, scene.truth.reachable, "tab:green", alpha=0.15)
    viz.draw_layout(ax, scene.layout)
    viz.draw_scan(ax, pose, scan.points, config.lidar.mount_height)
    viz.draw_robot(ax, pose, config.robot.radius)
    ax.set_title(f"{scene.layout.name} (seed {config.scene.seed}, {scene.ngeom} geoms)")
    out = config.out or f"{scene.layout.name}.png"
    print(f"wrote {viz.save(fig, out)}")


@entry_point()
def tour(cfg: DictConfig) -> None:
    """Drive the scripted office tour with SLAM; draw true, odometry and SLAM trajectories."""
    from explore_rl import viz
    from explore_rl.tour import run_tour

    config, run = build_or_fail(cfg, run_tour)
    scene, robot, session, status = run.scene, run.robot, run.session, run.status
    slam, odom = session.metrics(), session.metrics(session.odometry_poses())
    log.info("tour %s after %.1f m: %d keyframes", status.value, robot.travelled, slam.keyframes)
    log.info("ATE %.3f m (odometry %.3f m), map error %.3f m (odometry %.3f m)",
             slam.ate_m, odom.ate_m, slam.map_error_m, odom.map_error_m)
    fig, ax = viz.new_figure(scene.layout)
    viz.draw_layout(ax, scene.layout, color="0.8")
    session.draw(ax)
    viz.draw_robot(ax, robot.true_pose, config.robot.radius)
    ax.set_title(f"{scene.layout.name} tour: ATE {slam.ate_m:.3f} m (odometry {odom.ate_m:.3f} m)")
    out = config.out or "tour.png"
    print(f"wrote {viz.save(fig, out)}")


def exploration_figure(explorer, title: str):
    """Estimated map, true/estimated trajectories, ellipses, candidate paths (paper Fig. 7)."""
    from explore_rl import viz

    fig, ax = viz.new_figure(explorer.scene.layout)
    viz.draw_layout(ax, explorer.scene.layout, color="0.85")
    explorer.session.draw(ax)
    state = explorer.last_state
    if state is not None:
        viz.draw_candidates(ax, [c.path for c in state.candidates], explorer.last_choice)
    viz.draw_robot(ax, explorer.robot.true_pose, explorer.config.robot.radius)
    ax.set_title(title, fontsize=9)
    return fig


def write_csv(path: Path, rows: list[dict]) -> None:
    import csv

    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w", newline="") as handle:
        if rows:
            writer = csv.DictWriter(handle, fieldnames=list(rows[0]))
            writer.writeheader()
            writer.writerows(rows)


@entry_point()
def explore(cfg: DictConfig) -> None:
    """Explore a scene with a policy; write decisions.csv, a figure and optionally a GIF."""
    from tqdm import tqdm

    from explore_rl import viz
    from explore_rl.runner import Explorer

    config, explorer = build_or_fail(cfg, Explorer)
    name = f"{explorer.scene.layout.name}_{config.policy.name}_seed{config.seed}"
    out_dir = Path(config.out or config.explore.out_dir)
    frames = []
    bar = tqdm(total=100, desc=f"explored % ({name})", disable=not config.explore.progress_bar,
               bar_format="{desc}: {n:.0f}/{total} |{bar}| {elapsed}")

    def on_decision(explorer, record) -> None:
        bar.update(100 * record.explored - bar.n)
        if config.explore.animation:
            fig = exploration_figure(explorer, f"decision {record.decision}: {100 * record.explored:.0f} %")
            frames.append(viz.figure_to_array(fig))
            viz.plt.close(fig)

    try:
        result = explorer.run(on_decision)
    finally:  # ends the bar's line, also before an error line
        bar.close()
    write_csv(out_dir / f"{name}.csv", result.table())
    last = result.records[-1] if result.records else None
    summary = (f"{result.status.value}: {len(result.records)} decisions, "
               f"{explorer.robot.travelled:.1f} m, explored {100 * (last.explored if last else 0):.1f} %, "
               f"map error {last.map_error_m if last else 0:.3f} m, loop closures {last.loop_closures if last else 0}")
    fig = exploration_figure(explorer, f"{name}: {summary}")
    figure = viz.save(fig, out_dir / f"{name}.png")
    safety = (f", blocked decisions {last.blocked_decisions}, contacts {last.contacts}, "
              f"min clearance {last.min_clearance_m:.3f} m") if last else ""
    print(summary + safety)
    print(f"wrote {out_dir / (name + '.csv')} and {figure}")
    if frames:
        import imageio.v2 as imageio

        gif = out_dir / f"{name}.gif"
        imageio.mimsave(gif, frames, duration=0.4)
        print(f"wrote {gif}")


def comparison_figure(runs: dict[str, list[dict]], scene_name: str):
    """Map error and 3D volume against travel distance, one line per policy (paper Fig. 6)."""
    from explore_rl import viz

    fig, axes = viz.plt.subplots(1, 2, figsize=(11, 4))
    for policy, rows in runs.items():
        travel = [r["travel_m"] for r in rows]
        axes[0].plot(travel, [r["map_error_m"] for r in rows], label=policy)
        axes[1].plot(travel, [r["volume_m3"] for r in rows], label=policy)
    axes[0].set(xlabel="travel distance [m]", ylabel="map error [m]", title=f"{scene_name}: map error")
    axes[1].set(xlabel="travel distance [m]", ylabel="3D occupied volume [m$^3$]", title=f"{scene_name}: volume")
    for ax in axes:
        ax.grid(alpha=0.3)
        ax.legend()
    return fig


def compare_line(name: str, result, travelled: float) -> str:
    """One policy's line of ``explore-rl-compare``; a run without decisions (a tiny budget)
    says so instead of reading a last record that does not exist."""
    head = f"{name:8s} {result.status.value:22s} travel {travelled:6.1f} m  "
    if not result.records:
        return head + "no decisions"
    last = result.records[-1]
    return (head + f"explored {100 * last.explored:5.1f} %  map error {last.map_error_m:.3f} m  "
            f"volume {last.volume_m3:6.1f} m3  loop closures {last.loop_closures}  "
            f"blocked {last.blocked_decisions}  contacts {last.contacts}")


@entry_point()
def compare(cfg: DictConfig) -> None:
    """Explore one scene with several policies (``compare.policies``) and compare them."""
    from dataclasses import replace

    from explore_rl import viz
    from explore_rl.runner import Explorer

    config, _ = build_or_fail(cfg, lambda c: None)
    out_dir = Path(config.out or config.explore.out_dir)
    runs, lines = {}, []
    for name in config.compare.policies:
        policy_config = replace(config, policy=replace(config.policy, name=name))
        _, explorer = build_or_fail(OmegaConf.structured(policy_config), Explorer)
        result = explorer.run()
        runs[name] = result.table()
        stem = f"{explorer.scene.layout.name}_{name}_seed{config.seed}"
        write_csv(out_dir / f"{stem}.csv", runs[name])
        viz.save(exploration_figure(explorer, f"{stem}: {result.status.value}"), out_dir / f"{stem}.png")
        lines.append(compare_line(name, result, explorer.robot.travelled))
    scene_name = config.scene.name
    figure = viz.save(comparison_figure(runs, scene_name), out_dir / f"{scene_name}_comparison.png")
    print("\n".join(lines))
    print(f"wrote {figure} and per-policy figures/CSVs in {out_dir}")


def training_run_dir(config: Config) -> Path:
    """``out``; under a sweep (``-m``) ``out/<the run's overrides>``; without ``out``,
    Hydra's own output folder."""
    from hydra.core.hydra_config import HydraConfig
    from hydra.types import RunMode

    hydra_config = HydraConfig.get()
    if config.out is None:
        return Path(hydra_config.runtime.output_dir)
    if hydra_config.mode == RunMode.MULTIRUN:
        return Path(config.out) / (hydra_config.job.override_dirname or f"run{hydra_config.job.num}")
    return Path(config.out)


def check_run_dir(config: Config, run_dir: Path) -> None:
    """A new run needs an empty or new folder (``out=``): one that holds a run needs
    ``resume=true``; any other non-empty folder is refused (its files would be overwritten).
    Hydra's own timestamped folder (no ``out``) is always new."""
    if config.resume or config.out is None or not run_dir.exists():
        return
    if (run_dir / "checkpoints" / "last.pt").exists():
        raise ValueError(f"{run_dir} already holds a run: add resume=true to continue it, or choose another out=")
    if not run_dir.is_dir():
        raise ValueError(f"out={run_dir} is a file, not a folder: choose a new or empty folder")
    if any(run_dir.iterdir()):
        raise ValueError(f"out={run_dir} is not empty and holds no training run: choose a new or empty folder "
                         "(nothing was written)")


@entry_point("train")
def train(cfg: DictConfig) -> None:
    """Train the g-U-Net actor-critic with A2C (explore_rl/trainer/a2c.py)."""
    from explore_rl.trainer.a2c import TrainingRun, resolve_device

    config, _ = build_or_fail(cfg, lambda c: resolve_device(c.train.device))  # a missing GPU: one line
    check_scene_file(config)
    check_optional_dependencies(config)
    run_dir = training_run_dir(config)
    check_run_dir(config, run_dir)
    run_dir.mkdir(parents=True, exist_ok=True)
    if not config.resume:
        (run_dir / "config.yaml").write_text(OmegaConf.to_yaml(cfg))
    run = TrainingRun(config, run_dir)  # a bad checkpoint / incompatible resume: ValueError, one line
    if config.resume:  # written only once the resume is known to work
        (run_dir / "config_resumed.yaml").write_text(OmegaConf.to_yaml(cfg))
    state = run.run()
    print(f"{state.updates} updates, {state.frames} decisions, {len(run.episodes.finished)} episodes, "
          f"{state.skipped_updates} skipped, {state.wall_s / 60:.1f} min; checkpoints in {run.checkpoints}")


def evaluation_dir(config: Config) -> Path:
    """``out``; under a sweep (``-m``) ``out/<job number>_<scene>`` (each holds its
    config.yaml); without ``out``, Hydra's own output folder."""
    from hydra.core.hydra_config import HydraConfig
    from hydra.types import RunMode

    from explore_rl.comparison import scene_label

    hydra_config = HydraConfig.get()
    if config.out is None:
        return Path(hydra_config.runtime.output_dir)
    if hydra_config.mode == RunMode.MULTIRUN:
        return Path(config.out) / f"{hydra_config.job.num}_{scene_label(config)}"
    return Path(config.out)


def check_scene_file(config: Config) -> None:
    """``scene=file``: read and check the scene file once, here, so that a missing or bad one fails in one line
    before any trial or worker starts (each would otherwise fail on its own). Procedural scenes need nothing."""
    if config.scene.name == "file":
        from explore_rl.scene.build import make_layout

        make_layout(config.scene, config.robot.radius)  # SceneFileError: FILE: FIELD: PROBLEM


def check_evaluation(config: Config) -> None:
    """Fail before any trial runs if the scene file or the learned policy's actor file is unusable."""
    check_scene_file(config)
    if "learned" in config.evaluate.policies:
        from explore_rl.models.actor_file import load_actor

        load_actor(config.policy.checkpoint)


# evaluate keys that change how the trials run, not what they are: a resumed study may change them
RUN_ONLY_KEYS = ("workers", "threads", "progress_bar")


def trial_settings(config: DictConfig) -> dict:
    """A config as a plain dict without the :data:`RUN_ONLY_KEYS` of ``evaluate``: what two
    runs must share for one to resume the other's trials."""
    settings = OmegaConf.to_container(config, resolve=False)
    for key in RUN_ONLY_KEYS:
        settings.get("evaluate", {}).pop(key, None)
    return settings


def finished_trials_of_this_config(partial: Path, saved_config: Path, cfg: DictConfig) -> dict:
    """The trials an earlier, unfinished ``explore-rl-eval`` into the same folder logged
    (``comparison.PARTIAL``), if it ran this config (up to :data:`RUN_ONLY_KEYS`); a log of
    another config is refused in one line (its trials would be mixed into this report)."""
    from explore_rl import comparison

    done = comparison.finished_trials(partial)
    if done and (not saved_config.exists()
                 or trial_settings(OmegaConf.load(saved_config)) != trial_settings(cfg)):
        raise ValueError(f"out={partial.parent} holds {len(done)} finished trials of another config ({partial.name}, "
                         f"config.yaml); pass another out= or delete {partial} to start over")
    return done


@entry_point()
def evaluate(cfg: DictConfig) -> None:
    """Compare policies on one scene over trials (explore_rl/comparison.py): every decision
    (decisions.csv), mean and std per policy (summary.md), map error and 3D volume against
    travel (PNG). ``explore-rl-eval scene=street policy.checkpoint=PATH out=DIR``; a sweep
    (``-m scene=street,garage``) also writes one summary over its runs into ``out``. Each
    finished trial is logged as it comes (``comparison.PARTIAL``): run the same command again
    after a stop or a crash and only the missing trials run."""
    from hydra.core.hydra_config import HydraConfig
    from hydra.types import RunMode

    from explore_rl import comparison

    config, _ = build_or_fail(cfg, check_evaluation)
    settings = config.evaluate
    out = evaluation_dir(config)
    out.mkdir(parents=True, exist_ok=True)
    partial = out / comparison.PARTIAL
    done = finished_trials_of_this_config(partial, out / "config.yaml", cfg)
    if partial.exists():
        comparison.restart_log(partial, done.values())
    (out / "config.yaml").write_text(OmegaConf.to_yaml(cfg))
    trials = comparison.make_trials(config, settings.policies, settings.trials, settings.first_trial)
    remaining = [trial for trial in trials if comparison.trial_key(trial) not in done]
    log.info("%d trials (%s x %d from trial %d) on %s with slam=%s, %d workers; writing to %s", len(trials),
             ",".join(settings.policies), settings.trials, settings.first_trial, comparison.scene_label(config),
             config.slam.frontend, settings.workers, out)
    if len(remaining) < len(trials):
        log.info("resuming: %d of %d trials were finished before (%s); running the other %d",
                 len(trials) - len(remaining), len(trials), partial, len(remaining))
    ran = comparison.run_trials(remaining, settings.workers, settings.threads, progress=settings.progress_bar,
                                on_result=functools.partial(comparison.log_trial, partial),
                                desc=f"{comparison.scene_label(config)} trials")
    by_key = {**done, **{comparison.trial_key(run): run for run in ran}}
    runs = [by_key[key] for key in map(comparison.trial_key, trials) if key in by_key]
    report = comparison.write_report(runs, out)
    partial.unlink(missing_ok=True)
    print(report["table"].read_text(), end="")
    failed = [r for r in runs if r["status"] == "error"]
    for run in failed:
        print(f"trial {run['trial']} of {run['policy']} failed: {run['error']}", file=sys.stderr)
    print(f"wrote {report['csv']}, {report['table']}, {', '.join(str(p) for p in report['plots'])}")
    if config.out is not None and HydraConfig.get().mode == RunMode.MULTIRUN:
        combined = comparison.combine(Path(config.out))
        if combined is not None:
            print(f"wrote {combined['table']} (every run of the sweep so far)")
    if len(failed) == len(runs):
        sys.exit(1)
