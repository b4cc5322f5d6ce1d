"""Episodes on disk: the MCAP format (writer, reader, columnar view) and the in-memory
episode types."""

from .columns import RunColumns, read_columns
from .model import HIGHWAY, Episode, EpisodeEnd, StepRecord, Vocabulary
from .reader import DamagedFileWarning, Run, read_episodes, read_header, read_run
from .writer import EpisodeWriter, new_header

__all__ = [
    "EpisodeWriter", "read_run", "read_episodes", "read_columns", "read_header", "Run",
    "RunColumns", "DamagedFileWarning", "new_header", "Episode", "EpisodeEnd", "StepRecord",
    "Vocabulary", "HIGHWAY",
]
