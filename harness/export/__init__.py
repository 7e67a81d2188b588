"""A whole drive as one co-simulation FMU: the export (:mod:`~harness.export.drive_fmu`) and the slave that runs
the drive's master inside the FMU (:mod:`~harness.export.drive_slave` for FMI 2.0, :mod:`~harness.export.drive_slave3`
for FMI 3.0)."""
