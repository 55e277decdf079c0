"""Models: what the hardware is, and the road it drives on. Physics as plain functions and
frozen dataclasses."""
