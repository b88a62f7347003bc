"""Occupancy grids (seed §3.2): log-odds cells updated by Bayes' rule from sonar readings.

Each cell ``C`` holds the log-odds ``l = ln(P[s(C) = occ] / P[s(C) = emp])``
of being occupied; the prior is 0 (p = 0.5). The recursive Bayesian update of
the seed's equation (1), with independent cells and readings that depend only
on the state, becomes a sum in log-odds form::

    l_{t+1}(C) = l_t(C) + ln( p[r_{t+1} | occ] / p[r_{t+1} | emp] )

and the likelihood ratio of one sonar reading is what :class:`SonarModel`
gives (an Elfes-style stochastic sensor model; see its docstring: the
occupied arc's likelihood for one cell depends on the other cells of the
arc, taken at their current estimates, so rings are fused in order, one at
a time). Log-odds
are clamped to ``±SonarModel.clamp`` (10 by default, p = 0.99995) so a cell
can still change its mind, yet entropy can get close to 0.

The update is vectorised: for every beam direction (720 bins of 0.5°) a
*cone template* lists the cells of the cone around the transducer's cell
(flat offsets, sorted by distance) with, for each, a key into two tables
computed once per reading range bin (a quarter cell): the empty cone's
log-odds increments and the arc's weights. Fusing a ring is a slice of a
template per beam (the only Python loop), one gather from the tables and
one ``np.add.at`` into the grid for the empty cones, then the same for the
arcs, with their per-beam sums by ``np.add.reduceat``. The grid is kept in a
buffer padded by the templates' reach, so cones running off the map need no
bounds test (:attr:`OccupancyGrid.log_odds` is a view of the inside); a
transducer that is itself off the map takes a slower, masked path.

Cells use :class:`~atlas_rap.maps.frame.GridFrame`'s convention: row 0 at the
top, ``origin`` the lower-left corner of the lower-left cell.

Over 25 KB on purpose: the occupancy grid: the vectorised Bayesian sonar update (its hot
path), entropy, quality and its file forms, over one array layout.
"""

from __future__ import annotations

import json
import math
import zipfile
from dataclasses import asdict, dataclass
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np

from atlas_rap.errors import MapError
from atlas_rap.maps.frame import GridFrame
from atlas_rap.maps.rosmap import FREE, OCCUPIED, UNKNOWN, RosMap, write_ros_map
from atlas_rap.model import SonarConfig
from atlas_rap.outputs import atomic_write

__all__ = ["OccupancyGrid", "SonarModel", "binary_entropy", "load_grid_arrays"]

ANGLE_BINS = 720  # beam directions per turn for the cone templates (0.5 degree)
PHI_BINS = 8  # bins of |angle off the beam axis| in the increment table


