"""The ridges of the fast maps, located from the drive of the piston (issue 9).

Along a signature map's axis a stroke goes from moving to creeping (slower than the
creep speed, :data:`diagnostics.stroke_state.CREEP`) to held on its end stop; at each
change of state the readings have a kink, and the maps split their axis there
(:meth:`diagnostics.signatures.SignatureMaps._ridge_pieces`).  The direct maps bracket
each ridge by :data:`~diagnostics.signatures.RIDGE_ROUNDS` rounds of
:data:`~diagnostics.signatures.RIDGE_POINTS` equally spaced solves; here each ridge is the
root of a quantity the grid solves give already, the piston's *drive*
(:mod:`diagnostics.fastpath.phase`, [m/s²]):

* creeping | held: the end-stop state's drive ``d·ẍ`` (minus the stop's reaction over
  the mass; :func:`~diagnostics.fastpath.phase.held_grid`), solved whatever the state:
  it has no friction switch, is smooth through the ridge and 0 on it (≤ 0 held);
* moving | creeping: the moving state's ``d·ẍ`` with its speed set to the creep speed
  (:func:`~diagnostics.fastpath.phase.drive`): ≥ 0 where the stroke moves at the creep
  speed or faster.

A secant between the two coarse nodes around a ridge estimates it; each round solves a
few points around the estimate (offsets :data:`OFFSETS` times the tolerance) and at the
bracket's quartiles, the bracket shrinks to the first change of side among them, and the
next estimate is the secant of the new bracket; for a creep ridge, once two points lie on
its moving side, the line of their speeds extrapolated to the creep speed (the drive bends
steeply near that ridge: its secant left a third round in most conditions).  The side of
a point is that of the direct maps (its stroke state,
:func:`diagnostics.stroke_state.stroke_codes`; for the held ridge the sign of the end-stop
state's drive, the consistency test of that state).  All the ridges of all the hypotheses
at a condition are refined together, one compiled solve per kind per round
(:data:`MAX_ROUNDS` at most; typically two), each run of points started from the solution
at an end of its bracket.  A point with no operating point gives up the ridge (no cut, as
the direct maps).  The final bracket is as narrow as the direct maps' (:data:`RIDGE_TOL`
of the coarse interval).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from itertools import pairwise
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from diagnostics.signatures import RIDGE_POINTS, RIDGE_ROUNDS
from diagnostics.stroke_state import SPEED_COLUMNS, stroke_codes

if TYPE_CHECKING:
    from diagnostics.fastpath.maps import FastMaps
    from diagnostics.hypotheses import FaultParameter

__all__ = ["MAX_ROUNDS", "RIDGE_TOL", "Cut", "Piece", "locate"]

Arr = npt.NDArray[np.float64]
IArr = npt.NDArray[np.int64]

#: width of a located ridge's bracket, as a share of the coarse interval [-]: that of the
#: direct maps' bracketing, (RIDGE_POINTS + 1)^-RIDGE_ROUNDS
RIDGE_TOL = float((RIDGE_POINTS + 1) ** -RIDGE_ROUNDS)
#: refinement rounds at most; a ridge still wider than its tolerance keeps its bracket
MAX_ROUNDS = 8
#: where a round solves, around the estimate, in tolerances [-]
OFFSETS = (-36.0, -12.0, -4.0, -1.35, -0.45, 0.45, 1.35, 4.0, 12.0, 36.0)
#: the creep ridge's first estimate from the held state (the level of its drive where the
#: moving state's friction is that at the creep speed) before any moving solve
HELD_ESTIMATE = True
#: and where in the bracket, as shares of its width [-]
QUARTILES = (0.25, 0.5, 0.75)


@dataclass
class Piece:
    """A map piece's coarse solve: the parameter, nodes ``zc`` [fitting coordinate], the
    observables ``coarse``, per node the phases' solutions ``ys`` and drives ``drv``
    (:meth:`diagnostics.fastpath.maps.Context.probe`) and whether the compiled solve
    found them (``ok``; else the direct evaluator's observables, no solution)."""

    p: FaultParameter
    zc: Arr
    coarse: Arr
    ys: Arr
    drv: Arr
    ok: npt.NDArray[np.bool_]


@dataclass
class Cut:
    """A located ridge: the bracket ``lo`` < ``hi`` [fitting coordinate] and the phases'
    solutions at ``hi`` (None where the compiled solve has none there)."""

    lo: float
    hi: float
    y_hi: Arr | None


@dataclass
class _Target:
    """A ridge being located: piece, phase, kind (``held`` or creep), bracket ``lo`` <
    ``hi`` with the side of ``lo`` (``up``: moving side), the drives and solutions at its
    ends, the estimate."""

    piece: int
    phase: int
    held: bool
    lo: float
    hi: float
    up: bool
    g_lo: float
    g_hi: float
    y_lo: Arr | None
    y_hi: Arr | None
    tol: float
    open: bool = True
    dead: bool = False
    #: solutions of the held state at the ends (the held ridge's runs start there)
    h_lo: Arr | None = None
    h_hi: Arr | None = None
    #: the level of the drive that is the ridge (held kind: 0; the creep ridge's first
    #: estimate on the held state: the friction at the creep speed over the mass)
    theta: float = 0.0
    #: a creep ridge's first estimate being found on the held state (its owner waits)
    owner: _Target | None = None
    waiting: bool = False
    guess: float | None = None
    #: a creep ridge's two points on its moving side nearest it: (z, speed above creep)
    near: tuple[tuple[float, float], tuple[float, float]] | None = None

    def estimate(self) -> float:
        """The first estimate where given; for a creep ridge with two points on its
        moving side, the line of their speeds extrapolated to the creep speed; else
        regula falsi in the bracket (its middle where the drives do not allow it)."""
        if self.guess is not None:
            z, self.guess = self.guess, None
            return min(max(z, self.lo), self.hi)
        if self.near is not None:
            (z1, g1), (z2, g2) = self.near
            if g1 != g2:
                z = z1 - g1 * (z2 - z1) / (g2 - g1)
                if self.lo < z < self.hi:
                    return z
        den = self.g_lo - self.g_hi
        if math.isfinite(den) and den != 0.0:
            z = self.lo + (self.hi - self.lo) * self.g_lo / den
            if self.lo < z < self.hi:
                return z
        return 0.5 * (self.lo + self.hi)

    def points(self) -> Arr:
        """This round's points: :data:`OFFSETS` around the estimate and the bracket's
        quartiles (so that a poor estimate still shrinks it fourfold), inside it, in
        order, each more than a tenth of the tolerance past the one before it (a dozen
        numbers: Python floats, numpy's per-call cost was most of the time)."""
        lo, hi, tol = self.lo, self.hi, self.tol
        w = hi - lo
        e = self.estimate()
        z = [e + tol * o for o in OFFSETS]
        if w > 3.0 * tol * OFFSETS[-1]:
            z += [lo + w * q for q in QUARTILES]
        z = sorted(v for v in z if lo < v < hi)
        gap = 0.1 * tol
        return np.array(z[:1] + [b for a, b in pairwise(z) if b - a > gap])


def _above(code: int, phase: int, creep_ridge: bool) -> bool:
    """Whether a point of stroke code ``code`` (``3·working + return``) is on the moving
    side of ``phase``'s ridge (moving | creeping where ``creep_ridge``, else creeping |
    held)."""
    state = code // 3 if phase == 0 else code % 3
    return state == 0 if creep_ridge else state != 2


def _targets(pieces: list[Piece], creep: float) -> list[_Target]:
    out = []
    every = stroke_codes(np.concatenate([pc.coarse for pc in pieces]), creep) if pieces \
        else np.empty(0, dtype=np.int64)
    at = 0
    for i, pc in enumerate(pieces):
        codes = every[at:at + pc.zc.size]  # row by row: one call for every piece
        at += pc.zc.size
        dz = float(pc.zc[1] - pc.zc[0])
        for k in np.flatnonzero((codes[:-1] != codes[1:]) & (codes[:-1] >= 0)
                                & (codes[1:] >= 0)):
            for ph in range(2):
                for creep_ridge in (True, False):
                    a = _above(int(codes[k]), ph, creep_ridge)
                    if a == _above(int(codes[k + 1]), ph, creep_ridge):
                        continue
                    ys = [pc.ys[j] if pc.ok[j] else None for j in (k, k + 1)]
                    col = 1 if creep_ridge else 0
                    d = pc.drv[k:k + 2, ph]
                    t = _Target(i, ph, not creep_ridge, float(pc.zc[k]), float(pc.zc[k + 1]),
                                a, float(d[0, col]), float(d[1, col]), ys[0], ys[1],
                                RIDGE_TOL * dz)
                    out.append(t)
                    theta = float(d[0 if a else 1, 0] - d[0 if a else 1, 1])
                    if creep_ridge and HELD_ESTIMATE and math.isfinite(theta):
                        out.append(_Target(i, ph, True, t.lo, t.hi, a,
                                           float(d[0, 0]) - theta, float(d[1, 0]) - theta,
                                           ys[0], ys[1], t.tol, theta=theta, owner=t))
                        t.waiting = True
    return out


def locate(maps: FastMaps, pieces: list[Piece]) -> list[list[Cut]]:
    """The located ridges of each piece (module docstring), in order along the axis;
    brackets that overlap are merged."""
    creep = maps.ctx.creep
    targets = _targets(pieces, creep)
    for _ in range(MAX_ROUNDS):
        for held in (True, False):
            todo = [t for t in targets if t.open and t.held == held and not t.waiting]
            if not todo:
                continue
            # each run goes away from the end it starts at (continuation)
            zs = [t.points() if held or t.up else t.points()[::-1] for t in todo]
            sizes = [z.size for z in zs]
            params = [pieces[t.piece].p for t, n in zip(todo, sizes, strict=True)
                      for _ in range(n)]
            phases = np.repeat(np.array([t.phase for t in todo], dtype=np.int64), sizes)
            starts = [_start(t) for t in todo]
            if held:
                g, ys, ok = maps.probe_held(params, phases, zs, starts)
                g -= np.repeat([t.theta for t in todo], sizes)
                sides = ~(g <= 0.0)  # NaN where none: see below
                codes = np.where(ok, 0, -1)
            else:
                out, ys, drv, ok = maps.probe_moving(params, zs, starts)
                codes = stroke_codes(out, creep)
                rows = np.arange(phases.size)
                g = drv[rows, phases, 1]
                # the moving side of a creep ridge (:func:`_above`): the phase moving
                sides = (codes >= 0) & (np.where(phases == 0, codes // 3, codes % 3) == 0)
                speed = out[rows, np.take(SPEED_COLUMNS, phases)] - creep
            j = 0
            for t, z in zip(todo, zs, strict=True):
                sl = slice(j, j + z.size)
                j += z.size
                r = slice(None) if held or t.up else slice(None, None, -1)
                _update(t, z[r], codes[sl][r], sides[sl][r], g[sl][r], ys[sl][r], ok[sl][r])
                if not held:
                    _moving_side(t, z[r], sides[sl][r], speed[sl][r])
                if t.owner is not None and not t.open:  # the creep ridge's first estimate
                    t.owner.waiting = False
                    if not t.dead:
                        t.owner.guess = 0.5 * (t.lo + t.hi)
    cuts: list[list[Cut]] = [[] for _ in pieces]
    for t in targets:
        if not t.dead and t.owner is None:
            cuts[t.piece].append(Cut(t.lo, t.hi, None if t.held else t.y_hi))
    return [_merged(c) for c in cuts]


def _start(t: _Target) -> Arr | None:
    """Where a target's run starts: the held ridge from a held solution (either end's),
    the creep ridge from the moving end's solution."""
    if t.held:
        for y in (t.h_lo, t.h_hi, t.y_hi if t.up else t.y_lo, t.y_lo if t.up else t.y_hi):
            if y is not None:
                return y
        return None
    return t.y_lo if t.up else t.y_hi


def _update(t: _Target, zs: Arr, codes: IArr, sides: npt.NDArray[np.bool_], g: Arr,
            ys: Arr, ok: npt.NDArray[np.bool_]) -> None:
    """The bracket of ``t`` narrowed to the first change of side among ``zs``."""
    if zs.size == 0 or min(codes.tolist()) < 0:
        t.open, t.dead = False, True
        return
    up = t.up
    j = next((k for k, side in enumerate(sides.tolist()) if side != up), -1)
    if j < 0:  # all on lo's side
        j = zs.size - 1
        t.lo, t.g_lo = float(zs[j]), float(g[j])
        _keep(t, "lo", ys[j] if ok[j] else None)
    else:
        t.hi, t.g_hi = float(zs[j]), float(g[j])
        _keep(t, "hi", ys[j] if ok[j] else None)
        if j > 0:
            t.lo, t.g_lo = float(zs[j - 1]), float(g[j - 1])
            _keep(t, "lo", ys[j - 1] if ok[j - 1] else None)
    if t.hi - t.lo <= t.tol:
        t.open = False


def _moving_side(t: _Target, zs: Arr, sides: npt.NDArray[np.bool_], excess: Arr) -> None:
    """Keep a creep ridge's two points nearest it on its moving side (``zs`` ascending;
    this round's and the last ones') with the stroke's speed above the creep speed
    ``excess`` [m/s], which extrapolates to the ridge (:meth:`_Target.estimate`): the
    drive does not, it bends down steeply near the ridge and is far off on the creeping
    side, so that regula falsi across the bracket left the second round's estimate 5-6
    tolerances off (measured), a third round."""
    if t.dead:
        return
    moving = [bool(m) for m in sides.tolist()]
    size = len(moving)
    if t.up:  # the moving side is lo's: the run of points from lo
        n = next((k for k, m in enumerate(moving) if not m), size)
        idx = range(n)
    else:  # hi's: the run of points up to hi
        n = next((k for k, m in enumerate(reversed(moving)) if not m), size)
        idx = range(size - n, size)
    zl, xl = zs.tolist(), excess.tolist()
    pts = [(zl[i], xl[i]) for i in idx if math.isfinite(xl[i])]
    if t.near is not None:
        pts += list(t.near)
    if len(pts) >= 2:
        pts.sort(key=lambda q: q[0], reverse=t.up)  # the nearest the ridge first
        t.near = (pts[0], pts[1])


def _keep(t: _Target, end: str, y: Arr | None) -> None:
    """The solution at a new bracket end ``end`` (held or moving by the target's kind)."""
    if t.held:
        setattr(t, "h_" + end, y)
    else:
        setattr(t, "y_" + end, y)


def _merged(cuts: list[Cut]) -> list[Cut]:
    """``cuts`` in order of ``lo``, overlapping brackets joined."""
    out: list[Cut] = []
    for c in sorted(cuts, key=lambda c: c.lo):
        if out and c.lo <= out[-1].hi:
            last = out[-1]
            if c.hi > last.hi:
                out[-1] = Cut(last.lo, c.hi, c.y_hi)
            continue
        out.append(c)
    return out
