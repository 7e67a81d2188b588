"""FMU declarations, one module per FMU (``pd_<name>.py``: unique module names, so that several of them
can be loaded into one process).  Importing this package needs pythonfmu; the physics does not."""
