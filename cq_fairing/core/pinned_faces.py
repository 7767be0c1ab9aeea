r"""Which faces with joins across their surfaces are pinned, within which budgets, and
why the others are kept: the rule every backend applies.

A face whose joins run across its surface
(:func:`~cq_fairing.core.joint_projection.unholdable`) is projected onto its own target
with every join pinned to its source (:func:`~cq_fairing.core.pinned_projection.pin_face`).
Each side of a join gets half the budget of the join: half of
:data:`~cq_fairing.core.pinned_projection.GAP` times the model's size, and half of
:data:`~cq_fairing.core.joins.ANGLE_SLACK` degrees, so that a join between two pinned
faces stays within the whole budget.  A face is not pinned when it has no target or a
join edge with no p-curve on it, nor when a join is open in the source by more than
:data:`~cq_fairing.core.joint_projection.SOURCE_GAP` times its tolerance (the neighbour
then lies off the face's edge, where its measure projects it onto the face's moved
interior).  The backend measures a pinned face against its tolerance, installs it, and
lets it stand as a kept face in the joint projection; the sentences here say why a face
is kept, in the same words in every backend.
"""

from dataclasses import dataclass

from .joins import ANGLE_SLACK
from .joint_projection import SOURCE_GAP
from .pinned_projection import GAP, pin_face

__all__ = ["PinAttempt", "pin_budget", "pinned_sides", "attempt_pin", "pinned_sentence",
           "unpinned_sentence", "over_sentence", "held_by_pins", "FOLD"]

FOLD = 90.0   # degrees: a pinned target whose normal turns more than this has folded


@dataclass(frozen=True)
class PinAttempt:
    """Outcome of :func:`attempt_pin`.

    Attributes
    ----------
    outcome : PinnedFace or None
        The pinned projection (``None``: not attempted).
    wide : float or None
        The widest source gap of the face's joins, where it is over
        :data:`~cq_fairing.core.joint_projection.SOURCE_GAP` times the tolerance.
    """

    outcome: object = None
    wide: float = None

    @property
    def met(self):
        """The face was pinned within the budgets (its tolerance is the caller's check)."""
        return self.outcome is not None and self.outcome.met


def pin_budget(size):
    """``(gap, angle)``: one side's share of a join's budget in a model of ``size``
    (half of ``GAP * size``, half of ``ANGLE_SLACK`` degrees)."""
    return 0.5 * GAP * size, 0.5 * ANGLE_SLACK


def pinned_sides(joins, face, continuity):
    """``[(side, smooth)]``: the sides of ``joins`` on ``face``, each with whether its
    tangent plane is pinned too (a smooth join, unless ``continuity`` is ``"G0"``); the
    backend turns each side into a :class:`~cq_fairing.core.pinned_projection.PinnedEdge`
    from its edge's p-curve on the face."""
    return [(side, continuity != "G0" and join.kind == "smooth")
            for join in joins for side in join.sides if side.face == face]


def attempt_pin(source, target, edges, joins, size, tolerance):
    """Pin a face's joins to its source (module notes), or say why it is not tried.

    Parameters
    ----------
    source : BSplineSurface
        The face's surface, non-periodic.
    target : (SplineSpace, SplineSpace) or None
        The face's own target (:func:`~cq_fairing.core.joint_projection.joint_targets`);
        ``None``: none (the face is not pinned).
    edges : sequence of PinnedEdge or None
        One per side of the face's joins; ``None`` where one has no p-curve.
    joins : sequence of Join
        The face's joins (their source gaps).
    size : float
        The model's size (the gap budget's scale).
    tolerance : float
        The face's tolerance.

    Returns
    -------
    PinAttempt
    """
    if target is None or edges is None:
        return PinAttempt()
    wide = max(join.source_gap for join in joins)
    if wide > SOURCE_GAP * tolerance:
        return PinAttempt(wide=wide)
    return PinAttempt(pin_face(source, target, edges, *pin_budget(size)))


def pinned_sentence(outcome):
    """What a pinned face's joins do, ``outcome`` its
    :class:`~cq_fairing.core.pinned_projection.PinnedFace`."""
    return (f"they open {outcome.gap:.2g} and turn {outcome.angle:.2g} deg at most on its "
            "side")


def unpinned_sentence(neighbours, attempt):
    """Why a face whose joins with ``neighbours`` (their names, one string) run across
    its surface is kept as it was, after ``attempt`` (:func:`attempt_pin`)."""
    joins = f"its joins with {neighbours} run across its surface"
    outcome = attempt.outcome
    if attempt.wide is not None:
        return (f"{joins}, and one is {attempt.wide:.2g} open in the source: a neighbour "
                "that far meets the face off its edge, where pins cannot hold it")
    if outcome is None:
        return f"{joins}, where no fairing can hold them"
    if outcome.surface is None:
        return f"{joins}; pinned to its source there it needs a net as large as its source's"
    turn = (f"turn {outcome.angle:.2g} deg" if outcome.angle <= FOLD else
            f"fold (its normal turns by up to {outcome.angle:.0f} deg against the source's)")
    return (f"{joins}; pinned to its source there it would still open {outcome.gap:.2g} or "
            f"{turn} after {outcome.refined} refinements")


def over_sentence(deviation, tolerance, refined):
    """Why a face that its pinned joins hold ``deviation`` from its source, over its
    ``tolerance``, after ``refined`` span halvings, is kept as it was."""
    return (f"with its joins pinned to its source the face stays {deviation:.3g} from its "
            f"source, over tol={tolerance:g}, after {refined} refinements")


def held_by_pins(joins, pinned, unchanged):
    """The joins with a face of ``pinned`` whose every face is pinned or ``unchanged``:
    each side is its source along the join, to within the pins' budget (the joint
    projection reports the others)."""
    return [j for j in joins if set(j.faces) & pinned and set(j.faces) <= pinned | unchanged]
