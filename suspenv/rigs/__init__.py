"""Rigs: what we do to a model (K&C tests, road runs, handling manoeuvres)."""