@dataclass(frozen=True, slots=True)
class SonarModel:
    """An Elfes-style stochastic model of one sonar reading, as log-likelihood ratios per cell.

    A reading ``r`` (metres from the transducer on the robot's rim) of a
    beam of width ``beam_width`` (from :class:`SonarConfig`) says, for a cell
    at distance ``rho`` from the transducer and angle ``phi`` off the beam
    axis:

    * **Angular fall-off.** The beam's sensitivity is Gaussian in angle,
      ``w(phi) = exp(-phi^2 / (2 s^2))`` with ``s = angular_sigma *
      beam_width / 2``; cells more than ``cone * beam_width / 2`` off the
      axis are not touched (by default the cone is the beam: ±7.5° for the
      simulated 15° transducers, where w falls to 0.61).
    * **Range error.** ``sigma(r) = sigma0 + sigma_per_m * r`` (default
      0.015 + 0.01 r): the sensor's noise (the simulated sonar's is
      0.01 + 0.01 r) plus a little for the cells' size.
    * **Empty cone before the echo** (``rho <= r - 2 sigma``, fading
      linearly to nothing at ``r - sigma``): had the cell been occupied, the
      beam would have returned an echo from it with probability
      ``detection * w(phi)`` and read shorter; it did not, so the likelihood
      ratio is ``1 - detection * w(phi)`` (0.15 on the axis by default:
      -1.9 in log-odds). ``detection`` is below 1 because smooth walls met
      at a grazing angle reflect the sound away (specular reflection).
    * **Shadows.** Specular reflection is not independent from reading to
      reading: a beam sliding along a wall loses its echo again and again,
      and its empty cone would wear the wall away although head-on readings
      have seen it. So an empty cone stops just past the first cell the
      grid already believes occupied (log-odds above ``shadow``, 0.5 by
      default, p = 0.62): that cell still gets the empty evidence (a
      person who has walked away is forgotten), the cells behind it, in its
      shadow, get none from this beam. ``shadow=None`` turns this off.
    * **Occupied arc at the echo** (``|rho - r| <= arc_sigmas * sigma``):
      the echo came from *some* cell of the arc, cell ``i`` with weight
      ``a_i = w(phi_i) g_i``, ``g = exp(-(rho - r)^2 / (2 sigma^2))``. As in
      Elfes' model the arc is one piece of evidence shared among its cells
      by what the grid already believes: the chance that cell ``i`` made
      the echo is ``q_i = a_i p_i / sum_j a_j (p_j + false_alarm)`` (``p``
      the cells' current P(occ); ``false_alarm`` stands for echoes from
      nothing the map holds: people passing, noise), and the cell's new
      probability is ``p_i + reliability * q_i * (1 - p_i)`` (its
      log-odds increment follows). An echo from an arc the grid knows to be
      empty but for one cell pins that cell at once; an arc of unknown
      cells shares the evidence out thinly until other readings' empty
      cones have said which of them are empty. This keeps walls about a
      cell thick and oblique echoes from painting arcs across free space.
    * **Max-range readings** (``r >= max_range``: no echo, or an echo lost
      to specular reflection) add **no occupied arc** and only an empty cone
      up to ``max_range_fraction * max_range`` (0.3, i.e. 1.5 m for a 5 m
      sonar), with the weaker detection probability ``max_range_detection``
      (0.3): a lost echo may hide a wall anywhere along the beam, so no
      echo at all is weak evidence, and only near the robot.

    ``clamp`` bounds the log-odds (±10, p = 0.99995): far enough for the
    entropy of a well-seen cell to be ~0, near enough to change its mind.
    """

    detection: float = 0.85
    reliability: float = 0.97
    false_alarm: float = 0.01
    sigma0: float = 0.015
    sigma_per_m: float = 0.01
    arc_sigmas: float = 2.5
    angular_sigma: float = 1.0
    cone: float = 1.0
    max_range_fraction: float = 0.3
    max_range_detection: float = 0.3
    shadow: float | None = 0.5
    clamp: float = 10.0

    def __post_init__(self) -> None:
        for name in ("detection", "max_range_detection", "reliability"):
            if not 0.0 <= getattr(self, name) < 1.0:
                raise ValueError(f"SonarModel.{name} must be in [0, 1)")
        if self.false_alarm <= 0:
            raise ValueError("SonarModel.false_alarm must be positive")
        if self.sigma0 <= 0 or self.sigma_per_m < 0 or self.arc_sigmas <= 0:
            raise ValueError("SonarModel needs sigma0 > 0, sigma_per_m >= 0 and arc_sigmas > 0")
        if self.angular_sigma <= 0 or self.cone <= 0:
            raise ValueError("SonarModel needs angular_sigma > 0 and cone > 0")
        if not 0.0 <= self.max_range_fraction <= 1.0:
            raise ValueError("SonarModel.max_range_fraction must be in [0, 1]")
        if self.clamp <= 0:
            raise ValueError("SonarModel.clamp must be positive")

    def sigma(self, r: Any) -> Any:
        """Range error (metres) of a reading ``r``."""
        return self.sigma0 + self.sigma_per_m * r

    def _weight(self, phi: Any, beam_width: float) -> np.ndarray:
        s = self.angular_sigma * beam_width / 2
        return np.exp(-0.5 * (np.asarray(phi, dtype=np.float64) / s) ** 2)

    def free_increments(self, r: float, rho: Any, phi: Any, beam_width: float, max_range: float,
                        echo: bool | None = None) -> np.ndarray:
        """Log-odds increments of the empty cone for cells at distances ``rho``, angles ``phi`` off the axis.

        ``echo`` False means a max-range reading (the default: ``r < max_range``).
        """
        w = self._weight(phi, beam_width)
        rho = np.asarray(rho, dtype=np.float64)
        if echo is None:
            echo = r < max_range
        if not echo:
            return np.where(rho <= self.max_range_fraction * max_range,
                            np.log1p(-self.max_range_detection * w), 0.0)
        sigma = self.sigma(r)
        fade = np.clip((r - rho) / sigma - 1.0, 0.0, 1.0)  # 1 up to r - 2 sigma, 0 from r - sigma
        return np.log1p(-self.detection * w * fade)

    def arc_weights(self, r: float, rho: Any, phi: Any, beam_width: float, max_range: float,
                    echo: bool | None = None) -> np.ndarray:
        """Weights ``a`` of cells on the occupied arc of reading ``r`` (0 off the arc and for max range)."""
        rho = np.asarray(rho, dtype=np.float64)
        if echo is None:
            echo = r < max_range
        if not echo:
            return np.zeros(np.broadcast(rho, np.asarray(phi)).shape)
        sigma = self.sigma(r)
        g = np.exp(-0.5 * ((rho - r) / sigma) ** 2)
        return np.where(np.abs(rho - r) <= self.arc_sigmas * sigma, self._weight(phi, beam_width) * g, 0.0)

    def arc_increments(self, weights: np.ndarray, p: np.ndarray) -> np.ndarray:
        """Log-odds increments of one arc's cells with weights ``weights`` and current P(occ) ``p``."""
        a = np.asarray(weights, dtype=np.float64)
        p = np.asarray(p, dtype=np.float64)
        denominator = float((a * p).sum() + self.false_alarm * a.sum())
        if denominator <= 0:
            return np.zeros_like(a)
        k = self.reliability * a / denominator
        return np.log1p(k * (1.0 - p)) - np.log1p(-k * p)

    def reach(self, max_range: float) -> float:
        """Farthest distance from the transducer a reading can touch."""
        return max(max_range + self.arc_sigmas * self.sigma(max_range), self.max_range_fraction * max_range)


