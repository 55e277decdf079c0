"""Typed errors. Messages name the broken rule and the offending values."""


class SuspenvError(Exception):
    """Base class of every suspenv error."""


class ValidationError(SuspenvError, ValueError):
    """Bad input: a rule about shapes, ranges or names was broken."""


class EvaluationError(SuspenvError):
    """A physics evaluation failed (lock-up, divergence, ...).

    Raised inside models; ``Problem.evaluate`` turns it into a failed row whose
    message is ``str(error)``.
    """


class ConvergenceError(EvaluationError):
    """An iterative solver did not converge."""


class LockupError(EvaluationError):
    """A linkage cannot be assembled or locks up along a sweep."""


class InfrastructureError(SuspenvError):
    """The machinery that evaluates designs failed: a lost worker or scheduler, a timeout,
    memory. Never a result of the design: nothing of it is archived, and rerunning the same
    command resumes with exactly the evaluations that are missing."""
