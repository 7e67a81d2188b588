"""Pure equations of the press-drive components (numpy and scipy only; no FMI imports).

Every component module exposes a parameter dataclass (fields carry ``unit`` and ``doc`` metadata) and a
model class with the common interface of :class:`fmus.physics.base.Model`.  The FMU classes, the monolithic
reference of the harness and the tests all call these same functions.
"""
