"""The refinement of a rough grasp into a starting posture: a least-squares search over the 22 finger joints and a
small correction of the palm's pose that brings the contact segments onto the object's surface, keeps every other
segment out of the object and the fingers out of each other, and, when asked, makes the contacts' pushes cancel
(`balance`) and the controller's squeeze press each contact in (`press`).

The search is well posed: its residual is smooth (the one-sided terms are `soft_hinge`s) and measured by
`search_geometry` to about 1e-13 of its size, with exact Jacobians; a trust-region search brings it near a minimum
and a trust-region Newton's method then finishes at the minimum itself, so that where it ends does not move with
the last bits of its inputs, of the BLAS or of the processor (issue 50; RELIABILITY.md says how far it may move
and where it still can).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import partial

import numpy as np
from scipy.optimize import least_squares

from ..base.poses import rotvec_quat
from ..sim.hand import DISTAL_SEGMENTS
from ..sim.objects import GraspObject
from ..sim.scene import Scene
from .start_geometry import SearchGeometry, hinge_bend, hinge_slope, soft_hinge

#: the trust-region search's most iterations (`_search`)
SEARCH_ITERATIONS = 300
#: `_polish`: Newton's steps at most, the step of its Hessian's differences, its first trust region (in units of
#: `_SCALE`: the joints' radians, the palm's 3 cm and half radian, the reach of the search), and the predicted gain
#: below which a step is taken as it is (the cost's rounding)
POLISH_STEPS = 150
HESSIAN_STEP = 1e-6
POLISH_REACH = 0.05
POLISH_FLOOR = 1e-12
_SCALE = np.concatenate([np.ones(22), np.full(3, 0.03), np.full(3, 0.5)])
#: the width of the search's smooth hinges (`soft_hinge`): of the clearances, m, and of the squeeze's cosine
HINGE_WIDTH = 2e-4
PRESS_WIDTH = 0.05
#: `refine(press=...)` asks the squeeze's motion of each contact to make at most about 45 degrees with its push
PRESS_COSINE = 0.7


@dataclass(frozen=True)
class StartingPosture:
    """A designed grasp: palm pose in the object frame (pos, quat w x y z), 22 joint angles, the
    segments that touch the object (`contacts`, the five distal ones for the paper's kind) and the
    design's grasp type."""

    name: str
    hand_pos: np.ndarray
    hand_quat: np.ndarray
    posture: np.ndarray
    contacts: tuple[str, ...] = DISTAL_SEGMENTS
    grasp_type: str = "power"


@dataclass(frozen=True)
class Refinement:
    """One way to refine a design (`refine`): the weights of the terms that balance the contacts' pushes and
    that make the squeeze press each contact in, and the palm's gap to the surface in place of the design's
    (`standoff`, m; None keeps the design's)."""

    balance: float = 0.0
    press: float = 0.0
    standoff: float | None = None


#: Tried in turn for each design of the `grasp_types` family until its start holds (`GraspVerifier`): the
#: design as it is; then with the squeeze pressing every contact in (`refine(press=...)`: in the paper's mid
#: and low wraps the controller's squeeze draws the thumb off the object, its motion at about 140 degrees
#: from its push); with the contacts' pushes balanced (so the thumb opposes the fingers); both; for a
#: power grasp, the palm 1 mm off the surface (taking up what four fingers push more than the thumb); and
#: the balance weighed more (a pinch of a tapered or curved object needs its two pushes nearly opposed).
#: Whether one start holds turns on millimetres, so several are tried (docs/studies/generator_defaults.md has what
#: each object got).
REFINEMENTS: tuple[Refinement, ...] = (
    Refinement(), Refinement(press=1.0), Refinement(balance=0.6), Refinement(balance=0.6, press=1.0),
    Refinement(press=1.0, standoff=0.001), Refinement(balance=0.6, standoff=0.001),
    Refinement(balance=2.5), Refinement(balance=6.0, press=1.0),
)


def _left_jacobian(rotvec: np.ndarray) -> np.ndarray:
    """(3, 3): the small turn (rad, fixed frame) that a change of a rotation vector makes of its rotation."""
    angle = float(np.linalg.norm(rotvec))
    x, y, z = rotvec
    cross = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
    if angle < 1e-6:  # the series' first terms
        return np.eye(3) + 0.5 * cross + cross @ cross / 6.0
    return (np.eye(3) + (1.0 - np.cos(angle)) / angle**2 * cross
            + (angle - np.sin(angle)) / angle**3 * cross @ cross)


def _search(measure: Callable[[np.ndarray], np.ndarray],
            measure_jacobian: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]],
            weigh: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray, np.ndarray]],
            anchor: np.ndarray, reference: np.ndarray, start: np.ndarray, bounds: tuple[np.ndarray, np.ndarray]
            ) -> np.ndarray:
    """A least-squares search run to its local minimum over residuals of two kinds: weighed measures
    (`weigh(measure(v))`: each measure's weighed value, slope and bend: the terms of the geometry) and
    `anchor * (v - reference)` (the terms that keep the search near the design).

    A trust-region search (`scipy.optimize.least_squares`) brings it near the minimum; its Jacobian is the chain
    rule of the weights' exact slopes and the measures' Jacobian (`measure_jacobian`: the measures and their
    rows; a smooth hinge's bend is far sharper than the geometry's, and differencing through it gave derivatives
    off by a part in a thousand). That search models the cost by the Jacobian alone, and where the residuals are
    large (a press or balance term that cannot be met) or the cost is flat (the weak pull towards the design) it
    crawls and stops wherever its steps stop paying, a place that moves with the last bits of its inputs. So
    Newton's method then finishes (`_polish`)."""

    def fun(v: np.ndarray) -> np.ndarray:
        return np.concatenate([weigh(measure(v))[0], anchor * (v - reference)])

    def jacobian(v: np.ndarray) -> np.ndarray:
        measures, rows = measure_jacobian(v)
        return np.vstack([weigh(measures)[1][:, None] * rows, np.diag(anchor)])

    result = least_squares(fun, start, jac=jacobian, bounds=bounds, x_scale="jac", max_nfev=SEARCH_ITERATIONS,
                           ftol=None, xtol=1e-12, gtol=1e-8)
    return _polish(measure_jacobian, weigh, anchor, reference, result.x, bounds)


