"""Runs: the ask -> evaluate -> archive -> tell loop (:mod:`.loop`), the append-only
evaluation archive (:mod:`.archive`), configs, run directories, the ``optimize`` pipeline,
and finished runs compared (:mod:`.compare`)."""