def load_grid_arrays(path: str | Path) -> tuple[np.ndarray, GridFrame]:
    """The occupancy probabilities and frame of a grid file: the levels' ``grid.npz`` or a run's
    ``occupancy.npz``. Anything else (empty, not an archive, arrays missing, of the wrong shape or
    not numbers) raises :class:`~atlas_rap.errors.MapError` naming the file."""
    try:
        with _open_npz(path) as data:
            frame = GridFrame.from_array(data["frame"])
            p_occ = np.asarray(data["p_occ"], dtype=np.float32)
    except (KeyError, TypeError, ValueError) as exc:
        raise MapError(f"{path}: not a grid written by atlas map or atlas run --map-out "
                         f"({str(exc).strip(chr(39))})") from None
    if p_occ.shape != frame.shape:
        raise MapError(f"{path}: not a grid written by atlas map or atlas run --map-out (p_occ has shape "
                         f"{p_occ.shape}, not the frame's {frame.shape})")
    return p_occ, frame


def _open_npz(path: str | Path):
    """``np.load`` of an ``.npz`` archive; every way a file can fail to be one is a ``ValueError``."""
    try:
        data = np.load(Path(path), allow_pickle=False)
    except (EOFError, zipfile.BadZipFile, ValueError):  # ValueError: what numpy would read as a pickle
        raise ValueError("the file is empty or not an .npz archive") from None
    except OSError as exc:
        raise ValueError(f"cannot read it: {exc.strerror or exc}") from None
    if not isinstance(data, np.lib.npyio.NpzFile):
        raise ValueError("it holds one array (.npy), not an .npz archive of a grid")
    return data


def binary_entropy(p: np.ndarray) -> np.ndarray:
    """Entropy in bits of binary variables with P(1) = ``p`` (0 at p = 0 or 1)."""
    p = np.asarray(p, dtype=np.float64)
    q = 1.0 - p
    with np.errstate(divide="ignore", invalid="ignore"):
        h = -(np.where(p > 0, p * np.log2(p), 0.0) + np.where(q > 0, q * np.log2(q), 0.0))
    return h.astype(np.float32)


# -- cone templates ------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class _Templates:
    """Cone templates for one (resolution, padded width, model, beam) combination; see the module docstring."""

    extent: int  # cells from the transducer's cell to the farthest template cell (row or column)
    # every angle bin's template, end to end; each sorted by distance from the transducer
    offsets: np.ndarray  # offset of the cell in the padded buffer (int64)
    rows: np.ndarray  # row and column offsets (int16, for the masked path)
    cols: np.ndarray
    keys: np.ndarray  # rho_bin * PHI_BINS + phi_bin (int32): the cell's column in the tables
    starts: np.ndarray  # (ANGLE_BINS,): where each angle bin's template starts
    cuts: np.ndarray  # (ANGLE_BINS, rho bins + 1): how many cells of the template have rho_bin < i
    free: np.ndarray  # (range bins + 1, rho bins * PHI_BINS) float32 empty-cone increments; last row: max range
    arc: np.ndarray  # the same shape: arc weights
    free_end: np.ndarray  # (range bins + 1,): one past the last rho bin of the empty cone
    arc_start: np.ndarray  # (range bins + 1,): first rho bin of the arc
    arc_end: np.ndarray  # (range bins + 1,): one past its last (arc_start when there is no arc)
    quantum: float  # metres per range / rho bin
    range_bins: int


