#!/usr/bin/env python3
"""Build every press-drive FMU: ``python build_fmus.py [--out DIR] [--only NAME ...] [--no-validate]``.

The library behind this command is :mod:`fmus.build`; see its docstring."""
import sys

from fmus.build import main

if __name__ == "__main__":
    sys.exit(main())
