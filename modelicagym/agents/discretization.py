"""Map continuous observations to integer states for tabular agents.

The paper's scheme: every observation variable is cut into ``n_bins`` equal bins over an interval
``[low, high]``, and the two outermost bins are open, so values outside the interval fall into them
instead of being lost. The state index concatenates the bin indices, first variable most
significant; with 10 bins this is exactly the paper's "concatenate the digits" index
(``bins (3, 0, 7, 9) -> state 3079``).

Boundaries: a value equal to an edge belongs to the bin *above* it (``edges[k-1] <= x < edges[k]``
is bin ``k``), as ``numpy.digitize`` does by default.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from gymnasium import spaces

from modelicagym.errors import ArgumentError, ArgumentTypeError, ConfigError

__all__ = ["Discretizer"]

class Discretizer:
    """Equal-width binning of each observation variable with open outermost bins.

    ``intervals[d] = (low, high)`` is split into ``n_bins[d]`` bins; the ``n_bins[d] - 1`` inner
    edges are ``linspace(low, high, n_bins[d] + 1)[1:-1]``. Works on one observation of shape
    ``(d,)`` or a batch of shape ``(n, d)``.
    """

    def __init__(self, intervals: Sequence[Sequence[float]], n_bins: int | Sequence[int] = 10) -> None:
        bounds = np.asarray(intervals, dtype=np.float64)
        if bounds.ndim != 2 or bounds.shape[1] != 2 or bounds.shape[0] == 0:
            raise ConfigError(f"intervals must be a non-empty list of (low, high) pairs, got {intervals!r}")
        if not np.all(np.isfinite(bounds)) or np.any(bounds[:, 0] >= bounds[:, 1]):
            raise ConfigError(f"every interval needs finite low < high, got {bounds.tolist()}")
        counts = np.broadcast_to(np.asarray(n_bins), (bounds.shape[0],)).astype(np.int64)
        if np.any(counts < 1):
            raise ConfigError(f"n_bins must be >= 1, got {n_bins!r}")
        self.lows = bounds[:, 0].copy()
        self.highs = bounds[:, 1].copy()
        self.n_bins = counts.copy()
        self.edges: list[np.ndarray] = [
            np.linspace(low, high, count + 1)[1:-1]
            for low, high, count in zip(self.lows, self.highs, self.n_bins, strict=True)
        ]
        #: edges padded with +inf to a common length, so one broadcast comparison bins all variables
        self.padded_edges = np.full((len(self.edges), max(len(e) for e in self.edges)), np.inf)
        for d, edges in enumerate(self.edges):
            self.padded_edges[d, : len(edges)] = edges
        #: mixed-radix place values of the bins: the first variable is the most significant digit
        self.strides = np.concatenate([np.cumprod(self.n_bins[::-1])[::-1][1:], [1]]).astype(np.int64)
        self.n_states = int(np.prod(self.n_bins))

    @classmethod
    def for_box(
        cls,
        space: spaces.Space,
        n_bins: int | Sequence[int] = 10,
        intervals: Sequence[Sequence[float]] | None = None,
    ) -> Discretizer:
        """Build a discretizer for a flat ``Box`` space, over ``intervals`` or the box's own bounds."""
        if not isinstance(space, spaces.Box) or len(space.shape) != 1:
            raise ArgumentTypeError(f"tabular agents need a 1-D Box observation space, got {space!r}")
        if intervals is None:
            if not (np.all(np.isfinite(space.low)) and np.all(np.isfinite(space.high))):
                raise ConfigError(
                    f"the observation space {space!r} has infinite bounds: give intervals=[(low, high), ...] "
                    "for every variable"
                )
            intervals = np.stack([space.low, space.high], axis=1)
        if len(intervals) != space.shape[0]:
            raise ConfigError(f"{len(intervals)} intervals for an observation of {space.shape[0]} variables")
        return cls(intervals, n_bins)

    @property
    def n_variables(self) -> int:
        """Number of observation variables."""
        return len(self.edges)

    def bins(self, observations: np.ndarray) -> np.ndarray:
        """Bin index of every variable: shape ``(..., d)`` in, same shape of int64 out."""
        obs = np.asarray(observations, dtype=np.float64)
        if obs.shape[-1:] != (self.n_variables,):
            raise ArgumentError(f"expected observations with {self.n_variables} variables, got shape {obs.shape}")
        # The bin index is the number of edges <= x (numpy.digitize's convention), counted at once.
        return (obs[..., None] >= self.padded_edges).sum(axis=-1)

    def states(self, observations: np.ndarray) -> np.ndarray:
        """State index of each observation: shape ``(..., d)`` in, ``(...)`` int64 out."""
        return self.bins(observations) @ self.strides

    def to_dict(self) -> dict[str, np.ndarray]:
        """Arrays that reconstruct this discretizer (see :meth:`from_dict`)."""
        return {"lows": self.lows, "highs": self.highs, "n_bins": self.n_bins}

    @classmethod
    def from_dict(cls, data: dict[str, np.ndarray]) -> Discretizer:
        """Inverse of :meth:`to_dict`."""
        return cls(np.stack([data["lows"], data["highs"]], axis=1), data["n_bins"])
