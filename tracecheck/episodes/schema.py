"""The messages of a tracecheck MCAP file, as pydantic models (exported to ``schemas/``).

A file holds one run: a :class:`RunHeaderMessage` on ``/tracecheck/run``, then for each
episode an :class:`EpisodeHeaderMessage` on ``/tracecheck/episode``, one :class:`StepMessage`
per state on ``/tracecheck/step`` (step 0 is the initial state) and an
:class:`EpisodeEndMessage` on ``/tracecheck/episode_end``. The classes are named ``…Message``
(the in-memory episode of :mod:`tracecheck.episodes.model` has its own ``EpisodeEnd`` and
``StepRecord``); their JSON schemas keep the names the files carry (``tracecheck.Step``,
titled ``Step``). Every message is JSON with a JSON schema, so any MCAP tool can
show and plot it. Beside the messages, each episode carries its states as numpy columns in an
attachment (see :mod:`tracecheck.episodes.codec`) for fast whole-file analysis.

State values are JSON: numbers and booleans as such, a function from set elements as an
object (``{"EgoVehicle": 150.36, "Vehicles2": 21.9}``), a set of elements as a list of names,
anything else as a B literal in ProB's notation.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated, Any, Literal, Optional

from pydantic import BaseModel, ConfigDict, Field, StringConstraints, model_validator

from .model import END_REASONS

__all__ = ["RunHeaderMessage", "EpisodeHeaderMessage", "StepMessage", "EpisodeEndMessage",
           "SearchRunMessage", "SearchPointMessage",
           "MESSAGES", "TOPICS", "export_schemas", "SCHEMA_DIR"]

Source = Literal["recorded", "imported-simb", "imported-prob2trace", "imported-minari",
                 "external"]
EndReason = Literal[END_REASONS]
#: a parameter of a B operation (a column of the files is named after it)
ParameterName = Annotated[str, StringConstraints(pattern=r"^[A-Za-z_][A-Za-z0-9_]*$")]
#: the values of an action's REAL parameters, by name
ParameterValues = dict[ParameterName, float]


class _Message(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False, defer_build=True)


class SearchPointMessage(_Message):
    """The search evaluation an episode is (``tracecheck falsify``)."""

    repetition: int = Field(ge=0, description="which of the search's repetitions")
    evaluation: int = Field(ge=0, description="which evaluation of that repetition")
    parameters: dict[str, Any] = Field(description="the values the search tried, by name")
    objective: float = Field(description="lower is closer to a violation; negative: one")
    violated: bool = Field(description="whether the episode violates the property")
    optimizer: str = Field("", description="the optimizer that chose the parameters")
    attribution: Optional[Literal["shield gap", "unavoidable under the shield",
                                  "agent's choice", "not attributed"]] = Field(
        None, description="why the violation happened (branching re-simulation)")
    attribution_step: Optional[int] = Field(None, ge=0, description="the step it names")
    attribution_detail: Optional[str] = Field(None, description="the reason in words")


class SearchRunMessage(_Message):
    """How a search (``tracecheck falsify``) ran: its episodes carry their own point."""

    optimizer: str
    baseline: Optional[str] = Field(None, description="the optimizer run beside it on the "
                                                      "same budget (uniform random)")
    budget: int = Field(ge=1, description="episodes per repetition")
    repeat: int = Field(ge=1)
    seed: int = Field(ge=0, description="the search's own seed (repetition r: seed + r)")
    property: str
    space: dict[str, list] = Field(description="each dimension: [low, high] or its choices")
    choices: Optional[list[str]] = Field(
        None, description="the dimensions of space that are lists of choices (the others "
                          "are ranges [low, high])")
    stop_at_first: Optional[bool] = Field(
        None, description="each search ended at its first violation (ARCH-COMP's protocol)")
    reset: Optional[list[str]] = Field(
        None, description="the dimensions of space that are the environment's reset "
                          "parameters (what an episode starts from), not its settings")
    guide: Optional[Literal["margin"]] = Field(
        None, description="what values the episodes that keep a true/false property: the "
                          "shield's guard margins (none: +1)")


class RunHeaderMessage(_Message):
    """Once per file: where the episodes come from."""

    model_config = ConfigDict(title="RunHeader")  # the schema's name in files

    tracecheck_version: str
    created: str = Field(description="ISO 8601 time the file was written")
    source: Source
    environment: Optional[str] = Field(
        None, description="the environment adapter's name; a file without one "
                          "names none (the installed environment that claims its variables, "
                          "if any, is taken)")
    environment_id: Optional[str] = None
    environment_config: Optional[dict[str, Any]] = None
    search: Optional[SearchRunMessage] = Field(
        None, description="the search that ran the episodes (tracecheck falsify)")
    agent_id: Optional[str] = None
    agent_sha256: Optional[str] = None
    agent_file: Optional[str] = Field(
        None, description="where the agent file was (a Q-table there is used again to "
                          "re-simulate; a stable-baselines3 file never is: it runs code)")
    shield_name: Optional[str] = None
    shield_sha256: Optional[str] = None
    base_seed: Optional[int] = None
    horizon: Optional[int] = Field(None, description="the most agent steps per episode")
    model_name: Optional[str] = Field(None, description="B machine the states belong to")
    variables: list[str] = Field(default_factory=list, description="state variable names")
    actions: list[str] = Field(default_factory=list, description="action (operation) names")
    external_command: Optional[list[str]] = Field(
        None, description="source external: the agent script's command line (SimB's external "
                          "simulation; the port was appended)")
    external_cwd: Optional[str] = Field(None, description="the folder the script ran in")
    external_script: Optional[str] = Field(None, description="the script file it ran")
    external_script_sha256: Optional[str] = None
    action_parameters: Optional[dict[str, list[ParameterName]]] = Field(
        None, description="continuous actions: for each operation with parameters, the REAL "
                          "parameter each component of its action vector binds, in order")
    action_low: Optional[list[Optional[float]]] = Field(
        None, description="continuous actions: the action space's lower bounds (null: none), "
                          "the components of each operation in action_parameters in turn")
    action_high: Optional[list[Optional[float]]] = Field(
        None, description="continuous actions: the action space's upper bounds (null: none), "
                          "in the same order")
    action_floats: Optional[list[Literal["float16", "float32", "float64"]]] = Field(
        None, description="continuous actions: the float type the environment receives each "
                          "component in (float32: only float32 values are actions), in the "
                          "same order")
    shield_mode: Optional[Literal["project", "replace", "mask"]] = Field(
        None, description="continuous actions: how the live shield made an action allowed "
                          "(project: the nearest allowed; replace: the fallback action; "
                          "mask: a hybrid space's best-scored enabled operation, its values "
                          "projected)")
    projection_scale: Optional[list[float]] = Field(
        None, description="continuous actions: the unit of each component in projection "
                          "distances, in the same order")

    @model_validator(mode="after")
    def _action_space_fits(self) -> "RunHeaderMessage":
        """The action space's bounds and scale, where given, describe the same components."""
        low, high, scale = self.action_low, self.action_high, self.projection_scale
        sizes = {len(v) for v in (low, high, scale, self.action_floats) if v is not None}
        if len(sizes) > 1:
            raise ValueError("action_low, action_high, action_floats and projection_scale "
                             "have different lengths")
        if low is not None and high is not None and any(
                a is not None and b is not None and a > b for a, b in zip(low, high)):
            raise ValueError("an action_low bound lies above its action_high bound")
        if scale is not None and any(not s > 0 for s in scale):
            raise ValueError("a projection_scale is not positive")
        return self