def _polish(measure_jacobian: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]],
            weigh: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray, np.ndarray]],
            anchor: np.ndarray, reference: np.ndarray, x: np.ndarray, bounds: tuple[np.ndarray, np.ndarray]
            ) -> np.ndarray:
    """A trust-region Newton's method from near a minimum of `_search`'s cost to the minimum itself, whose place
    does not move with the last bits of where it started.

    The Hessian is the Jacobian's square, the weights' bends (exact) and the measures' own curvature, weighed by
    the residuals' slopes: differences of `HESSIAN_STEP` of the measures' Jacobian at the start, then kept by
    symmetric rank-one updates from the gradients of the points it tries (a structured quasi-Newton method, as
    NL2SOL's), so that large residuals and directions of negative curvature are modelled at the cost of one
    evaluation a step. Each step minimises that model within a trust region (of `POLISH_REACH` at first, in units
    of `_SCALE`); a joint or pose at its bound that the gradient pushes out stays there. It stops after
    `POLISH_STEPS` or at a step below 1e-11."""
    lower, upper = bounds

    def evaluate(v: np.ndarray) -> tuple:
        measures, rows = measure_jacobian(v)
        values, slopes, bends = weigh(measures)
        residuals = np.concatenate([values, anchor * (v - reference)])
        jacobian = np.vstack([slopes[:, None] * rows, np.diag(anchor)])
        return 0.5 * float(residuals @ residuals), values, slopes, bends, rows, jacobian, jacobian.T @ residuals

    def bent(rows: np.ndarray, pull: np.ndarray) -> np.ndarray:  # the measures' gradient, weighed by `pull`
        return rows.T @ pull

    radius = POLISH_REACH
    cost, values, slopes, bends, rows, jacobian, gradient = evaluate(x)
    pull = values * slopes
    curvature = np.column_stack([(bent(measure_jacobian(x + HESSIAN_STEP * e)[1], pull) - bent(rows, pull))
                                 / HESSIAN_STEP for e in np.eye(x.size)])
    curvature = 0.5 * (curvature + curvature.T)
    for _ in range(POLISH_STEPS):
        held = ((x - lower <= 1e-12) & (gradient > 0)) | ((upper - x <= 1e-12) & (gradient < 0))
        free = np.flatnonzero(~held)
        hessian = jacobian.T @ jacobian + rows.T @ ((values * bends)[:, None] * rows) + curvature
        hessian = hessian[np.ix_(free, free)]
        scale = _SCALE[free]
        step = np.zeros_like(x)
        step[free] = scale * _trust_step(scale[:, None] * hessian * scale[None, :], scale * gradient[free], radius)
        moved = np.clip(x + step, lower, upper) - x
        if np.abs(moved).max() < 1e-11:
            break
        predicted = -(gradient @ moved + 0.5 * moved[free] @ hessian @ moved[free])
        trial = evaluate(x + moved)
        # the secant of the measures' curvature between here and the trial point (a symmetric rank-one update)
        change = bent(trial[4], trial[1] * trial[2]) - bent(rows, trial[1] * trial[2]) - curvature @ moved
        if abs(change @ moved) > 1e-8 * np.linalg.norm(change) * np.linalg.norm(moved):
            curvature = curvature + np.outer(change, change) / (change @ moved)
        # below the cost's rounding (about 1e-12) the model's step is taken as it is: a ratio of two roundings
        # would shrink the region at random (a bound that cuts a step can leave it predicting no gain: shrink)
        ratio = -1.0 if predicted <= 0.0 else (cost - trial[0]) / predicted if predicted > POLISH_FLOOR else 1.0
        if ratio < 0.25:
            radius *= 0.25
        elif ratio > 0.75 and np.linalg.norm(moved[free] / scale) > 0.9 * radius:
            radius *= 2.0
        if ratio > 0.1:
            x = x + moved
            cost, values, slopes, bends, rows, jacobian, gradient = trial
    return x


