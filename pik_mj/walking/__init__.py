"""Walking pattern generation (irteus manual, "歩行動作生成"): preview control of the
cart-table model, gait timing with cycloid swing feet, and footstep planning.

Pure numpy; the whole-body IK per tick is applied on top of a :class:`GaitPlan`.
"""

from __future__ import annotations

from pik_mj.walking.footsteps import (
    ReachLimits,
    go_pos,
    limb_sides,
    relative_step,
    straight_steps,
    violated_reach_limits,
)
from pik_mj.walking.gait import (
    Footstep,
    GaitParameters,
    GaitPlan,
    mid_frame,
    normalize_feet,
    plan_gait,
    wrap_angle,
)
from pik_mj.walking.preview import (
    PreviewController,
    PreviewGains,
    PreviewResult,
    cart_table_model,
    extended_system,
    preview_gains,
    solve_riccati_by_iteration,
)

__all__ = [
    "Footstep",
    "GaitParameters",
    "GaitPlan",
    "PreviewController",
    "PreviewGains",
    "PreviewResult",
    "ReachLimits",
    "cart_table_model",
    "extended_system",
    "go_pos",
    "limb_sides",
    "mid_frame",
    "normalize_feet",
    "plan_gait",
    "preview_gains",
    "relative_step",
    "solve_riccati_by_iteration",
    "straight_steps",
    "violated_reach_limits",
    "wrap_angle",
]
