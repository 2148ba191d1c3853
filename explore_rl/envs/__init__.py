"""The TorchRL environment: one exploration decision per step (see explore_env.py).

``make_env`` and ``EnvFactory`` load lazily: importing ``explore_rl.envs.config`` (as
``explore_rl.config`` does) must not import TorchRL, which switches multiprocessing to
``spawn`` for the whole process.
"""

__all__ = ["EnvFactory", "make_env"]


def __getattr__(name: str):
    if name in __all__:
        from explore_rl.envs import factory

        return getattr(factory, name)
    raise AttributeError(f"module 'explore_rl.envs' has no attribute {name!r}")
