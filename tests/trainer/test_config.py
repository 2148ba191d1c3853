"""The trainer's config: the objective's options are named for what they are."""

from __future__ import annotations

import pytest
import yaml

from explore_rl.config import load_config, load_saved_config
from explore_rl.trainer.config import RENAMED


@pytest.mark.parametrize("old,new", sorted(RENAMED.items()))
def test_an_old_option_name_fails_in_one_line_naming_the_new_one(old, new):
    value = "em_choice" if old == "imitation_target" else "1"
    with pytest.raises(ValueError, match=rf"algo\.{old} was renamed algo\.{new}") as error:
        load_config([f"algo.{old}={value}"])
    assert "\n" not in str(error.value)


def test_a_config_saved_with_the_old_names_loads_with_the_new_ones(tmp_path):
    saved = {"algo": {"imitation_coef": 1.0, "imitation_target": "rewards", "imitation_replay_steps": 8,
                      "imitation_batch": 16, "imitation_buffer": 3000}}
    path = tmp_path / "config.yaml"
    path.write_text(yaml.safe_dump(saved))
    algo = load_saved_config(path).algo
    assert (algo.distill_coef, algo.distill_target, algo.dagger_steps) == (1.0, "expected_reward", 8)
    assert algo.imitation_coef is None and algo.a2c_coef == 1.0


def test_nothing_to_learn_and_replay_without_its_weight_are_refused():
    with pytest.raises(ValueError, match="nothing would be learned"):
        load_config(["algo.a2c_coef=0"])
    with pytest.raises(ValueError, match="algo.dagger_steps > 0 needs algo.distill_coef > 0"):
        load_config(["algo.dagger_steps=2"])


def test_the_shipped_policy_card_config_still_loads():
    from pathlib import Path

    card = Path(__file__).resolve().parents[2] / "policies" / "office_paper" / "config.yaml"
    algo = load_saved_config(card).algo
    assert algo.distill_target == "expected_reward" and algo.distill_coef > 0
