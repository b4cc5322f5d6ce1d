"""The highway's property set (``--properties highway``): the paper's SimB tasks, exactly."""

__all__ = ["HIGHWAY_TOML"]

SPEED = "RSQRT(VehiclesVx(EgoVehicle)**2 + VehiclesVy(EgoVehicle)**2)"
ACCEL = "RSQRT(VehiclesAx(EgoVehicle)**2 + VehiclesAy(EgoVehicle)**2)"

#: The paper's SimB tasks (its Tables 2 and 3), exactly.
HIGHWAY_TOML = f"""
[metrics.episode_length]
aggregate = "steps"
description = "Episode length [s]"

[metrics.velocity]
expression = "{SPEED}"
aggregate = "average"
description = "Velocity [m/s]"

[metrics.distance]
expression = "VehiclesVx(EgoVehicle)"
aggregate = "sum_between_steps"
description = "Distance [m]"

[metrics.right_lane]
expression = "IF VehiclesY(EgoVehicle) >= 7.0 THEN 1.0 ELSE 0.0 END"
aggregate = "sum_between_steps"
description = "On right lane [s]"

[metrics.total_reward]
expression = "Reward"
aggregate = "sum"
description = "Total reward"

[properties.SAF1]
predicate = "Crash = FALSE"
description = "The agent must avoid collisions with other vehicles"

[properties.SAF2]
predicate = "Crash = FALSE => {SPEED} >= 20.0"
description = "The agent must drive faster than 20 m/s"

[properties.SAF3]
predicate = "Crash = FALSE => {SPEED} <= 30.0"
description = "The agent must drive slower than 30 m/s"

[properties.SAF4]
predicate = "Crash = FALSE => (VehiclesAx(EgoVehicle) < 0.0 => {ACCEL} <= 5.0)"
description = "The agent should decelerate at a maximum of 5 m/s²"

[properties.SAF5]
predicate = "Crash = FALSE => (VehiclesAx(EgoVehicle) > 0.0 => {ACCEL} <= 5.0)"
description = "The agent should accelerate at a maximum of 5 m/s²"

[properties.SAF6]
predicate = "not(#v.(v : PresentVehicles \\\\ {{EgoVehicle}} & VehiclesX(v) >= -15.0 & VehiclesX(v) <= 15.0 & VehiclesY(v) >= -4.0 & VehiclesY(v) <= 4.0))"
description = "Keep 2 m lateral and 10 m longitudinal safety distance to each other vehicle"
"""
