"""Episodes on disk: the MCAP format, its readers, and the in-memory episode types."""

from .mcap_io import (DamagedFileWarning, EpisodeWriter, Run, RunColumns, new_header,
                      read_columns, read_episodes, read_header, read_run)
from .model import HIGHWAY, Episode, EpisodeEnd, StepRecord, Vocabulary

__all__ = [
    "EpisodeWriter", "read_run", "read_episodes", "read_columns", "read_header", "Run",
    "RunColumns", "DamagedFileWarning", "new_header", "Episode", "EpisodeEnd", "StepRecord",
    "Vocabulary", "HIGHWAY",
]