def _trust_step(hessian: np.ndarray, gradient: np.ndarray, radius: float) -> np.ndarray:
    """The step p that minimises gradient . p + p . hessian . p / 2 with |p| (the Euclidean norm) at most
    `radius`: Newton's step where the Hessian is positive definite and the step short enough, else the step
    -(hessian + mu I)^-1 gradient whose length is the radius (mu by bisection)."""
    values, vectors = np.linalg.eigh(hessian)
    along = vectors.T @ gradient

    def step(mu: float) -> np.ndarray:
        return -vectors @ (along / (values + mu))

    if values[0] > 0.0:
        newton = step(0.0)
        if np.linalg.norm(newton) <= radius:
            return newton
    low = max(0.0, -values[0]) + 1e-12 * max(1.0, abs(values[-1]))
    high = low + np.linalg.norm(gradient) / radius + abs(values[-1])
    for _ in range(100):
        mu = 0.5 * (low + high)
        if np.linalg.norm(step(mu)) > radius:
            low = mu
        else:
            high = mu
    return step(high)


class _Residuals:
    """The search's measures of one rough grasp's neighbourhood: the vector v (28,) is the finger joints (22,), the
    palm's move (3,) m from the rough grasp's position and its turn (3,) rad (a rotation vector) from its orientation;
    the measures are the geometry's distances (contacts, other geoms, finger pairs), then the pushes' terms."""

    def __init__(self, geometry: SearchGeometry, pos: np.ndarray, quat: np.ndarray):
        self.geometry, self.pos, self.quat = geometry, pos, quat
        self.counts = (len(geometry.distal), len(geometry.other), len(geometry.pairs))

    def unpack(self, v: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        return v[:22], self.pos + v[22:25], rotvec_quat(v[25:28], self.quat)

    def pushing(self, v: np.ndarray, balance: float, press: float) -> np.ndarray:
        """The pushes' mean (3,) when `balance`, then the squeeze's cosines when `press`."""
        joints, p, q = self.unpack(v)
        self.geometry.place(joints, p, q)
        pushes = self.geometry.pushes()
        return np.concatenate(([pushes.mean(axis=0)] if balance else [])
                              + ([self.geometry.pressing(joints, pushes)] if press else []))

    def pushing_jacobian(self, v: np.ndarray, balance: float, press: float) -> np.ndarray:
        """The Jacobian of `pushing` (the pushes' own, `push_jacobians`, chained through the squeeze's cosines)."""
        joints, p, q = self.unpack(v)
        self.geometry.place(joints, p, q)
        pushes, push_rows = self.geometry.push_jacobians()
        assert push_rows is not None  # asked for (rows=True)
        rows = [push_rows.mean(axis=0)] if balance else []
        rows += [self.geometry.pressing_jacobian(joints, pushes, push_rows)[1]] if press else []
        stacked = np.vstack(rows)
        stacked[:, 25:28] = stacked[:, 25:28] @ _left_jacobian(v[25:28])
        return stacked

    def measure(self, v: np.ndarray, balance: float, press: float) -> np.ndarray:
        """The geometry's measures: distances (contacts, other geoms, finger pairs), then `pushing`'s terms."""
        distances = self.geometry.distances(*self.unpack(v))
        return np.concatenate([*distances, self.pushing(v, balance, press) if balance or press else []])

    def measure_jacobian(self, v: np.ndarray, balance: float, press: float) -> tuple[np.ndarray, np.ndarray]:
        """The measures and their Jacobian (len, 28)."""
        distances = self.geometry.distances(*self.unpack(v))
        rows = np.vstack(self.geometry.distance_jacobians())
        rows[:, 25:28] = rows[:, 25:28] @ _left_jacobian(v[25:28])
        if not (balance or press):
            return np.concatenate(distances), rows
        pushed = self.pushing(v, balance, press)
        return np.concatenate([*distances, pushed]), np.vstack([rows, self.pushing_jacobian(v, balance, press)])

    def weigh(self, m: np.ndarray, balance: float, press: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The residuals of the measures, their slopes and their bends (second derivatives)."""
        n_distal, n_other, n_pairs = self.counts
        distal, other = m[:n_distal], m[n_distal:n_distal + n_other]
        pairs, rest = m[n_distal + n_other:n_distal + n_other + n_pairs], m[n_distal + n_other + n_pairs:]
        values = [100.0 * distal,                                  # touch: contact gap 0
                  300.0 * soft_hinge(0.001 - other, HINGE_WIDTH),  # other segments stay out of the object
                  300.0 * soft_hinge(0.002 - pairs, HINGE_WIDTH)]  # fingers stay out of each other
        slopes = [np.full(n_distal, 100.0), -300.0 * hinge_slope(0.001 - other, HINGE_WIDTH),
                  -300.0 * hinge_slope(0.002 - pairs, HINGE_WIDTH)]
        bends = [np.zeros(n_distal), 300.0 * hinge_bend(0.001 - other, HINGE_WIDTH),
                 300.0 * hinge_bend(0.002 - pairs, HINGE_WIDTH)]
        if balance:  # the pushes cancel
            values.append(balance * rest[:3])
            slopes.append(np.full(3, balance))
            bends.append(np.zeros(3))
            rest = rest[3:]
        if press:  # the squeeze presses each contact in
            values.append(press * soft_hinge(PRESS_COSINE - rest, PRESS_WIDTH))
            slopes.append(-press * hinge_slope(PRESS_COSINE - rest, PRESS_WIDTH))
            bends.append(press * hinge_bend(PRESS_COSINE - rest, PRESS_WIDTH))
        return np.concatenate(values), np.concatenate(slopes), np.concatenate(bends)


class Refiner:
    """Refines rough grasps of one object into starting postures (`refine` for one, this for several): it keeps
    the object's scene and `SearchGeometry`, and the first search (to touch) of each rough grasp, which a
    refinement of the same rough grasp with other terms starts from instead of searching it again.

    Args:
        obj: the object.
        contacts: the segments that must touch.
    """

    def __init__(self, obj: GraspObject, contacts: tuple[str, ...] = DISTAL_SEGMENTS):
        self.obj, self.contacts = obj, tuple(contacts)
        self.scene = Scene(obj)
        self.geometry = SearchGeometry(self.scene, self.contacts)
        self._touching: dict[bytes, np.ndarray] = {}

    def __call__(self, rough: StartingPosture, balance: float = 0.0, press: float = 0.0) -> StartingPosture:
        """The refined start of a rough grasp (arguments as `refine`'s; the rough grasp's contacts are this
        refiner's)."""
        limits = self.scene.hand.limits()
        lower, upper = limits[:, 0] + 1e-3, limits[:, 1] - 1e-3
        pos = np.asarray(rough.hand_pos, dtype=float)
        base_quat = np.asarray(rough.hand_quat, dtype=float) / np.linalg.norm(rough.hand_quat)
        posture = np.asarray(rough.posture, dtype=float)
        residuals = _Residuals(self.geometry, pos, base_quat)
        # stay close to the designed grasp type, and near the designed hand pose
        anchor = np.concatenate([np.full(22, 0.03), np.full(3, 1.0), np.full(3, 0.05)])
        design = np.concatenate([posture, np.zeros(6)])
        start = np.concatenate([np.clip(posture, lower, upper), np.zeros(6)])
        bounds = (np.concatenate([lower, [-0.03] * 3, [-0.5] * 3]), np.concatenate([upper, [0.03] * 3, [0.5] * 3]))

        def search(start: np.ndarray, balance: float, press: float) -> np.ndarray:
            return _search(partial(residuals.measure, balance=balance, press=press),
                           partial(residuals.measure_jacobian, balance=balance, press=press),
                           partial(residuals.weigh, balance=balance, press=press), anchor, design, start, bounds)

        key = np.concatenate([pos, base_quat, posture]).tobytes()
        if key not in self._touching:
            self._touching[key] = search(start, 0.0, 0.0)
        found = search(self._touching[key], balance, press) if balance or press else self._touching[key]
        joints, p, q = residuals.unpack(found)
        return StartingPosture(rough.name, p, q, joints, self.contacts, rough.grasp_type)


def refine(obj: GraspObject, rough: StartingPosture, balance: float = 0.0, press: float = 0.0) -> StartingPosture:
    """Least-squares search from a rough grasp to one where the contact segments (by default all five
    distal ones) touch, every other segment stays clear of the object and the fingers of each other.

    The residual is smooth (the one-sided terms are `soft_hinge`s, the distances measured between cores,
    `search_geometry`), its Jacobian exact, and the search runs to its local minimum, so that its
    result does not turn on the last bits of the inputs or of the arithmetic. With `balance` or `press` it runs
    twice: first to touch, then, from there, with those terms (whose pushes are defined only while the contacts'
    cores are outside the object; on a mesh their Jacobian is by forward differences, `start_geometry.PUSH_STEP`).

    Args:
        obj: the object.
        rough: the rough grasp: its palm pose in the object frame (`hand_pos` (3,) m, `hand_quat` (4,) w x y z; the
            search moves the palm by up to 3 cm and 0.5 rad), its finger joints (22,) rad, the segments that must
            touch (`contacts`), its name and grasp type (`GRASP_TYPES`), which the refined start keeps.
        balance: weight of a term that asks the contacts' pushes to cancel (the mean of their unit
            directions towards the object, `SearchGeometry.pushes`, near zero): the thumb then opposes the
            fingers instead of pressing sideways; 0 leaves it out.
        press: weight of a term that asks the controller's squeeze to press each contact into the object
            (`SearchGeometry.pressing`: the cosine between its motion under the squeeze and its push at least
            `PRESS_COSINE`); 0 leaves it out.

    Returns:
        The refined `StartingPosture` (check it with `is_design_grasp`).
    """
    return Refiner(obj, rough.contacts)(rough, balance, press)
