"""FMU declarations, one module per FMU (``pd_<name>.py``, a :class:`fmus.declaration.Component`): unique module
names, so that several FMUs can be loaded into one process.  Importing them needs no exporter (pythonfmu); each
imports its package relatively, so the same file serves the developer's ``fmus`` and the copy an FMU packs."""
