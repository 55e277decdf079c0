"""Recording runs: the append-only SQLite evaluation archive, run directories, versions."""
