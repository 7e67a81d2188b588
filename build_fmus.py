#!/usr/bin/env python3
"""Build every press-drive FMU: ``python build_fmus.py [--fmi-version 2|3] [--model-exchange] [--out DIR]
[--only NAME ...] [--no-validate]`` (FMI 2.0 by default, into build/fmus; FMI 3.0 co-simulation into build/fmus3;
FMI 3.0 model exchange, ``--fmi-version 3 --model-exchange``, into build/fmus3me).

The library behind this command is :mod:`fmus.build`; see its docstring."""
import sys

from fmus.build import main

if __name__ == "__main__":
    sys.exit(main())
