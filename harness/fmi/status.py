"""FMI status codes (the same numbers in FMI 1.0, 2.0 and 3.0) and their log labels."""
from __future__ import annotations

OK, WARNING, DISCARD, ERROR, FATAL, PENDING = range(6)
_LABELS = ("ok", "warning", "discard", "error", "fatal", "pending")
