"""The error raised for a bad recording (missing channel, unit mismatch, bad time, NaN)."""

from suspenv.core.errors import ValidationError


class RecordingError(ValidationError):
    """A recording file or object breaks a rule of the format; the message names it."""
