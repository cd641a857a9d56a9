"""Embedded robot models."""

from drake_sot.models.humanoid import (
    HumanoidInfo,
    add_body_collision,
    add_ground,
    half_sitting_configuration,
    load_humanoid,
    make_control_model,
    sole_corner_points,
    weld_base,
)

__all__ = [
    "HumanoidInfo",
    "add_body_collision",
    "add_ground",
    "half_sitting_configuration",
    "load_humanoid",
    "make_control_model",
    "sole_corner_points",
    "weld_base",
]