class EpisodeHeaderMessage(_Message):
    """Start of an episode."""

    model_config = ConfigDict(title="EpisodeHeader")  # the schema's name in files

    episode: int
    seed: Optional[int] = None
    origin: Optional[str] = Field(None, description="file the episode was imported from")
    environment_config: Optional[dict[str, Any]] = Field(
        None, description="this episode's environment settings on top of the run's "
                          "environment_config (a search's parameters)")
    search: Optional[SearchPointMessage] = None
    reset_options: Optional[dict[str, Any]] = Field(
        None, description="what the episode started from besides its seed: the values of "
                          "the environment's reset parameters a search chose")


class StepMessage(_Message):
    """One state of an episode and the action that led to it (none for step 0)."""

    model_config = ConfigDict(title="Step")  # the schema's name in files

    episode: int
    step: int = Field(ge=0)
    time: float = Field(description="seconds since the start of the episode")
    action: Optional[str] = None
    state: dict[str, Any]
    reward: float
    crashed: bool
    observation: Optional[list[list[float]]] = Field(
        None, description="the raw observation of this state")
    action_values: Optional[dict[str, float]] = Field(
        None, description="the agent's values (Q-values) when it chose this step's action, "
                          "in the state before")
    preferred_action: Optional[str] = Field(
        None, description="the agent's unshielded choice for this step")
    allowed_actions: Optional[list[str]] = Field(
        None, description="the actions the live shield allowed for this step")
    shield_time_us: Optional[float] = Field(
        None, description="the live shield's decision time for this step (µs)")
    deadlock: Optional[bool] = Field(
        None, description="the live shield allowed nothing: the fallback was taken")
    shield_problem: Optional[str] = Field(
        None, description="why the live shield could not evaluate some guard in the state "
                          "before: those actions were not allowed (it failed closed)")
    parameters: Optional[ParameterValues] = Field(
        None, description="continuous actions: the executed action's parameter values")
    proposal: Optional[ParameterValues] = Field(
        None, description="continuous actions: the agent's proposed parameter values")
    projection_distance: Optional[float] = Field(
        None, ge=0, description="continuous actions: how far the shield moved the proposal")
    allowed_intervals: Optional[dict[ParameterName,
                                     list[tuple[Optional[float], Optional[float]]]]] = \
        Field(None, description="continuous actions: the allowed values of each parameter "
                                "in the state before, as [low, high] (null: unbounded)")

    @model_validator(mode="after")
    def _intervals_in_order(self) -> "StepMessage":
        for name, intervals in (self.allowed_intervals or {}).items():
            if any(a is not None and b is not None and a > b for a, b in intervals):
                raise ValueError(f"an allowed interval of {name} has its low end above its "
                                 "high end")
        return self


