"""Press-drive FMUs.

``fmus.physics`` holds the equations (numpy only), ``fmus.slave`` the one base slave class on top of
pythonfmu, ``fmus.components`` one short declaration per FMU.  This package root imports nothing so that
the physics can be used without pythonfmu installed.
"""
