"""Statistics: property sets, per-episode estimates with intervals and tests, Monte Carlo."""
