"""The HELM on the blackboard (seed §2.3.4): tracks the newest local path plan, drives, posts local←vehicle; `python -m codger.helm`."""

from codger.helm.helm import DriveKeys, Helm, HelmConfig, helm_config_for

__all__ = ["DriveKeys", "Helm", "HelmConfig", "helm_config_for"]
