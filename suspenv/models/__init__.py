"""Models: what the hardware is. Physics as plain functions and frozen dataclasses."""
