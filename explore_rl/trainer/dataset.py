"""EM-scored decisions on disk: a TorchRL replay buffer over ``LazyMemmapStorage``.

Every decision the env observes carries EM's evaluation of every frontier node
(``("expert", "action_rewards")``, Algorithm 1) and EM's choice (``("expert", "em_action")``).
Kept on disk, those labelled states can be collected by many workers, grow across runs,
and train a policy offline (explore_rl/trainer/offline.py) or feed DAgger replay (``train.dataset=PATH``).

A memory-mapped storage needs rows of one fixed size, so a decision is stored *compact
but fixed*: ``x`` padded to ``graph.max_nodes`` rows (float32), the upper-triangle edges
as a list padded to ``max_edges`` with their count and weights (a padded ``adj`` would be
a megabyte per decision), the node count, ``action_mask``, ``action_rewards``,
``em_action`` and metadata (``layout``, ``episode``, ``scene``: an index into the
dataset's scene names). The two label columns keep those flat names on disk (format
``explore_rl.decisions/1``, unchanged since datasets were first written, so every dataset
still loads); :func:`padded_batch` rebuilds the padded batch the actor reads, as wide as
the largest graph sampled, with the labels under ``("expert", ...)`` as the env returns
them (like ``imitation.pad_graphs``).

A dataset is a folder::

    PATH/dataset.json   schema (max_nodes, max_edges, features, capacity) and scene names
    PATH/storage/       the memory-mapped columns and TorchRL's storage metadata (length)
    PATH/writer/, sampler/   TorchRL's writer cursor and sampler state

One process writes at a time (parallel collectors send their decisions to one writer,
benchmarks/collect_decisions.py); :meth:`DecisionDataset.append` makes them durable
(``ReplayBuffer.dumps`` into the folder the storage already lives in copies nothing).
"""

from __future__ import annotations

import json
import logging
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np
import torch
from tensordict import TensorDict, TensorDictBase
from torchrl.data import LazyMemmapStorage, ReplayBuffer

from explore_rl.envs.keys import ACTION_REWARDS, EM_ACTION, EXPERT
from explore_rl.graph.exploration_graph import CURRENT as CURRENT_IDENTITY
from explore_rl.graph.exploration_graph import FRONTIER as FRONTIER_IDENTITY
from explore_rl.graph.features import feature_names, loop_lengths
from explore_rl.trainer.config import DATASET_SCHEMA_FILE as SCHEMA_FILE
from explore_rl.trainer.config import check_dataset_path

log = logging.getLogger(__name__)

STORAGE = "storage"
FORMAT = "explore_rl.decisions/1"


@dataclass
class DatasetSchema:
    """The fixed shapes of a dataset's rows, and what the columns of ``x`` are."""

    max_nodes: int
    max_edges: int
    features: list[str]
    capacity: int
    scenes: list[str] = field(default_factory=list)  # ``scene`` column -> scene name
    format: str = FORMAT

    def scene_id(self, name: str) -> int:
        """The index of scene ``name`` (added if new)."""
        if name not in self.scenes:
            self.scenes.append(name)
        return self.scenes.index(name)


# ---------------------------------------------------------------------- row conversion


