"""Runs: the ask -> evaluate -> archive -> tell loop (:mod:`.loop`), the append-only
evaluation archive (:mod:`.archive`), "best" (:mod:`.quality`), configs, run directories
and the ``optimize`` pipeline. Finished runs are compared by :mod:`suspenv.analysis`."""
