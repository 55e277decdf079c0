"""Experiments: TOML configs -> resolved config -> run directory (see :mod:`.config`)."""