def fixed_rows(decisions: list[TensorDictBase], schema: DatasetSchema, scene: str = "") -> tuple[TensorDict, int]:
    """Compact decisions (``imitation.compact_decisions``: ``x[n, F]``, ``edges[2, E]``,
    ``weights[E]``, ...) as fixed-size rows ``[B]`` of ``schema``; also how many were
    dropped because they had more nodes or edges than the schema holds (logged)."""
    keep = [d for d in decisions
            if d["x"].shape[0] <= schema.max_nodes and d["edges"].shape[1] <= schema.max_edges]
    dropped = len(decisions) - len(keep)
    if dropped:
        log.warning("%d decisions larger than max_nodes=%d / max_edges=%d were not stored", dropped,
                    schema.max_nodes, schema.max_edges)
    count, n, e = len(keep), schema.max_nodes, schema.max_edges
    features = len(schema.features)
    rows = TensorDict({
        "x": torch.zeros(count, n, features),
        "edges": torch.zeros(count, 2, e, dtype=torch.int16 if n <= 32767 else torch.int32),
        "weights": torch.zeros(count, e),
        "n_edges": torch.zeros(count, dtype=torch.int32),
        "n_nodes": torch.zeros(count, dtype=torch.int32),
        "action_mask": torch.zeros(count, n, dtype=torch.bool),
        "action_rewards": torch.zeros(count, n),
        "em_action": torch.zeros(count, dtype=torch.int64),
        "layout": torch.full((count,), -1, dtype=torch.int64),
        "episode": torch.full((count,), -1, dtype=torch.int64),
        "scene": torch.full((count,), schema.scene_id(scene), dtype=torch.int64),
    }, batch_size=[count])
    for row, decision in enumerate(keep):
        size, edges = decision["x"].shape[0], decision["edges"].shape[1]
        if decision["x"].shape[1] != features:
            raise ValueError(f"a decision has {decision['x'].shape[1]} node features, the dataset "
                             f"{features} ({', '.join(schema.features)}): collect with the dataset's graph.features")
        rows["x"][row, :size] = decision["x"]
        rows["edges"][row, :, :edges] = decision["edges"].to(rows["edges"].dtype)
        rows["weights"][row, :edges] = decision["weights"]
        rows["n_edges"][row], rows["n_nodes"][row] = edges, size
        rows["action_mask"][row, :size] = decision["action_mask"]
        rows["action_rewards"][row, :size] = decision["action_rewards"]
        rows["em_action"][row] = decision["em_action"]
        for key in ("layout", "episode"):
            if key in decision.keys():
                rows[key][row] = decision[key]
    return rows, dropped


def padded_batch(rows: TensorDictBase, columns: list[int] | None = None) -> TensorDict:
    """The padded batch ``[B]`` (``x``, symmetric ``adj``, ``node_mask``, ``action_mask``,
    ``("expert", "action_rewards")``, ``("expert", "em_action")``) of fixed-size rows, as
    wide as the largest graph; ``columns``: the node-feature columns to keep (e.g. the paper's four of an extended set)."""
    count = rows.shape[0]
    width = int(rows["n_nodes"].max()) if count else 1
    x = rows["x"][:, :width].to(torch.float32)
    if columns is not None:
        x = x[..., columns]
    node_mask = torch.arange(width).unsqueeze(0) < rows["n_nodes"].unsqueeze(1).long()
    adj = torch.zeros(count, width, width)
    valid = torch.arange(rows["edges"].shape[-1]).unsqueeze(0) < rows["n_edges"].unsqueeze(1).long()
    batch_index = torch.arange(count).unsqueeze(1).expand_as(valid)[valid]
    i, j = rows["edges"][:, 0][valid].long(), rows["edges"][:, 1][valid].long()
    weights = rows["weights"][valid].to(torch.float32)
    adj[batch_index, i, j] = weights
    adj[batch_index, j, i] = weights
    return TensorDict({"x": x.contiguous(), "adj": adj, "node_mask": node_mask,
                       "action_mask": rows["action_mask"][:, :width].clone(),
                       EXPERT: {ACTION_REWARDS[1]: rows["action_rewards"][:, :width].to(torch.float32),
                                EM_ACTION[1]: rows["em_action"].clone()}}, batch_size=[count])


# ---------------------------------------------------------------------- the dataset


def read_schema(path: str | Path) -> DatasetSchema:
    """The schema of the dataset at ``path``; ValueError in one line if there is none."""
    path = Path(path)
    file = path / SCHEMA_FILE
    if not file.is_file():
        raise ValueError(f"{path}: no dataset there ({SCHEMA_FILE} missing); collect one with "
                         "benchmarks/collect_decisions.py --out PATH or train.dataset=PATH")
    try:
        raw = json.loads(file.read_text())
        schema = DatasetSchema(**raw)
    except (json.JSONDecodeError, TypeError) as error:
        raise ValueError(f"{file}: not a dataset schema ({error})") from None
    if schema.format != FORMAT:
        raise ValueError(f"{file}: format {schema.format!r}, this version reads {FORMAT!r}")
    return schema


