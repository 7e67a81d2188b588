"""The complete press drives of the seeds (and the two-inertia coupling benchmark), as data.

Each module defines ``SYSTEM = System(...)``: instances (an FMU model name from build_fmus.py and parameter
values with their units in comments and their source in the seeds), power bonds, connections, the default
experiment, and the scenes that may be asked of it.  No stepping code lives here.
"""
