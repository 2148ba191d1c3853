"""Exploration graphs (poses + frontiers) and their padded-tensor encoding.

The names below load lazily: importing ``explore_rl.graph.config`` (as
``explore_rl.config`` does) must not import the planning and SLAM code the graph uses.
"""

__all__ = ["EncodedGraph", "ExplorationGraph", "build_graph", "encode", "graph_from_state"]


def __getattr__(name: str):
    if name in ("EncodedGraph", "encode"):
        from explore_rl.graph import encode as module
    elif name in ("ExplorationGraph", "build_graph", "graph_from_state"):
        from explore_rl.graph import exploration_graph as module
    else:
        raise AttributeError(f"module 'explore_rl.graph' has no attribute {name!r}")
    return getattr(module, name)
