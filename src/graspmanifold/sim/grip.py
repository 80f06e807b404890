"""What closing a hand on an object means, shared by the controller, the judging and the synthesis: which
joints flex a finger around an object, how far past touch a grasp presses (the squeeze), how often the hand's
servo targets change (the control period), and the row norms every displacement check uses."""

from __future__ import annotations

import numpy as np

from .hand import FINGER_JOINTS, SHADOW_HAND, HandModel

#: joints that flex a finger around an object (the squeeze acts on these): the finger joints numbered 1-3 but
#: the thumb's third, which rotates it
FLEXION = np.array([j[-1] in "123" and j not in ("THJ3",) for j in FINGER_JOINTS])
#: rad beyond the touching posture on the flexion joints: how hard the controller and an open-loop replay press
SQUEEZE = 0.15
#: s between two servo targets (50 Hz): the controller's period and an open-loop replay's
CONTROL_PERIOD = 0.02


def squeezed(posture: np.ndarray, amount: float, hand: HandModel = SHADOW_HAND) -> np.ndarray:
    """The posture with its flexion joints pushed further towards the closed hand: the target that
    makes fingers touching an object press on it. The controller and the generator's verifier squeeze
    with it.

    Each flexion joint moves `amount` towards its closed angle, or to it where it is nearer: a joint at the
    closed angle stays there (the squeeze used to push it `amount` one way or the other by the sign of a
    difference of zero, so that a posture at the closed hand was squeezed by a last bit's choice).

    Args:
        posture: finger postures (..., 22), rad (one, or one per row).
        amount: how far to push each flexion joint (`FLEXION`), rad.
        hand: the hand model whose closed posture and ranges apply (default ours).

    Returns:
        The squeezed postures (..., 22), rad, clipped to the hand's joint ranges.
    """
    return pressed_towards(posture, amount, hand.keyframe_posture("closed"), hand.limits())


def pressed_towards(posture: np.ndarray, amount: float | np.ndarray, closed: np.ndarray, limits: np.ndarray
                    ) -> np.ndarray:
    """`squeezed` with the hand's closed posture and ranges given (a controller keeps them at hand).

    Args:
        posture: finger postures (..., 22), rad.
        amount: how far to push each flexion joint, rad: one, or one per posture (..., 1).
        closed: the closed hand's posture (22,), rad.
        limits: the joint ranges (22, 2), rad.

    Returns:
        The pressed postures (..., 22), rad.
    """
    target = posture + np.clip(closed - posture, -amount, amount) * FLEXION
    return np.clip(target, limits[:, 0], limits[:, 1])


def row_norms(rows: np.ndarray) -> np.ndarray:
    """Euclidean norm of every row, rounded exactly as `np.linalg.norm` of that row alone.

    Args:
        rows: (m, k) vectors.

    Returns:
        (m,) norms, in the rows' unit.
    """
    return np.sqrt((rows[:, None, :] @ rows[:, :, None])[:, 0, 0])