@lru_cache(maxsize=4)
def _templates(resolution: float, padded_width: int, model: SonarModel, beam_width: float,
               max_range: float) -> _Templates:
    quantum = resolution / 4.0
    reach = model.reach(max_range)
    extent = math.ceil(reach / resolution) + 1
    half_cone = model.cone * beam_width / 2.0
    # every cell of the square around the transducer's cell, but that cell itself: distance and direction
    span = np.arange(-extent, extent + 1)
    dr, dc = (a.ravel() for a in np.meshgrid(span, span, indexing="ij"))
    rho = np.hypot(dr, dc) * resolution
    keep = (rho <= reach) & (rho > 0)
    dr, dc, rho = (np.concatenate([[0], v[keep]]) for v in (dr, dc, rho))  # index 0: the transducer's cell
    angle = np.arctan2(-dr[1:], dc[1:])  # row 0 is the top: world y grows as the row falls
    order = np.argsort(angle, kind="stable")
    angle, order = angle[order], order + 1
    rho_bins = math.ceil(reach / quantum) + 2
    rho_bin = np.minimum(np.rint(rho / quantum).astype(np.int64), rho_bins - 1)
    # the angle-sorted cells three times over, so that a window never wraps
    angle3 = np.concatenate([angle - 2 * np.pi, angle, angle + 2 * np.pi])
    index3 = np.concatenate([order] * 3)
    offsets, rows, cols, keys = [], [], [], []
    cuts = np.zeros((ANGLE_BINS, rho_bins + 1), dtype=np.int64)
    phi_step = half_cone / PHI_BINS
    for a in range(ANGLE_BINS):
        centre = a * 2 * np.pi / ANGLE_BINS
        if centre > np.pi:
            centre -= 2 * np.pi
        lo, hi = np.searchsorted(angle3, [centre - half_cone, centre + half_cone], side="left")
        pick = np.concatenate([[0], index3[lo:hi]])  # the transducer's cell, then the cone's
        phi = np.concatenate([[0.0], np.abs(angle3[lo:hi] - centre)])
        by_rho = np.argsort(rho[pick], kind="stable")
        pick, phi = pick[by_rho], phi[by_rho]
        r_, c_ = dr[pick], dc[pick]
        rows.append(r_.astype(np.int16))
        cols.append(c_.astype(np.int16))
        offsets.append((r_ * padded_width + c_).astype(np.int64))
        phi_bin = np.minimum((phi / phi_step).astype(np.int64), PHI_BINS - 1)
        keys.append((rho_bin[pick] * PHI_BINS + phi_bin).astype(np.int32))
        cuts[a] = np.searchsorted(rho_bin[pick], np.arange(rho_bins + 1), side="left")
    # tables: one row per reading range bin (the last for max range), one column per (rho bin, phi bin)
    range_bins = math.floor(max_range / quantum) + 1
    rho_c = np.repeat(np.arange(rho_bins) * quantum, PHI_BINS)
    phi_c = np.tile((np.arange(PHI_BINS) + 0.5) * phi_step, rho_bins)
    free = np.zeros((range_bins + 1, rho_bins * PHI_BINS), dtype=np.float32)
    arc = np.zeros_like(free)
    free_end = np.zeros(range_bins + 1, dtype=np.int64)
    arc_start = np.zeros(range_bins + 1, dtype=np.int64)
    arc_end = np.zeros(range_bins + 1, dtype=np.int64)
    for k in range(range_bins + 1):
        r, echo = min(k * quantum, max_range), k < range_bins
        free[k] = model.free_increments(r, rho_c, phi_c, beam_width, max_range, echo=echo)
        arc[k] = model.arc_weights(r, rho_c, phi_c, beam_width, max_range, echo=echo)
        used = np.nonzero(free[k].reshape(rho_bins, PHI_BINS).any(axis=1))[0]
        free_end[k] = used[-1] + 1 if used.size else 0
        used = np.nonzero(arc[k].reshape(rho_bins, PHI_BINS).any(axis=1))[0]
        arc_start[k], arc_end[k] = (used[0], used[-1] + 1) if used.size else (0, 0)
    starts = np.concatenate([[0], np.cumsum([len(o) for o in offsets])[:-1]]).astype(np.int64)
    flat = [np.concatenate(arrays) for arrays in (offsets, rows, cols, keys)]
    for arr in flat:
        arr.setflags(write=False)
    return _Templates(extent, *flat, starts, cuts, free, arc, free_end, arc_start, arc_end, quantum, range_bins)


# -- the grid --------------------------------------------------------------------


