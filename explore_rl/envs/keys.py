"""Tensordict keys of the expert's labels: EM's teaching signal, kept apart from what a
policy observes.

The env evaluates every decision with EM and returns the result under one sub-tensordict,
``("expert", ...)``, so a policy (whose ``in_keys`` are top-level observation keys) cannot
read it by accident, while the losses, the DAgger buffer and the evaluations read it by
these names. Plain strings: importing this module imports nothing.
"""

EXPERT = "expert"
EM_ACTION = (EXPERT, "em_action")  # row of EM's choice, -1 when EM failed
ACTION_REWARDS = (EXPERT, "action_rewards")  # (N,) Algorithm 1 reward of each frontier row, 0 elsewhere
NEAREST_ACTION = (EXPERT, "nearest_action")  # row of the nearest frontier

# the trainer's bookkeeping of a collected batch (explore_rl/trainer/async_collector.py): which
# collector worker took the decisions, and the policy lag bound of its batch (in updates)
WORKER = ("collector", "worker")
POLICY_LAG = ("collector", "policy_lag")
