"""Checking recordings against shields: loading shields, replay and diff, re-simulation."""
