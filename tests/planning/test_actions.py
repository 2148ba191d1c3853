"""The action set: every candidate's path predicted at once equals one at a time, on real states."""

from __future__ import annotations

import numpy as np

from explore_rl.config import load_config
from explore_rl.planning.actions import predict_candidate_paths, predict_candidate_paths_reference, select_actions
from explore_rl.runner import Explorer

OFFICE = ["scene=office", "slam=model", "policy=nearest", "explore.progress_bar=false"]


def test_candidate_paths_at_once_equal_one_at_a_time_along_an_episode():
    """On the decisions of an office episode: the same sampled poses, travel and revisits
    for every candidate, and so the same action set."""
    config = load_config(OFFICE)
    explorer = Explorer(config)
    revisits_seen = 0
    for _ in range(8):
        state = explorer.next_state()
        if state is None:
            break
        fast = predict_candidate_paths(state, config.planning.revisits)
        reference = predict_candidate_paths_reference(state, config.planning.revisits)
        assert len(fast) == len(reference) == len(state.candidates)
        for a, b in zip(fast, reference):
            np.testing.assert_array_equal(a.poses, b.poses)
            np.testing.assert_array_equal(a.travel, b.travel)
            assert a.revisits == b.revisits
        chosen = [a.candidate for a in select_actions(state, config.planning.actions, config.planning.revisits)]
        assert chosen == [a.candidate for a in select_actions(state, config.planning.actions,
                                                              config.planning.revisits, reference=True)]
        revisits_seen += sum(len(p.revisits) for p in fast)
        explorer.act(state, explorer.policy.choose(state))
    assert revisits_seen > 5  # the episode closes loops: the comparison covers revisits
