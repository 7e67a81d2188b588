"""Transport load of the belt conveyors of a non-stop book-block trimmer (seed 003, second article:
P. V. Topolnytskyi, transport force and drive-shaft moment; spec knife_drive.md section 1.5 and its table of
published conditions C1-C11).

What the article gives (our copy: abstract, introduction, test conditions, the caption of Fig. 1; no results,
no equations): belt conveyors carry the blocks at a set speed and pitch past stationary knives that trim the
head and the tail of each block at the same time; blocks 5, 10, 18, 36 mm thick, coated paper No. 8 (cut
lengths 220, 320, 450 mm) and offset paper No. 3 (210, 290, 320, 410 mm), speeds 0.5, 1.0, 1.8, 2.7 m/s,
pitch 500 mm, a 1200 mm cutting tool ("no more than three blocks trimmed at once"); Fig. 1 (missing): the
moment on the drive shaft against speed, blocks 320x450x36 (coated) and 320x410x36 mm (offset), cut 320 mm.

The force model here is the toolkit's own (the article's is not in our copy):

* Cutting work.  Trimming an edge of cut length L_c through a block of thickness h opens a cut of area
  h*L_c; it takes the work w*h*L_c, w [J/m2 = N/m] the specific cutting work of the paper stack (the
  knife's edge and the friction on its faces together).  The knife stands still, so all of it is done by
  the conveyor: the transport force is the cutting work per unit of travel.
* Progressive cut.  The blade's edge runs through the block's thickness over a length L_zone of the tool
  (the cutting zone; an inclined edge, the article's tool is 1200 mm long), so a point of the block's edge
  is cut at the rate h/L_zone per unit travel while it is inside the zone.  With blocks of length L_c (the
  cut length lies along the travel) at pitch s, the block k's edge covers [x - k*s - L_c, x - k*s] at
  conveyor travel x, and

      F(x) = F0 + n_knives * w * h / L_zone * sum_k overlap([x - k*s - L_c, x - k*s], [0, L_zone])

  n_knives = 2 (head and tail at once), F0 the conveyor's own resistance (belts, guides; not given).
* Consequences (tested): its mean over a pitch is F0 + n_knives*w*h*L_c/s whatever the zone (energy per
  block over the pitch), and when L_zone is a whole number of pitches it is constant.  It does not depend on
  the speed: the article measured the moment against the speed, but without its data any speed law (rate
  dependence of the cutting work, belt losses, air) would be invented, so none is assumed.
* Drive shaft: moment M = F*r/eta (pulley radius r, efficiency eta; not given), the belt without slip.

Default w = 2.5e4 J/m2 is an order of magnitude, not a measurement: a guillotine's knife force of some 30 kN
over a 0.12 m stroke through a 1.15 m x 0.12 m pile (a common machine rating) gives 2.6e4 J/m2.  The other
defaults are the article's (pitch, tool, knives, the Fig. 1 block) or assumed (r = 0.05 m, eta = 1, F0 = 0).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from . import variants
from .base import Model, ParameterError, Params, param


def overlap(a0, a1, b0: float, b1: float):
    """Length of [a0, a1] inside [b0, b1] (elementwise for arrays)."""
    return np.maximum(0.0, np.minimum(a1, b1) - np.maximum(a0, b0))


def edge_in_zone(x, pitch: float, cut_length: float, zone: float):
    """Sum over the blocks of the length of their edge inside the cutting zone [0, zone] at conveyor travel x
    (block k's leading edge at x - k*pitch, k = 0, 1, ...; elementwise for arrays), and the number of blocks
    with some edge in the zone."""
    x = np.asarray(x, dtype=float)
    k_max = int(math.ceil((zone + cut_length) / pitch)) + 1      # blocks that can reach the zone at once
    first = np.floor(x / pitch)                                  # the last block that entered (k >= 0)
    total = np.zeros_like(x)
    count = np.zeros_like(x)
    for j in range(k_max + 1):
        k = first - j
        lead = x - k * pitch
        part = np.where(k >= 0, overlap(lead - cut_length, lead, 0.0, zone), 0.0)
        total += part
        count += part > 0.0
    return total, count


def edge_slope(x: float, pitch: float, cut_length: float, zone: float) -> float:
    """d edge_in_zone(x)[0] / dx for one travel x: each block's overlap min(lead, zone) - max(lead - cut_length,
    0), where positive, grows with its leading end below the zone's end and shrinks with its trailing end past
    the zone's start (the same blocks as edge_in_zone)."""
    k_max = int(math.ceil((zone + cut_length) / pitch)) + 1
    first = math.floor(x / pitch)
    slope = 0.0
    for j in range(k_max + 1):
        k = first - j
        lead = x - k * pitch
        if k >= 0 and min(lead, zone) - max(lead - cut_length, 0.0) > 0.0:
            slope += (1.0 if lead < zone else 0.0) - (1.0 if lead - cut_length > 0.0 else 0.0)
    return slope


