"""Exploration graphs (poses + frontiers) and their padded-tensor encoding."""

from explore_rl.graph.encode import EncodedGraph, encode
from explore_rl.graph.exploration_graph import ExplorationGraph, build_graph, graph_from_state

__all__ = ["EncodedGraph", "ExplorationGraph", "build_graph", "encode", "graph_from_state"]