class EpisodeEndMessage(_Message):
    """End of an episode: written only once all its steps are."""

    model_config = ConfigDict(title="EpisodeEnd")  # the schema's name in files

    episode: int
    steps: int = Field(ge=0, description="agent actions, the initial state not counted")
    crashed: bool
    total_reward: float
    reason: EndReason


MESSAGES: dict[str, type[_Message]] = {
    "tracecheck.RunHeader": RunHeaderMessage,
    "tracecheck.EpisodeHeader": EpisodeHeaderMessage,
    "tracecheck.Step": StepMessage,
    "tracecheck.EpisodeEnd": EpisodeEndMessage,
}
TOPICS = {
    "tracecheck.RunHeader": "/tracecheck/run",
    "tracecheck.EpisodeHeader": "/tracecheck/episode",
    "tracecheck.Step": "/tracecheck/step",
    "tracecheck.EpisodeEnd": "/tracecheck/episode_end",
}
SCHEMA_DIR = Path(__file__).resolve().parents[2] / "schemas"


def schema_json(name: str) -> str:
    """The JSON schema text of message ``name`` (as stored in files and in ``schemas/``)."""
    schema = MESSAGES[name].model_json_schema()
    schema["$id"] = f"{name}.json"
    return json.dumps(schema, indent=2, sort_keys=True) + "\n"


def export_schemas(folder: Path = SCHEMA_DIR) -> list[Path]:
    """Write every message's JSON schema into ``folder``; the files written.

    A developer's command whose purpose is to regenerate the repository's ``schemas/``: it
    replaces those files without ``--force``, each through a temporary file renamed into place
    (never through a link: :func:`tracecheck.outputs.check_output` refuses one)."""
    from ..outputs import check_output, write_file

    paths = []
    for name in MESSAGES:
        path = check_output(Path(folder) / f"{name}.json", force=True, what="schema file")
        paths.append(write_file(path, schema_json(name)))
    return paths


if __name__ == "__main__":  # python -m tracecheck.episodes.schema
    for p in export_schemas():
        print(p)