class DecisionDataset:
    """The decisions in a dataset folder (see the module docstring), opened or created.

    ``schema`` (for a new folder): its shapes; for an existing one it must agree (else a
    one-line ValueError naming the difference). ``batch_size``: decisions per :meth:`sample`.
    """

    def __init__(self, path: str | Path, schema: DatasetSchema | None = None, batch_size: int = 16):
        self.path = check_dataset_path(path)
        existing = (self.path / SCHEMA_FILE).is_file()
        if existing:
            stored = read_schema(self.path)
            if schema is not None:
                check_same_schema(self.path, stored, schema)
            self.schema = stored
        elif schema is None:
            raise ValueError(f"{self.path}: no dataset there ({SCHEMA_FILE} missing) and no schema to create one")
        else:
            self.schema = DatasetSchema(**asdict(schema))
            self.path.mkdir(parents=True, exist_ok=True)
            self.write_schema()
        self.storage = LazyMemmapStorage(self.schema.capacity, scratch_dir=self.path / STORAGE, existsok=True)
        self.buffer = ReplayBuffer(storage=self.storage, batch_size=batch_size, collate_fn=lambda rows: rows)
        if (self.path / STORAGE / "storage_metadata.json").is_file():
            self.buffer.loads(self.path)

    def write_schema(self) -> None:
        partial = self.path / (SCHEMA_FILE + ".tmp")
        partial.write_text(json.dumps(asdict(self.schema), indent=1))
        partial.replace(self.path / SCHEMA_FILE)

    def __len__(self) -> int:
        return len(self.buffer)

    @property
    def full(self) -> bool:
        return len(self) >= self.schema.capacity

    def append(self, decisions: list[TensorDictBase], scene: str = "") -> int:
        """Store compact ``decisions`` (of scene ``scene``) and make them durable; returns how
        many were stored. Past ``capacity`` the oldest are overwritten (a ring, as a
        replay buffer), which a collection avoids by stopping at :attr:`full`."""
        if not decisions:
            return 0
        rows, _ = fixed_rows(decisions, self.schema, scene)
        if rows.shape[0] == 0:
            return 0
        self.buffer.extend(rows)
        self.write_schema()  # a new scene name
        self.buffer.dumps(self.path)
        return rows.shape[0]

    def rows(self, index: torch.Tensor | slice | None = None) -> TensorDict:
        """Stored rows (all by default) as an in-memory tensordict."""
        rows = self.storage.get(torch.arange(len(self)) if index is None else index)
        return rows.clone() if rows.is_memmap() else rows

    def sample(self, columns: list[int] | None = None) -> TensorDict:
        """A uniformly drawn padded batch (the global torch RNG, like the ListStorage buffer)."""
        return padded_batch(self.buffer.sample(), columns)

    def columns_for(self, features: list[str] | tuple[str, ...]) -> list[int]:
        """The ``x`` columns holding ``features``; ValueError if the dataset lacks one."""
        missing = [name for name in features if name not in self.schema.features]
        if missing:
            raise ValueError(f"{self.path}: the dataset has no node feature {missing[0]!r} (it holds "
                             f"{', '.join(self.schema.features)}): collect with graph.features=extended")
        return [self.schema.features.index(name) for name in features]


def check_same_schema(path: Path, stored: DatasetSchema, wanted: DatasetSchema) -> None:
    """ValueError in one line if a run's shapes differ from the dataset's."""
    for key in ("max_nodes", "max_edges", "features"):
        if getattr(stored, key) != getattr(wanted, key):
            raise ValueError(f"{path}: the dataset has {key}={getattr(stored, key)} but this run "
                             f"{getattr(wanted, key)}: use the dataset's value or a new dataset folder")


