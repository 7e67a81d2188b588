"""The master's time base: communication times are integer nanoseconds (:data:`NS` per second), so that a
run of n equal steps lands exactly on its stop time and two tools' grids compare bit for bit."""
from __future__ import annotations

NS = 1_000_000_000
