"""Episodes on disk: the MCAP format (writer, reader, columnar view) and the in-memory
episode types.

The names below are imported on first use, so that importing one light submodule (the
episode model, say) does not load numpy, pydantic and the MCAP library.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .._lazy import lazy_names

if TYPE_CHECKING:  # what editors and type checkers see; at run time, _WHERE
    from .columns import RunColumns, read_columns
    from .model import Episode, EpisodeEnd, StepRecord
    from .reader import Run, read_episodes, read_header, read_run
    from .vocabulary import Vocabulary
    from .writer import EpisodeWriter, new_header

_WHERE = {
    "RunColumns": "columns", "read_columns": "columns",
    "Episode": "model", "EpisodeEnd": "model", "StepRecord": "model",
    "Vocabulary": "vocabulary",
    "Run": "reader", "read_episodes": "reader",
    "read_header": "reader", "read_run": "reader",
    "EpisodeWriter": "writer", "new_header": "writer",
}

__all__ = [
    "EpisodeWriter", "read_run", "read_episodes", "read_columns", "read_header", "Run",
    "RunColumns", "new_header", "Episode", "EpisodeEnd", "StepRecord",
    "Vocabulary",
]


__getattr__, __dir__ = lazy_names(__name__, _WHERE, globals())
