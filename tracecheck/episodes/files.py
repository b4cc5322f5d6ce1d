"""Writing a whole run safely: into ``NAME.part``, renamed into place only when complete."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Iterable

from ..errors import InputError
from .writer import EpisodeWriter
from .model import Episode
from .schema import RunHeader

__all__ = ["write_run"]


def write_run(path: str | Path, header: RunHeader, episodes: Iterable[Episode]) -> tuple[int, int, int]:
    """Write ``episodes`` to ``path``; (episodes, steps, crashes) written.

    An error while producing the episodes (a bad input file, say) leaves any existing
    ``path`` untouched and no partial file behind.
    """
    path = Path(path)
    if path.is_dir():
        raise InputError(f"the output {path} is a folder; give a file name such as run.mcap")
    part = path.with_name(path.name + ".part")
    counts = [0, 0, 0]
    try:
        with EpisodeWriter(part, header) as out:
            for episode in episodes:
                out.write(episode)
                counts[0] += 1
                counts[1] += episode.end.steps
                counts[2] += episode.end.crashed
        os.replace(part, path)
    except BaseException:
        part.unlink(missing_ok=True)
        raise
    return counts[0], counts[1], counts[2]