# ---------------------------------------------------------------------- derived columns


def loop_length_column(rows: TensorDictBase, features: list[str]) -> tuple[torch.Tensor, torch.Tensor]:
    """The ``loop_length`` column ``(B, max_nodes)`` of stored rows, from each stored graph
    (the same :func:`~explore_rl.graph.features.loop_lengths` the env computes), and which
    rows it is exact for: a graph stored at ``max_nodes`` rows may have lost pose nodes to
    the encoding's cut (explore_rl/graph/encode.py), so its distances through the pose graph
    are not the env's; those rows are marked False (their column is left 0)."""
    identity = features.index("identity")
    column = torch.zeros(rows["x"].shape[:2])
    exact = rows["n_nodes"] < rows["x"].shape[1]
    for row in torch.nonzero(exact).flatten().tolist():
        n, e = int(rows["n_nodes"][row]), int(rows["n_edges"][row])
        kind = rows["x"][row, :n, identity].numpy()
        n_poses = int((kind != FRONTIER_IDENTITY).sum())
        current = int(np.flatnonzero(kind == CURRENT_IDENTITY)[0])
        edges, weights = with_zero_length_odometry(rows["edges"][row, :, :e].T.long().numpy(),
                                                   rows["weights"][row, :e].double().numpy(), n_poses)
        column[row, n_poses:n] = torch.from_numpy(loop_lengths(n_poses, edges, weights, current,
                                                               np.arange(n_poses, n))).float()
    return column, exact


def with_zero_length_odometry(edges: np.ndarray, weights: np.ndarray, n_poses: int) -> tuple[np.ndarray, np.ndarray]:
    """A stored edge list with the odometry edges it lost put back. Rows keep the edges of
    the padded adjacency, where an edge of length 0 (two consecutive keyframes at one
    place: a turn on the spot) is no entry; consecutive keyframes are always joined by an
    odometry factor, so a missing ``(k, k + 1)`` pair is such an edge, of length 0."""
    have = set(map(tuple, np.sort(edges, axis=1).tolist()))
    missing = [(k, k + 1) for k in range(n_poses - 1) if (k, k + 1) not in have]
    if not missing:
        return edges, weights
    return np.vstack([edges, np.array(missing)]), np.r_[weights, np.zeros(len(missing))]


def derive_loops_dataset(source: DecisionDataset, out: str | Path, chunk: int = 512) -> tuple[DecisionDataset, int]:
    """A ``graph.features=loops`` copy of an ``extended`` dataset at ``out``: every row
    whose stored graph is whole (:func:`loop_length_column`), with the ``loop_length``
    column appended; returns it and how many rows were left out (graphs cut at
    ``max_nodes``). ValueError in one line if ``source`` does not hold the extended set."""
    wanted, loops = list(feature_names("extended")), list(feature_names("loops"))
    if source.schema.features != wanted:
        raise ValueError(f"{source.path}: the dataset holds {', '.join(source.schema.features)}; "
                         f"a loops copy needs graph.features=extended")
    schema = DatasetSchema(max_nodes=source.schema.max_nodes, max_edges=source.schema.max_edges,
                           features=loops, capacity=source.schema.capacity, scenes=list(source.schema.scenes))
    target = DecisionDataset(out, schema)
    if len(target):
        raise ValueError(f"{target.path}: already holds {len(target)} decisions; give a new folder")
    left_out = 0
    for index in torch.arange(len(source)).split(chunk):
        rows = source.rows(index)
        column, exact = loop_length_column(rows, wanted)
        left_out += int((~exact).sum())
        rows = rows[exact]
        if rows.shape[0] == 0:
            continue
        rows.set("x", torch.cat([rows["x"], column[exact].unsqueeze(-1)], dim=-1))
        target.buffer.extend(rows)
    target.buffer.dumps(target.path)
    return target, left_out
