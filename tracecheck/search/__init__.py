"""Searching episodes on purpose: ``tracecheck falsify`` looks for the parameters (seed,
environment settings) under which the agent under its shield violates a property, with
optimisers from established libraries, every evaluation a recorded episode."""

from __future__ import annotations

__all__: list[str] = []
