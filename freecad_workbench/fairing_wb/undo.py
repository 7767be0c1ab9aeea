"""Undo steps of the workbench's commands: one transaction each, aborted when it fails.

FreeCAD keeps a failed feature in the document and only marks it invalid (the error of
its ``execute`` does not reach the caller; objects that depend on it stay touched, not
recomputed), so a command checks what it recomputed with
:func:`require_valid` inside the :func:`transaction` block: a failure then undoes the
whole command instead of leaving a half-made, open undo step.
"""

from contextlib import contextmanager

import cq_fairing as cf

__all__ = ["transaction", "require_valid"]


@contextmanager
def transaction(doc, name):
    """One undo step ``name`` around a block of changes to ``doc``.

    Committed when the block ends normally; aborted (every change made inside the block
    undone) when it raises, and the exception propagates.
    """
    doc.openTransaction(name)
    try:
        yield
    except BaseException:
        doc.abortTransaction()
        raise
    doc.commitTransaction()


def require_valid(objects):
    """Raise :class:`cq_fairing.FairingError` if a recompute left any of ``objects`` not
    up to date, with the reason for each (:func:`_failure`)."""
    reasons = [reason for reason in map(_failure, objects) if reason]
    if reasons:
        raise cf.FairingError(f"the recompute failed ({'; '.join(reasons)}); the command "
                              "was undone. Check the selection and the settings, then try "
                              "again.")


def _failure(obj):
    """Why ``obj`` is not up to date after a recompute (``""`` if it is): its own error,
    or, for an object FreeCAD left untouched, the errors of what it depends on."""
    if not obj.isValid():
        return f"{obj.Label}: {obj.getStatusString()}"
    if "Touched" not in obj.State:
        return ""
    failed = [d for d in obj.OutListRecursive if not d.isValid()]
    return f"{obj.Label} was not recomputed" + "".join(
        f", {d.Label} failed: {d.getStatusString()}" for d in failed)
