"""explore_rl: learned exploration under localization uncertainty.

The data flow, one module per stage: scene -> robot -> sensors.lidar -> slam ->
mapping -> planning -> graph -> envs -> models -> trainer (see README.md).
"""

__version__ = "0.1.0"