@dataclass(frozen=True)
class ConveyorLoadParams(Params):
    w_cut: float = param(2.5e4, "N/m", "specific cutting work of the paper stack per unit cut area, J/m2 (assumed order)",
                         low=0.0)
    thickness: float = param(0.036, "m", "block thickness h (article: 5, 10, 18, 36 mm)", low=0.0, low_open=True)
    cut_length: float = param(0.32, "m", "cut length of head or tail = block length along the travel (210-450 mm)",
                              low=0.0, low_open=True)
    pitch: float = param(0.5, "m", "block pitch in the trimming section (article: 500 mm)", low=0.0, low_open=True)
    tool_length: float = param(1.2, "m", "length of the cutting tool (article: 1200 mm)", low=0.0, low_open=True)
    zone: float = param(1.2, "m", "length of the tool over which the edge runs through the block (<= tool_length)",
                        low=0.0, low_open=True)
    knives: int = param(2, "", "edges trimmed at once (article: head and tail, 2)", choices=(1, 2))
    F0: float = param(0.0, "N", "the conveyor's own resistance (belts, guides; not given)", low=0.0)
    r_pulley: float = param(0.05, "m", "radius of the belt's drive pulley (assumed)", low=0.0, low_open=True)
    eta: float = param(1.0, "1", "efficiency from the drive shaft to the belts", low=0.0, low_open=True, high=1.0)
    x0: float = param(0.0, "m", "conveyor travel at phi = 0 (the first block's leading edge at the zone's start)")

    def check(self) -> None:
        if self.zone > self.tool_length:
            raise ParameterError("zone", self.zone, f"must be <= tool_length = {self.tool_length} m")
        if self.cut_length >= self.pitch:
            raise ParameterError("cut_length", self.cut_length, f"must be < pitch = {self.pitch} m (blocks apart)")


def transport_force(x, p: ConveyorLoadParams):
    """Transport force [N] at conveyor travel x (the module docstring's F(x)); elementwise for arrays."""
    edge, _ = edge_in_zone(x, p.pitch, p.cut_length, p.zone)
    return p.F0 + p.knives * p.w_cut * p.thickness / p.zone * edge


def mean_force(p: ConveyorLoadParams) -> float:
    """Mean transport force over a pitch: the cutting work of a block over the pitch, plus F0."""
    return p.F0 + p.knives * p.w_cut * p.thickness * p.cut_length / p.pitch


def blocks_per_hour(speed: float, pitch: float) -> float:
    """Blocks trimmed per hour at a transport speed and pitch."""
    return 3600.0 * speed / pitch


class ConveyorLoadModel(Model):
    """Load of the trimming section on the conveyor's drive shaft: port shaft motion IN (phi, w), torque out
    (shaft.tau = -M, resisting forward rotation); the belt travels x = x0 + r*phi."""
    Params = ConveyorLoadParams
    inputs = ("shaft.phi", "shaft.w")
    outputs = ("shaft.tau", "transport_force", "blocks_cut")
    states = ()

    def output(self, t, x, u):
        p = self.p
        travel = p.x0 + p.r_pulley * u[0]
        edge, count = edge_in_zone(travel, p.pitch, p.cut_length, p.zone)
        if self.m.scalar:
            edge, count = float(edge), float(count)
        F = p.F0 + p.knives * p.w_cut * p.thickness / p.zone * edge
        return (-F * p.r_pulley / p.eta, F, count)

    def output_jacobian(self, t, x, u):
        """The transport force grows with the edge length in the zone, whose slope in the travel is the number of
        blocks with exactly one end of their edge inside the zone, +1 for a leading end, -1 for a trailing one
        (edge_slope); the travel is r*phi; nothing depends on the speed."""
        p = self.p
        dF = p.knives * p.w_cut * p.thickness / p.zone * edge_slope(p.x0 + p.r_pulley * u[0], p.pitch,
                                                                    p.cut_length, p.zone) * p.r_pulley
        return np.array([[-dF * p.r_pulley / p.eta, 0.0], [dF, 0.0], [0.0, 0.0]])


class ConveyorLoadBatch(variants.Vectorised):
    """Variants of :class:`ConveyorLoadModel` together: the edge in the zone (its blocks' overlaps) on arrays.  The
    blocks that can reach the zone follow from the pitch, cut length and zone: variants differing in them are
    stepped apart (``key``)."""

    @classmethod
    def key(cls, model):
        p = model.p
        return (p.pitch, p.cut_length, p.zone)

    def output(self, t, X, U, rows=None):
        v = self.v
        p0 = self.models[0].p
        p = v.p
        travel = p.x0 + p.r_pulley * U[0]
        edge, count = edge_in_zone(travel, p0.pitch, p0.cut_length, p0.zone)
        F = p.F0 + p.knives * p.w_cut * p.thickness / p.zone * edge
        return v.m.stack((-F * p.r_pulley / p.eta, F, count))

    def advance(self, t0, h, X, U):
        return X


ConveyorLoadModel.Batch = ConveyorLoadBatch
