"""Live execution: environment adapters (one per environment, under ``envs/``)."""

from .adapter import EnvAdapter, adapters, get_adapter, load_adapter

__all__ = ["EnvAdapter", "adapters", "get_adapter", "load_adapter"]
