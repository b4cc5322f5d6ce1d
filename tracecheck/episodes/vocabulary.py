"""The state vocabularies runs are read in: :class:`Vocabulary` (the variables and actions an
episode may use) and the paper's highway one, :data:`HIGHWAY`, which ProB's and SimB's traces
of the paper use."""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["HIGHWAY_VARIABLES", "HIGHWAY_ACTIONS", "Vocabulary", "HIGHWAY"]

#: The state variables of the paper's highway model (Section 4.1).
HIGHWAY_VARIABLES = ("Crash", "PresentVehicles", "VehiclesX", "VehiclesY", "VehiclesVx",
                     "VehiclesVy", "VehiclesAx", "VehiclesAy", "Reward")
#: The agent's actions, in highway-env's order of action indices.
HIGHWAY_ACTIONS = ("LANE_LEFT", "IDLE", "LANE_RIGHT", "FASTER", "SLOWER")


@dataclass(frozen=True)
class Vocabulary:
    """The variables and actions an episode may use (the paper's, or a machine's)."""

    variables: tuple[str, ...]
    actions: tuple[str, ...]
    name: str = "highway"
    set_name: str = "Vehicles"


HIGHWAY = Vocabulary(HIGHWAY_VARIABLES, HIGHWAY_ACTIONS, "HighwayEnvironment")
