#!/usr/bin/env python
"""Env steps per second per registered id (random actions, one core, resets included).

    python scripts/bench_env.py [--steps 500] [--json]

Same as ``evertgym bench env``.
"""

import sys

from evertgym.cli import main

if __name__ == "__main__":
    sys.exit(main(["bench", "env", *sys.argv[1:]]))