class OccupancyGrid:
    """Log-odds of occupancy (float32) over the cells of ``frame``; the prior is 0 (p = 0.5).

    ``log_odds`` is a (height, width) array, row 0 at the top; ``updated``
    marks the cells any reading has touched (the default region of
    :meth:`quality`); ``cells_updated`` counts the cell updates made so
    far. ``model`` is the :class:`SonarModel` of :meth:`update_sonar`.
    ``run_qualities`` is the map quality each run that carried the grid
    measured as it began (Layer IV keeps it: ``atlas run --map-in/--map-out``
    carries it in the file), so a run can tell what the one before it added.
    ``driven`` (boolean, the frame's shape) marks the cells the robot's
    centre has passed over, as it believed (:meth:`mark_driven`; Layer IV
    marks them while it maps), in this run and the runs that carried the
    grid: the ways it is known to fit through, whatever the sonar later
    made of them. ``survey`` is None or a second grid of the same frame
    fusing only some of the same rings, those read far enough apart to be
    independent evidence (Layer IV keeps it and measures the map's quality
    on it: :mod:`atlas_rap.maps.survey`); the file carries it too.

    Both arrays are views into buffers with a hidden margin as wide as a
    sonar cone reaches (see the module docstring). They stay the grid's
    arrays unless a sonar reaching further than 5 m is fused, which widens
    the margin: take ``grid.log_odds`` afresh rather than keeping it.
    """

    def __init__(self, frame: GridFrame, model: SonarModel | None = None) -> None:
        self.frame = frame
        self.model = model if model is not None else SonarModel()
        self._margin = 0
        self._buffer = np.zeros(frame.shape, dtype=np.float32)
        self._seen = np.zeros(frame.shape, dtype=bool)
        self._log_odds = self._buffer
        self._updated = self._seen
        self.cells_updated = 0  # cell updates by update_sonar so far (a cell updated twice counts twice)
        self.run_qualities: list[float] = []
        self.driven = np.zeros(frame.shape, dtype=bool)
        self.survey: OccupancyGrid | None = None
        # room for the default sonar's cones; a longer-ranged sonar grows it (and moves the views)
        self._pad(self._required_margin(SonarConfig()))

    @classmethod
    def covering(cls, bounds: tuple[float, float, float, float], resolution: float = 0.05,
                 model: SonarModel | None = None) -> OccupancyGrid:
        """A grid (yaw 0) over (xmin, ymin, xmax, ymax), every cell at the prior."""
        return cls(GridFrame.covering(bounds, resolution), model)

    @classmethod
    def from_ros_map(cls, rosmap: RosMap, model: SonarModel | None = None) -> OccupancyGrid:
        """A grid holding a ROS map's occupancy probabilities; unknown (NaN) cells get the prior.

        The known cells count as updated; probabilities of 0 and 1 become
        the clamp's log-odds.
        """
        grid = cls(rosmap.frame, model)
        grid._set_probabilities(rosmap.occupancy)
        return grid

    def _set_probabilities(self, occupancy: np.ndarray) -> None:
        """Every cell from a probability (NaN: the prior, not updated; 0 and 1: the clamp)."""
        occupancy = np.asarray(occupancy, dtype=np.float64)
        known = ~np.isnan(occupancy)
        p = np.clip(np.where(known, occupancy, 0.5), 1e-12, 1 - 1e-12)
        self.log_odds = np.clip(np.log(p / (1 - p)), -self.model.clamp, self.model.clamp)
        self.updated[...] = known

    # -- the arrays -----------------------------------------------------------

    @property
    def log_odds(self) -> np.ndarray:
        """The cells' log-odds of occupancy, (height, width) float32, row 0 at the top (a view: writable)."""
        return self._log_odds

    @log_odds.setter
    def log_odds(self, values: np.ndarray) -> None:
        values = np.asarray(values, dtype=np.float32)
        if values.shape != self.frame.shape:
            raise ValueError(f"log_odds must have the frame's shape {self.frame.shape}, not {values.shape}")
        self._log_odds[...] = values

    @property
    def updated(self) -> np.ndarray:
        """Boolean (height, width): cells some reading has touched (a view: writable)."""
        return self._updated

    @property
    def shape(self) -> tuple[int, int]:
        return self.frame.shape

    @property
    def resolution(self) -> float:
        return self.frame.resolution

    def _pad(self, margin: int) -> None:
        """Grow the hidden margin around the cells to ``margin`` (cones then never need clipping)."""
        if margin <= self._margin:
            return
        h, w = self.frame.shape
        buffer = np.zeros((h + 2 * margin, w + 2 * margin), dtype=np.float32)
        seen = np.zeros(buffer.shape, dtype=bool)
        inside = (slice(margin, margin + h), slice(margin, margin + w))
        buffer[inside] = self._log_odds
        seen[inside] = self._updated
        self._buffer, self._seen, self._margin = buffer, seen, margin
        self._log_odds, self._updated = buffer[inside], seen[inside]

    # -- Bayes -----------------------------------------------------------------

    def update_sonar(self, x: float, y: float, heading: float, ranges: Any, angles: Any,
                     robot_radius: float, config: SonarConfig) -> int:
        """Fuse one reading or a whole ring taken at robot pose (x, y, heading); return the cell updates made.

        ``ranges`` are metres from the robot's rim (``config.max_range`` =
        no echo), ``angles`` the transducers' body-frame directions (one
        each, or numbers for a single reading). Each beam adds its
        :class:`SonarModel` log-likelihood ratios (equation (1) in log-odds
        form) to the cells of its cone: first the empty cones of all the
        beams, then the occupied arcs, shared out by what the grid then
        believes. The count returned is the number of cell updates (a cell
        in both an empty cone and an arc counts twice).
        """
        ranges = np.atleast_1d(np.asarray(ranges, dtype=np.float64))
        angles = np.atleast_1d(np.asarray(angles, dtype=np.float64))
        if ranges.shape != angles.shape or ranges.ndim != 1:
            raise ValueError("update_sonar needs one angle per range")
        valid = np.isfinite(ranges)
        if not valid.all():
            ranges, angles = ranges[valid], angles[valid]
        if ranges.size == 0:
            return 0
        frame = self.frame
        model = self.model
        self._pad(self._required_margin(config))
        margin, padded_width = self._margin, self._buffer.shape[1]
        tpl = _templates(frame.resolution, padded_width, model, float(config.beam_width), float(config.max_range))

        # -- per beam: the transducer's cell, the template (direction) and the table row (range)
        direction = heading + angles
        ux, uy = np.cos(direction), np.sin(direction)
        sx, sy = x + robot_radius * ux, y + robot_radius * uy  # the transducers, on the rim
        row, col = frame.world_to_cell(sx, sy)
        row, col = np.atleast_1d(row), np.atleast_1d(col)
        angle_bin = np.rint((direction - frame.origin[2]) * (ANGLE_BINS / (2 * np.pi))).astype(np.int64) % ANGLE_BINS
        # The templates put the transducer at its cell's centre: measure the echo from there instead
        # (the range plus how far the transducer is ahead of the centre along the beam).
        cx, cy = frame.cell_to_world(row, col)
        echo_range = ranges + (sx - cx) * ux + (sy - cy) * uy
        range_bin = np.where(ranges >= config.max_range, tpl.range_bins,
                             np.clip(np.rint(echo_range / tpl.quantum), 0, tpl.range_bins - 1)).astype(np.int64)
        free_n = tpl.cuts[angle_bin, tpl.free_end[range_bin]]  # the empty cone: the first free_n cells
        arc_lo = tpl.cuts[angle_bin, tpl.arc_start[range_bin]]  # the arc: cells arc_lo .. arc_hi - 1
        arc_hi = tpl.cuts[angle_bin, tpl.arc_end[range_bin]]
        base = (row + margin) * padded_width + col + margin  # the transducer's cell in the buffer
        key_base = range_bin * tpl.free.shape[1]
        inside = (row >= 0) & (row < frame.height) & (col >= 0) & (col < frame.width)

        buffer = self._buffer.reshape(-1)
        seen = self._seen.reshape(-1)
        total = 0
        # -- the empty cones
        cells, keys, beam = self._gather(tpl, angle_bin, np.zeros_like(free_n), free_n, base, key_base, row, col,
                                         inside)
        if cells.size and model.shadow is not None:  # each cone stops just past its first cell believed occupied
            blocked = np.flatnonzero(buffer[cells] > model.shadow)
            if blocked.size:
                first = np.full(ranges.size, cells.size, dtype=np.int64)
                np.minimum.at(first, beam[blocked], blocked)  # index in `cells` of each beam's first
                keep = np.arange(cells.size) <= first[beam]
                cells, keys = cells[keep], keys[keep]
        if cells.size:
            free = tpl.free.ravel()[keys]
            np.add.at(buffer, cells, free)  # <= 0: clamp below
            buffer[cells] = np.maximum(buffer[cells], -model.clamp)
            seen[cells] = True
            total += cells.size
        # -- the occupied arcs, each shared out among its cells by what the grid now believes
        cells, keys, beam = self._gather(tpl, angle_bin, arc_lo, arc_hi, base, key_base, row, col, inside)
        if cells.size:
            weights = tpl.arc.ravel()[keys].astype(np.float64)
            p = 1.0 / (1.0 + np.exp(-buffer[cells].astype(np.float64)))
            denominator = np.bincount(beam, weights * (p + model.false_alarm), minlength=ranges.size)
            k = model.reliability * weights / np.maximum(denominator[beam], 1e-300)
            np.add.at(buffer, cells, (np.log1p(k * (1.0 - p)) - np.log1p(-k * p)).astype(np.float32))
            buffer[cells] = np.minimum(buffer[cells], model.clamp)  # increments >= 0: clamp above
            seen[cells] = True
            total += cells.size
        self.cells_updated += total
        return total

    def mark_free(self, x: float, y: float, radius: float, p: float = 0.1) -> None:
        """The disc the robot's body covers at (x, y) is free (at most P(occ) = ``p``): the robot
        is standing there. Sonar measures from the rim outwards, so without this the cells
        under the robot would stay unknown where it never saw them from elsewhere."""
        found = self.frame.disc(x, y, radius)
        if found is None:
            return
        window, disc = found
        cap = np.float32(math.log(p / (1 - p)))
        cells = self._log_odds[window]
        cells[disc] = np.minimum(cells[disc], cap)
        self._updated[window] |= disc

    def mark_contact(self, x: float, y: float) -> None:
        """The robot's body touched something at (x, y): the cell there is occupied, as sure as
        the clamp allows (Layer IV marks the bumper's contacts: what the sonar missed, such as
        a door jamb met edge-on)."""
        row, col = self.frame.world_to_cell(x, y)
        if self.frame.contains_cell(row, col):
            self._log_odds[row, col] = self.model.clamp
            self._updated[row, col] = True

    def mark_driven(self, x: float, y: float, radius: float) -> None:
        """The robot's centre passed (x, y): the cells within ``radius`` of it are :attr:`driven`."""
        found = self.frame.disc(x, y, radius)
        if found is not None:
            self.driven[found[0]] |= found[1]

    def doubt_walls(self, x: float, y: float, radius: float, p: float = 0.55,
                    keep: np.ndarray | None = None) -> int:
        """The cells within ``radius`` of (x, y) that the grid believes occupied, but for those
        ``keep`` marks (a mask over the grid: the walls the robot sees from where it is), become
        doubtful: not counted as seen (:attr:`updated` False: unknown to a planner until the sonar
        sees them again), with at most P(occ) = ``p``, a weak memory (an echo from there is still
        explained; a few readings decide). For a robot whose known way has been cut: a wall it
        remembers there, and cannot see from where it is, may have gone. The cells doubted."""
        found = self.frame.disc(x, y, radius)
        if found is None:
            return 0
        window, disc = found
        cap = np.float32(math.log(p / (1 - p)))
        cells = self._log_odds[window]
        walls = disc & (cells > cap)
        if keep is not None:
            walls &= ~keep[window]
        cells[walls] = cap
        self._updated[window] &= ~walls
        return int(walls.sum())

    def _gather(self, tpl: _Templates, angle_bin: np.ndarray, start: np.ndarray, stop: np.ndarray,
                base: np.ndarray, key_base: np.ndarray, row: np.ndarray, col: np.ndarray,
                inside: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Cells start..stop-1 of every beam's template, end to end: (buffer indices, table keys, beam of each).

        No loop: one index array into the templates (each beam's run,
        concatenated). Cells of beams whose transducer is off the map are
        kept only where they are on it.
        """
        lengths = stop - start
        beams = np.flatnonzero(lengths > 0)
        if beams.size == 0:
            empty = np.zeros(0, dtype=np.int64)
            return empty, empty, empty
        counts = lengths[beams]
        ends = np.cumsum(counts)
        first = tpl.starts[angle_bin[beams]] + start[beams]
        index = np.repeat(first - (ends - counts), counts) + np.arange(ends[-1])
        beam = np.repeat(beams, counts)
        cells = tpl.offsets[index] + np.repeat(base[beams], counts)
        keys = tpl.keys[index] + np.repeat(key_base[beams], counts)
        if not inside[beams].all():
            frame, margin = self.frame, self._margin
            rows = tpl.rows[index] + np.repeat(row[beams], counts)
            cols = tpl.cols[index] + np.repeat(col[beams], counts)
            on = (rows >= 0) & (rows < frame.height) & (cols >= 0) & (cols < frame.width)
            cells = (rows[on] + margin) * self._buffer.shape[1] + cols[on] + margin
            keys, beam = keys[on], beam[on]
        return cells, keys, beam

    def _required_margin(self, config: SonarConfig) -> int:
        """Cells of margin the cones of ``config`` need around the grid."""
        return math.ceil(self.model.reach(float(config.max_range)) / self.frame.resolution) + 1

    # -- reading the grid ---------------------------------------------------------

    def probabilities(self) -> np.ndarray:
        """P(occupied) of every cell, float32, row 0 at the top."""
        return (1.0 / (1.0 + np.exp(-self._log_odds))).astype(np.float32)

    def labels(self, occupied: float = 0.65, free: float = 0.35) -> np.ndarray:
        """MAP-style labels (int8): 100 where p > ``occupied``, 0 where p < ``free``, else -1 (unknown)."""
        if not 0.0 <= free <= occupied <= 1.0:
            raise ValueError("labels need 0 <= free <= occupied <= 1")
        p = self.probabilities()
        out = np.full(p.shape, UNKNOWN, dtype=np.int8)
        out[p < free] = FREE
        out[p > occupied] = OCCUPIED
        return out

    def entropy(self) -> np.ndarray:
        """Binary entropy of every cell in bits (float32): 1 at the prior, 0 when certain."""
        return binary_entropy(self.probabilities())

    def quality(self, region: np.ndarray | None = None) -> float:
        """1 - mean entropy over ``region`` (a boolean mask; default: the cells ever updated); 0 when empty."""
        mask = self._updated if region is None else np.asarray(region, dtype=bool)
        if mask.shape != self.frame.shape:
            raise ValueError(f"region must have the grid's shape {self.frame.shape}, not {mask.shape}")
        if not mask.any():
            return 0.0
        return float(1.0 - self.entropy()[mask].mean(dtype=np.float64))

    # -- files -------------------------------------------------------------------

    def save_npz(self, path: str | Path) -> Path:
        """Save the grid to a compressed ``.npz``; return its path (``.npz`` added to a file name
        without it; a device such as ``/dev/null`` is written as it is named).

        Arrays: ``log_odds`` (float32, exact), ``updated`` (bool), ``p_occ``
        (float32 probabilities, for readers that want only those), ``frame``
        = [height, width, resolution, origin x, origin y, origin yaw] (the
        layout of the abstraction levels' ``grid.npz``, so ``atlas map
        render`` draws either), ``model`` (the :class:`SonarModel` as JSON),
        ``run_qualities`` (float64) and ``driven`` (bool), and with a ``survey``
        its ``survey_log_odds`` and ``survey_updated``; an older file without
        the last four loads with none.
        Written whole or not at all (``atlas_rap.outputs``).
        """
        path = Path(path)
        if path.suffix != ".npz" and (path.is_file() or not path.exists()):
            path = path.with_name(path.name + ".npz")
        with atomic_write(path) as stream:
            np.savez_compressed(stream, log_odds=np.ascontiguousarray(self._log_odds),
                                updated=np.ascontiguousarray(self._updated), p_occ=self.probabilities(),
                                frame=self.frame.to_array(),
                                model=np.array(json.dumps(asdict(self.model))),
                                run_qualities=np.array(self.run_qualities, dtype=np.float64),
                                driven=np.ascontiguousarray(self.driven),
                                **({} if self.survey is None else {
                                    "survey_log_odds": np.ascontiguousarray(self.survey.log_odds),
                                    "survey_updated": np.ascontiguousarray(self.survey.updated)}))
        return path

    @classmethod
    def load_npz(cls, path: str | Path) -> OccupancyGrid:
        """A grid saved by :meth:`save_npz`; also any ``.npz`` with ``frame`` and ``p_occ`` (NaN: the prior).

        A file that is not such a grid (empty, not an archive, arrays missing or of
        the wrong shape) raises ``ValueError`` saying what is wrong, before any
        array of the frame's size is made.
        """
        with _open_npz(path) as data:
            try:
                frame = GridFrame.from_array(data["frame"])
                arrays = ("log_odds", "updated") if "log_odds" in data else ("p_occ",)
                arrays += tuple(name for name in ("driven", "survey_log_odds", "survey_updated") if name in data)
                if ("survey_log_odds" in data) != ("survey_updated" in data):
                    raise ValueError("a survey needs both survey_log_odds and survey_updated, and it has one")
                for name in arrays:
                    if data[name].shape != frame.shape:
                        raise ValueError(f"{name} has shape {data[name].shape}, not the frame's {frame.shape}")
                model = SonarModel(**json.loads(str(data["model"]))) if "model" in data else None
                grid = cls(frame, model)
                if "log_odds" in data:
                    grid.log_odds = data["log_odds"]
                    grid.updated[...] = data["updated"]
                else:
                    grid._set_probabilities(data["p_occ"])
                if "driven" in data:
                    grid.driven[...] = data["driven"]
                if "survey_log_odds" in data:
                    grid.survey = cls(frame, model)
                    grid.survey.log_odds = data["survey_log_odds"]
                    grid.survey.updated[...] = data["survey_updated"]
                if "run_qualities" in data:
                    grid.run_qualities = [float(q) for q in np.ravel(data["run_qualities"])]
            except (KeyError, TypeError) as exc:
                raise ValueError(str(exc).strip("'\"")) from None
        return grid

    def to_ros_map(self, path_yaml: str | Path, occupied: float = 0.65, free: float = 0.35,
                   image_format: str = "pgm") -> Path:
        """Write the grid as a ROS map_server map (probabilities) whose labels are :meth:`labels` (occupied, free).

        The image holds each cell's probability in 8 bits (through
        :func:`~atlas_rap.maps.rosmap.write_ros_map`); the YAML's
        ``occupied_thresh`` and ``free_thresh`` are ``occupied`` and ``free``,
        and a probability within a grey level of a threshold is moved by at
        most one level to the side its label says, so any map_server reader
        (nav2's trinary mode, :func:`~atlas_rap.maps.rosmap.load_ros_map`)
        gets exactly ``labels(occupied, free)``. Cells never updated are
        written as p = 0.5 (grey 127), not as the conventional 205: that
        grey reads as free unless ``free`` is at most 0.196. Returns the
        image's path.
        """
        labels = self.labels(occupied, free)
        p = self.probabilities().astype(np.float64)
        # what a reader makes of grey level k: occupancy k / 255, computed as rosmap.classify does
        k = np.arange(256, dtype=np.float64)
        seen = 1.0 - (255.0 - k) / 255.0
        seen_label = np.select([seen > occupied, seen < free], [OCCUPIED, FREE], UNKNOWN)
        level = np.rint(p * 255.0).astype(np.int64)
        for value in (OCCUPIED, FREE, UNKNOWN):
            cells = labels == value
            if not cells.any():
                continue
            allowed = np.flatnonzero(seen_label == value)
            if allowed.size == 0:
                raise ValueError(f"thresholds occupied={occupied} and free={free} leave no grey level "
                                 f"that reads as label {value}")
            wanted = level[cells]
            at = np.clip(np.searchsorted(allowed, wanted), 0, allowed.size - 1)
            below, above = allowed[np.maximum(at - 1, 0)], allowed[at]
            level[cells] = np.where(np.abs(below - wanted) < np.abs(above - wanted), below, above)
        return write_ros_map(path_yaml, level / 255.0, self.frame.resolution, self.frame.origin, image_format,
                             occupied_thresh=occupied, free_thresh=free)

    def __repr__(self) -> str:
        f = self.frame
        return (f"<OccupancyGrid {f.height}x{f.width} at {f.resolution:g} m, "
                f"{int(self._updated.sum())} cells updated>")
