"""A stored frequency-energy curve for the verifier: matched positions and values along it.

Two builds of the same branch store other points along the same curve (the continuation's
steps follow round-off). :class:`Curve` interpolates one build's stored points by local cubics in
the chord length of (ln E, ln f), finds for any point its nearest position on the curve
(:meth:`Curve.match`), interpolates any quantity stored with the points at that position
(:meth:`Curve.values_at`) and bounds the interpolation error by the leave-one-out deviation of
the stored points (:meth:`Curve.leave_one_out`). Method: docs/reproducibility.md.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

__all__ = ["Curve", "CurveError", "DENSE_SPACING", "SAME_POINT"]

DENSE_SPACING = 2e-4  # largest distance between sub-points of the densified curve (first guess of the nearest point)
SAME_POINT = 1e-12  # points closer than this in (ln E, ln f) are one point of a curve
MIN_POINTS = 5  # the leave-one-out cubic needs four other points


class CurveError(ValueError):
    """The stored points do not make a curve that can be compared (too few, not positive, not finite)."""


class Curve:
    """A stored frequency-energy curve in (ln E, ln f), interpolated by local cubics.

    Each segment between stored points i and i+1 is the cubic through points i-1..i+2
    in the chord-length parameter (fewer points at the ends); the curve is densified
    with those cubics and distances are taken to the densified polyline. The
    interpolation error near point j is bounded by the leave-one-out deviation: the
    distance of point j from the cubic through its four neighbours j-2, j-1, j+1, j+2,
    an interpolation over twice the spacing (about 16 times the error of the
    interpolation used, for a smooth curve; large at kinks, as it should be).

    Repeated points (a stage starts at its predecessor's last point; the exact branch stores
    both sides of a grazing transition) are one point of the curve: ``keep`` marks the stored
    points kept, in the order of the file.
    """

    def __init__(self, energy, frequency, step=None):
        energy, frequency = np.asarray(energy, dtype=float), np.asarray(frequency, dtype=float)
        bad = ~(np.isfinite(energy) & np.isfinite(frequency) & (energy > 0) & (frequency > 0))
        if bad.any():
            raise CurveError(
                f"{int(bad.sum())} of {len(energy)} stored points have no positive finite energy and frequency"
            )
        points = np.column_stack([np.log(energy), np.log(frequency)])
        keep = np.ones(len(points), dtype=bool)
        if len(points):
            last = points[0]
            for i in range(1, len(points)):
                keep[i] = np.linalg.norm(points[i] - last) > SAME_POINT
                last = points[i] if keep[i] else last
        self.keep = keep
        self.points = points[keep]
        self.step = None if step is None else np.asarray(step)[keep]
        n = len(self.points)
        if n < MIN_POINTS:
            raise CurveError(f"a curve needs at least {MIN_POINTS} distinct stored points to be compared, got {n}")
        self.s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(self.points, axis=0), axis=1))])
        # leave-one-out: the cubic through the four nearest other points of each point
        window = np.clip(np.arange(n) - 2, 0, n - 5)[:, None] + np.arange(5)
        self._others = np.array([row[row != j] for j, row in enumerate(window)])
        self.interpolation_error = self.leave_one_out(self.points)
        # densified curve: on segment i, the cubic through the four points around it, sub-points
        # no farther apart than DENSE_SPACING, so that the nearest sub-point of a query lies on the
        # right arm where two arms of a branch pass close to each other
        self.nodes = np.clip(np.arange(n - 1) - 1, 0, n - 4)[:, None] + np.arange(4)
        count = np.maximum(4, np.ceil(np.diff(self.s) / DENSE_SPACING)).astype(int)
        owner = np.repeat(np.arange(n - 1), count)
        fractions = np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count)
        a = self.s[owner] + fractions / count[owner] * np.diff(self.s)[owner]
        self.sub_length = np.diff(self.s) / count
        self.dense = np.vstack([self._lagrange(self.nodes[owner], a, self.points), self.points[-1:]])
        self.dense_s = np.concatenate([a, self.s[-1:]])
        self.tree = cKDTree(self.dense)

    def _lagrange(self, nodes: np.ndarray, a: np.ndarray, values: np.ndarray) -> np.ndarray:
        """Values at parameters ``a`` of the polynomials through ``values`` at the stored points ``nodes``
        (one row of nodes per parameter); ``values`` has one row per kept point."""
        s = self.s[nodes]
        weights = np.ones(nodes.shape)
        for k in range(nodes.shape[1]):
            for m in range(nodes.shape[1]):
                if m != k:
                    weights[:, k] *= (a - s[:, m]) / (s[:, k] - s[:, m])
        stacked = values[nodes]
        return np.einsum("ik,ik...->i...", weights, stacked)

    def leave_one_out(self, values: np.ndarray) -> np.ndarray:
        """Deviation of each kept point's ``values`` (one row per kept point) from the cubic through
        its four nearest other points: a bound of the interpolation error there (norm over columns)."""
        values = np.asarray(values, dtype=float)
        deviation = self._lagrange(self._others, self.s, values) - values
        return np.abs(deviation) if deviation.ndim == 1 else np.linalg.norm(deviation, axis=1)

    def segment_error(self, segment: np.ndarray, error: np.ndarray | None = None) -> np.ndarray:
        """Interpolation error bound on the given segments: the largest ``error`` (by default the curve's
        own leave-one-out deviation) of the four points around each."""
        error = self.interpolation_error if error is None else error
        n = len(self.points)
        around = [error[np.clip(segment + d, 0, n - 1)] for d in (-1, 0, 1, 2)]
        return np.max(around, axis=0)

    def values_at(self, values: np.ndarray, parameter: np.ndarray, segment: np.ndarray) -> np.ndarray:
        """``values`` (one row per kept point) interpolated at chord-length ``parameter`` on ``segment``."""
        return self._lagrange(self.nodes[segment], parameter, np.asarray(values, dtype=float))

    def end_length(self, end: int) -> float:
        """Chord length of the continuation step at one end (0: start, -1: end): the last
        stored point of a stopped branch lies at most one step past its stop criterion.

        A step is a run of points with the same ``step`` number (numbers restart in each
        stage; a lone first point is the branch's start); without step numbers, two segments.
        """
        n = len(self.points)
        if self.step is None or not len(self.step):
            first, last = (0, 2) if end == 0 else (n - 3, n - 1)
        else:
            change = np.flatnonzero(np.diff(self.step) != 0)  # last point of each run but the final one
            if end == 0:
                last = n - 1 if not len(change) else (change[1] if change[0] == 0 and len(change) > 1 else change[0])
                first = 0
            else:
                first, last = (change[-1] if len(change) else 0), n - 1
        first, last = max(first, 0), min(last, n - 1)
        return float(self.s[last] - self.s[first])

    def match(self, queries: np.ndarray):
        """Nearest positions on the curve of points (ln E, ln f).

        Returns the distance, the segment, whether the nearest location is an end of the curve
        (then the point may lie beyond it) and the chord-length parameter there. The nearest
        sub-segment of the densified curve gives a first parameter; the distance to the cubic of
        that segment is then minimised by a shrinking search on the parameter (the densified
        polyline alone would add its own chord error)."""
        queries = np.atleast_2d(np.asarray(queries, dtype=float))
        _, nearest = self.tree.query(queries, k=min(8, len(self.dense)))
        nearest = np.atleast_2d(nearest)
        best = np.full(len(queries), np.inf)
        at_end = np.zeros(len(queries), dtype=bool)
        parameter = np.zeros(len(queries))
        last = len(self.dense) - 1
        for column in nearest.T:
            for lo in (column - 1, column):
                lo = np.clip(lo, 0, last - 1)
                a, b = self.dense[lo], self.dense[lo + 1]
                ab = b - a
                length2 = np.maximum((ab * ab).sum(axis=1), 1e-300)
                t = np.clip(((queries - a) * ab).sum(axis=1) / length2, 0.0, 1.0)
                d = np.linalg.norm(a + t[:, None] * ab - queries, axis=1)
                better = d < best
                best[better] = d[better]
                parameter[better] = (self.dense_s[lo] + t * (self.dense_s[lo + 1] - self.dense_s[lo]))[better]
                at_end[better] = ((lo[better] == 0) & (t[better] == 0)) | ((lo[better] == last - 1) & (t[better] == 1))
        segment = np.clip(np.searchsorted(self.s, parameter, side="right") - 1, 0, len(self.s) - 2)
        nodes = self.nodes[segment]
        width = self.sub_length[segment].copy()
        offsets = np.linspace(-1.0, 1.0, 5)
        for _ in range(40):
            trial = np.clip(parameter[:, None] + width[:, None] * offsets, self.s[0], self.s[-1])
            values = self._lagrange(np.repeat(nodes, 5, axis=0), trial.ravel(), self.points).reshape(len(queries), 5, 2)
            d = np.linalg.norm(values - queries[:, None, :], axis=2)
            choice = np.argmin(d, axis=1)
            parameter = trial[np.arange(len(queries)), choice]
            best = np.minimum(best, d.min(axis=1))
            width /= 2
        segment = np.clip(np.searchsorted(self.s, parameter, side="right") - 1, 0, len(self.s) - 2)
        return best, segment, at_end, parameter

    def distance(self, queries: np.ndarray):
        """Distance of points (ln E, ln f) to the curve, the segment and whether at an end (see :meth:`match`)."""
        d, segment, at_end, _ = self.match(queries)
        return d, segment, at_end
