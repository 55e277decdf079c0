"""Command-line interface: ``suspenv <command>``; one module per command."""
