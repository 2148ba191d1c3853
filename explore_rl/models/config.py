"""Configuration of the g-U-Net actor-critic (a plain dataclass: it doubles as the Hydra
structured config of the ``model`` group; ``conf/model/*.yaml`` repeat the values).

Paper (Sec. III-A): two g-U-Nets (actor, critic), depth 3, 1000 hidden features, dropout
0.5 before an MLP output layer. ``conf/model/gunet_paper.yaml`` is that network;
``conf/model/gunet.yaml`` a smaller one that trains on a CPU.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Optional

# How the metre edge weights of the exploration graph enter the GCN (see graph_unet.py).
EDGE_WEIGHT_MODES = ("distance", "unit", "inverse")


@dataclass
class ModelConfig:
    """The ``model`` config group."""

    hidden: int = 128  # features of every g-U-Net layer (paper: 1000)
    depth: int = 3  # pooling levels
    pool_ratio: float = 0.5  # top-k keeps ceil(pool_ratio * n) nodes per graph and level
    dropout: float = 0.5  # between the g-U-Net and the MLP head
    # Hidden width of the two-layer MLP head; 0 = a single linear layer (the authors' code).
    mlp_hidden: int = 128
    sum_res: bool = True  # skip connections add (True) or concatenate (False), as PyG
    # "distance": metres as given (paper, authors' code, PyG); "unit": every edge 1;
    # "inverse": 1 / max(length, min_edge_length), so near neighbours weigh more.
    edge_weight: str = "distance"
    min_edge_length: float = 0.1  # m; only used by edge_weight=inverse
    # Node features are multiplied by these before the first layer, so that each is of
    # order one (paper set: [uncertainty (m^2, <= ~0.08), distance (m, <= ~30), bearing (rad),
    # identity]). None: the feature set's own scales (explore_rl/graph/features.py).
    # Part of the model: a checkpoint keeps them (deployment needs no extra step).
    feature_scale: Optional[list[float]] = None
    # Node features also given relative to the graph: each named column divided by its largest
    # magnitude over the graph's real nodes (e.g. [path_length]: 1 for the farthest frontier),
    # appended to the input. Scale-free, so a large building's paths read like a small one's.
    # Names from graph.features (explore_rl/graph/features.py); [] = none (the shipped policies).
    relative_features: list[str] = field(default_factory=list)

    def validate(self) -> None:
        """Raise ValueError naming the first bad field (``model.<field>``) and what it must be."""
        _validate(self)


def _validate(config: ModelConfig) -> None:
    positive_ints = {"hidden": config.hidden, "depth": config.depth}
    for name, value in positive_ints.items():
        if not _is_int(value) or value < 1:
            raise ValueError(f"model.{name} must be a positive int, got {value!r}")
    if not _is_int(config.mlp_hidden) or config.mlp_hidden < 0:
        raise ValueError(f"model.mlp_hidden must be an int >= 0 (0 = one linear layer), "
                         f"got {config.mlp_hidden!r}")
    if not 0.0 < config.pool_ratio <= 1.0:
        raise ValueError(f"model.pool_ratio must be in (0, 1], got {config.pool_ratio!r}")
    if not 0.0 <= config.dropout < 1.0:
        raise ValueError(f"model.dropout must be in [0, 1), got {config.dropout!r}")
    if config.edge_weight not in EDGE_WEIGHT_MODES:
        raise ValueError(f"model.edge_weight must be one of {', '.join(EDGE_WEIGHT_MODES)}, "
                         f"got {config.edge_weight!r}")
    if config.feature_scale is not None and (not config.feature_scale
                                             or not all(v > 0 for v in config.feature_scale)):
        raise ValueError(f"model.feature_scale must be positive numbers, got {config.feature_scale!r}")
    names = config.relative_features
    if not all(isinstance(name, str) for name in names) or len(set(names)) != len(names):
        raise ValueError(f"model.relative_features must be distinct node feature names, got {list(names)!r}")
    if not config.min_edge_length > 0.0:
        raise ValueError(f"model.min_edge_length must be positive, got {config.min_edge_length!r}")


def _is_int(value: object) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)
