"""xacro: expanded by the ROS ``xacro`` package, metered against limits while it runs, its
``${...}`` expressions evaluated within a budget.
"""

from harness.models.xacro.expand import (
    XACRO_SUFFIX,
    Expansion,
    RobotArgs,
    UnusedRobotArgWarning,
    XacroOrigin,
    clear_cache,
    expand_xacro,
    is_xacro,
    normalize_args,
    parse_robot_arg,
)

__all__ = [
    "XACRO_SUFFIX",
    "Expansion",
    "RobotArgs",
    "UnusedRobotArgWarning",
    "XacroOrigin",
    "clear_cache",
    "expand_xacro",
    "is_xacro",
    "normalize_args",
    "parse_robot_arg",
]
